"""The largest extent of a body (the edge of its bounding box), before Gmsh runs: the scale its
tolerances, default sizes and model unit are taken from. Pure Python."""
from __future__ import annotations

from geometry import conrod_layout
from geometry.crank_layout import crank_layout
from geometry.params import BeamParams, ConrodParams, Geometry


def largest_extent(geom: Geometry) -> float:
    """The largest edge of the body's bounding box (m)."""
    if isinstance(geom, BeamParams):
        return max(geom.length, *geom.profile().outer.extent)
    if isinstance(geom, ConrodParams):
        return conrod_layout.largest_extent(geom)
    return crank_layout(geom).largest_extent
