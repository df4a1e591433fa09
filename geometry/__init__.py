"""Parametric Gmsh geometries of the study: straight beams of ten cross-sections and crankshafts.

``parse_geometry`` and ``parse_mesh`` validate the ``[geometry]`` and ``[mesh]`` tables
into frozen dataclasses (pure Python, no Gmsh); ``build_msh`` builds the OCC model,
meshes it and writes a ``.msh`` file that ``dolfinx.io.gmshio`` reads, returning a
:class:`MeshInfo`. Gmsh itself is loaded only when ``build_msh`` or ``MeshInfo`` is first
used, so reading a configuration stays light.

Modules: ``shapes`` and ``polygon`` (plane shapes and polygon checks), ``sections`` (the
beam sections), ``crank_layout`` (where a crankshaft's parts go), ``features`` (smallest
features against the kernel and the mesh size), ``params`` (the config tables), ``groups``
(physical group names and tags), ``body`` (what a builder returns), ``estimate`` (cells
and nodes before meshing), ``element_order`` (the P1 stiffness warning); with Gmsh:
``occ_shapes``, ``faces``, ``beam``, ``crankshaft`` and ``meshing``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from geometry.element_order import element_order_warning
from geometry.estimate import MeshEstimate, estimate_mesh
from geometry.params import BeamParams, CrankshaftParams, MeshParams, parse_geometry, parse_mesh
from geometry.sections import SECTIONS

if TYPE_CHECKING:
    from geometry.meshing import MeshInfo, build_msh

__all__ = ["BeamParams", "CrankshaftParams", "MeshEstimate", "MeshInfo", "MeshParams", "SECTIONS",
           "build_msh", "element_order_warning", "estimate_mesh", "parse_geometry", "parse_mesh",
           "section_area"]


def section_area(params: BeamParams) -> float:
    """The exact cross-section area (m²) from the parameters: shoelace or πr²."""
    return params.profile().area


def __getattr__(name: str) -> Any:  # PEP 562: import Gmsh on first use only
    if name in ("MeshInfo", "build_msh"):
        from geometry import meshing
        return getattr(meshing, name)
    raise AttributeError(f"module 'geometry' has no attribute {name!r}")
