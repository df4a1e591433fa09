"""OCC faces from plane shapes, placed in a cross-section plane x = const.

Shapes are drawn in Gmsh's x–y plane with (u, v) = (y, z) and then turned into the y–z
plane by the rotation of 120° about (1, 1, 1), which maps x → y, y → z, z → x: one
rigid motion for every shape, so circles stay single closed curves (``addCircle`` only
draws in the x–y plane in Gmsh 4.8). Needs an initialized Gmsh.
"""
from __future__ import annotations

import math
from functools import singledispatch

import gmsh

from geometry.shapes import Circle, Polygon, Sector

DimTags = list[tuple[int, int]]


@singledispatch
def add_wire(shape) -> int:
    """A closed curve loop around ``shape``; returns its tag."""
    raise TypeError(f"no OCC wire for {type(shape).__name__}")


@add_wire.register
def _(shape: Polygon) -> int:
    occ = gmsh.model.occ
    points = [occ.addPoint(y, z, 0.0) for y, z in shape.vertices]
    lines = [occ.addLine(a, b) for a, b in zip(points, points[1:] + points[:1])]
    return occ.addCurveLoop(lines)


@add_wire.register
def _(shape: Circle) -> int:
    occ = gmsh.model.occ
    return occ.addCurveLoop([occ.addCircle(*shape.centre, 0.0, shape.radius)])


@add_wire.register
def _(shape: Sector) -> int:
    occ = gmsh.model.occ
    centre = occ.addPoint(0.0, 0.0, 0.0)
    start = occ.addPoint(*shape.point(shape.start), 0.0)
    stop = occ.addPoint(*shape.point(shape.stop), 0.0)
    return occ.addCurveLoop([occ.addLine(centre, start), occ.addCircleArc(start, centre, stop),
                             occ.addLine(stop, centre)])


def add_face(outer, hole=None) -> int:
    """A plane face bounded by ``outer``, minus ``hole``; returns its tag (x–y plane)."""
    wires = [add_wire(outer)] + ([add_wire(hole)] if hole is not None else [])
    return gmsh.model.occ.addPlaneSurface(wires)


def to_section_plane(dimtags: DimTags, x: float) -> None:
    """Move entities drawn in the x–y plane with (u, v) = (y, z) into the plane at ``x``."""
    occ = gmsh.model.occ
    occ.rotate(dimtags, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0 * math.pi / 3.0)
    if x:
        occ.translate(dimtags, x, 0.0, 0.0)


def extrude_along_x(dimtags: DimTags, length: float) -> list[int]:
    """Extrude section faces by ``length`` along +x; returns the new volume tags."""
    return [tag for dim, tag in gmsh.model.occ.extrude(dimtags, length, 0.0, 0.0) if dim == 3]
