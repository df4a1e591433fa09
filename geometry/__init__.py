"""Parametric Gmsh geometries of the study: straight beams of ten cross-sections, crankshafts
and connecting rods (two eyes with their bores, an I-section shank; groups on both bores).

Independent of ``gcms_fenicsx``: the configuration layer reads the ``[geometry]`` and
``[mesh]`` tables into the parameter types of ``params`` and runs the checks here, whose
``errors.GeometryError`` names the key, value and what is allowed. ``build_msh`` builds the
OCC model, meshes it and writes a ``.msh`` file that ``dolfinx.io.gmshio`` reads, returning
a :class:`MeshInfo`; ``python -m geometry build`` does it in a process of its own. Gmsh is
loaded only when ``build_msh`` is first used.

Modules, pure Python: ``shapes`` and ``polygon`` (plane shapes and polygon checks),
``sections`` (the beam sections), ``crank_layout`` (where a crankshaft's parts go),
``conrod_layout`` (a connecting rod's eyes and shank, and which of its lengths fit),
``params`` (the parameter types and their defaults), ``extent`` (a body's largest extent),
``features`` (smallest features against the kernel and the mesh size), ``groups``
(physical group names and tags), ``estimate`` (cells and nodes before meshing),
``element_order`` (the P1 stiffness warning), ``errors``; with Gmsh: ``solid`` (what a
builder returns), ``occ_shapes``, ``faces``, ``beam``, ``crankshaft``, ``conrod`` and
``meshing``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from geometry.element_order import element_order_warning
from geometry.estimate import MeshEstimate, estimate_mesh
from geometry.params import BeamParams, ConrodParams, CrankshaftParams, MeshParams
from geometry.sections import SECTIONS

from geometry.info import MeshInfo

if TYPE_CHECKING:
    from geometry.meshing import build_msh

__all__ = ["BeamParams", "ConrodParams", "CrankshaftParams", "MeshEstimate", "MeshInfo", "MeshParams", "SECTIONS",
           "build_msh", "element_order_warning", "estimate_mesh", "section_area"]


def section_area(params: BeamParams) -> float:
    """The exact cross-section area (m²) from the parameters: shoelace or πr²."""
    return params.profile().area


def __getattr__(name: str) -> Any:  # PEP 562: import Gmsh on first use only
    if name == "build_msh":
        from geometry import meshing
        return getattr(meshing, name)
    raise AttributeError(f"module 'geometry' has no attribute {name!r}")
