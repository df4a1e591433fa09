"""Will P1 tetrahedra be too stiff? A warning predicted from the parameters, before meshing.

Linear tetrahedra cannot bend inside an element, so a mesh of order 1 is stiffer than the
body in bending. Measured (docs/element_order.md: free-free steel beams of square,
rectangular and round sections with L/h from 2 to 100 against Timoshenko or a P2 mesh, and
crankshafts against P2), the relative error of the first bending frequency is set by the
number of elements across the section, not by the slenderness (a fitted (L/h)^a gave
a = −0.015):

    beams:        e ≈ 1.22 (s/h)^1.87   (within 0.86–1.09 of 26 measurements, e ≤ 10 %)
    crankshafts:  e ≈ 0.91 (s/t)^1.76   (within 0.89–1.11 of 9, e ≤ 19 %)

A connecting rod is read as a beam of its shank's I-section (not measured: its first modes
bend the shank).

h is the section's bending depth √(12 I_min/A), t the web thickness, s the element size
Gmsh will use there (``[mesh] size``, capped by Gmsh's own cap and, on a round section or
web, by the curvature size; ``geometry.estimate``). The warning recommends order = 2 when
the prediction exceeds WARNING_THRESHOLD. Pure Python.
"""
from __future__ import annotations

from dataclasses import dataclass

from geometry.estimate import beam_volume_size, curvature_size, effective_size
from geometry.conrod_layout import shank_profile
from geometry.params import BeamParams, ConrodParams, Geometry, MeshParams

#: A predicted first-bending-frequency error above this recommends order = 2.
WARNING_THRESHOLD = 0.05


@dataclass(frozen=True)
class P1Law:
    """e = coefficient · (s/h)^exponent: the P1 error at s elements across a depth h."""

    coefficient: float
    exponent: float

    def error(self, ratio: float) -> float:
        return self.coefficient * ratio**self.exponent

    def ratio_for(self, error: float) -> float:
        """The s/h at which the predicted error is ``error``."""
        return (error / self.coefficient) ** (1.0 / self.exponent)


BEAM_LAW = P1Law(coefficient=1.22, exponent=1.87)
CRANK_LAW = P1Law(coefficient=0.91, exponent=1.76)


@dataclass(frozen=True)
class Resolution:
    """What the prediction reads: the law, the element size s and the depth h it spans."""

    law: P1Law
    size: float
    depth: float
    what: str  # for messages: "the section's bending depth √(12 I/A)"

    @property
    def error(self) -> float:
        return self.law.error(self.size / self.depth)


def resolution(geom: Geometry, mesh: MeshParams) -> Resolution:
    """The element size across the part that bends, and that part's depth."""
    size = effective_size(geom, mesh.size)
    if isinstance(geom, BeamParams):
        return Resolution(BEAM_LAW, beam_volume_size(geom, size), geom.profile().bending_depth,
                          "the section's bending depth √(12 I/A)")
    if isinstance(geom, ConrodParams):
        return Resolution(BEAM_LAW, size, shank_profile(geom).bending_depth,
                          "the shank's bending depth √(12 I/A)")
    return Resolution(CRANK_LAW, curvature_size(geom.web_width / 2.0, size), geom.web_thickness,
                      "web_thickness")


def p1_frequency_error(geom: Geometry, mesh: MeshParams) -> float:
    """The predicted relative error (too high) of the first bending frequency of ``geom``
    meshed with P1 tetrahedra as ``mesh`` says (its order aside)."""
    return resolution(geom, mesh).error


def element_order_warning(geom: Geometry, mesh: MeshParams) -> str | None:
    """A one-line warning recommending order = 2 when ``mesh`` is of order 1 and the
    predicted P1 error exceeds WARNING_THRESHOLD; None otherwise."""
    if mesh.order != 1:
        return None
    r = resolution(geom, mesh)
    if r.error <= WARNING_THRESHOLD:
        return None
    finer = r.law.ratio_for(WARNING_THRESHOLD) * r.depth
    return (f"[mesh] order = 1: P1 elements of {r.size:.3g} m across {r.what} = "
            f"{r.depth:.3g} m make the first bending frequency about {r.error:.0%} too high "
            f"(predicted, docs/element_order.md; warned above {WARNING_THRESHOLD:.0%}): use "
            f"order = 2, or [mesh] size <= {finer:.2g} m")
