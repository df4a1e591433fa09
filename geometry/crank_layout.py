"""Where the parts of a crankshaft go: the round parts along the axis and the webs' outlines.

Along x from 0: [nose], journal_0, web, pin_0, web, journal_1, …, pin_{N-1}, web,
journal_N, [flange]. Crank pin i is centred at radius stroke/2 and polar angle
crank_angles_deg[i] (from +y towards +z). A web is a plate of ``web_thickness`` whose
outline is the stadium (convex hull) of two discs of diameter ``web_width``, one on the
main axis and one on the pin axis, plus, with counterweights, a circular sector opposite
the pin reaching as far out as the web's pin end. The nose and the flange have no keys
of their own: their sizes are fixed fractions of the journal diameter (below), chosen
like a passenger-car crankshaft's pulley snout and flywheel flange.

Pure Python: the extent of the body is known before Gmsh runs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from geometry import groups
from geometry.shapes import Circle, Point, Polygon, Sector, Shape

if TYPE_CHECKING:
    from geometry.params import CrankshaftParams

NOSE_DIAMETER = 0.6  # × journal_diameter
NOSE_LENGTH = 0.8  # × journal_diameter
FLANGE_DIAMETER = 1.7  # × journal_diameter
FLANGE_LENGTH = 0.25  # × journal_diameter
COUNTERWEIGHT_HALF_ANGLE = math.radians(75.0)  # the sector spans ±75° opposite the pin


@dataclass(frozen=True)
class RoundPart:
    """A cylinder parallel to x: the nose, a main journal, a crank pin or the flange."""

    name: str
    x0: float
    length: float
    radius: float
    centre: Point = (0.0, 0.0)

    @property
    def x1(self) -> float:
        return self.x0 + self.length


@dataclass(frozen=True)
class Web:
    """A crank web from x0 to x0 + thickness, its outline as a union of plane shapes."""

    x0: float
    thickness: float
    shapes: tuple[Shape, ...]


@dataclass(frozen=True)
class CrankLayout:
    parts: tuple[RoundPart, ...]
    webs: tuple[Web, ...]
    length: float
    swing_radius: float  # the farthest any web or counterweight reaches from the axis

    @property
    def width(self) -> float:
        """The widest the body reaches across the axis: twice the swing radius or the
        flange's diameter (an upper bound of its bounding box's edges along y and z)."""
        flange = max((p.radius for p in self.parts if p.name == "flange"), default=0.0)
        return max(2.0 * self.swing_radius, 2.0 * flange)

    @property
    def largest_extent(self) -> float:
        """The largest edge of the body's bounding box."""
        return max(self.length, self.width)


def crank_layout(p: CrankshaftParams) -> CrankLayout:
    """Place every part of the crankshaft ``p`` along the x axis."""
    parts: list[RoundPart] = []
    webs: list[Web] = []
    x = 0.0

    def add(name: str, length: float, radius: float, centre: Point = (0.0, 0.0)) -> None:
        nonlocal x
        parts.append(RoundPart(name, x, length, radius, centre))
        x += length

    def add_web(angle: float) -> None:
        nonlocal x
        webs.append(Web(x, p.web_thickness, web_outline(p, angle)))
        x += p.web_thickness

    if p.nose:
        add("nose", NOSE_LENGTH * p.journal_diameter, NOSE_DIAMETER * p.journal_diameter / 2)
    for i, angle_deg in enumerate(p.crank_angles_deg):
        angle = math.radians(angle_deg)
        add(groups.journal(i), p.journal_length, p.journal_diameter / 2)
        add_web(angle)
        add(groups.pin(i), p.pin_length, p.pin_diameter / 2, _pin_centre(p, angle))
        add_web(angle)
    add(groups.journal(p.throws), p.journal_length, p.journal_diameter / 2)
    if p.flange:
        add("flange", FLANGE_LENGTH * p.journal_diameter, FLANGE_DIAMETER * p.journal_diameter / 2)
    return CrankLayout(tuple(parts), tuple(webs), x, (p.stroke + p.web_width) / 2)


def _pin_centre(p: CrankshaftParams, angle: float) -> Point:
    return (p.stroke / 2 * math.cos(angle), p.stroke / 2 * math.sin(angle))


def web_outline(p: CrankshaftParams, angle: float) -> tuple[Shape, ...]:
    """The web for a pin at polar ``angle`` (radians): two discs of radius web_width/2 on
    the main and pin axes, the rectangle joining their tangent points, and optionally the
    counterweight sector of radius (stroke + web_width)/2 centred on angle + π."""
    half = p.web_width / 2
    py, pz = _pin_centre(p, angle)
    ny, nz = -math.sin(angle) * half, math.cos(angle) * half  # normal to the crank arm
    shapes: list[Shape] = [
        Circle(half), Circle(half, (py, pz)),
        Polygon(((ny, nz), (-ny, -nz), (py - ny, pz - nz), (py + ny, pz + nz))),
    ]
    if p.counterweights:
        opposite = angle + math.pi
        shapes.append(Sector((p.stroke + p.web_width) / 2, opposite - COUNTERWEIGHT_HALF_ANGLE,
                             opposite + COUNTERWEIGHT_HALF_ANGLE))
    return tuple(shapes)


def web_area_and_perimeter(p: CrankshaftParams) -> tuple[float, float]:
    """The area and perimeter of a web's outline: a stadium of radius R = web_width/2 whose
    centres are d = stroke/2 apart (πR² + 2Rd, 2πR + 2d), plus with counterweights the ring
    sector between R and R + d over the sector's opening θ (θ/2 · ((R + d)² − R²); its
    outline replaces an arc θR by θ(R + d) and two radial edges of length d)."""
    radius, d = p.web_width / 2, p.stroke / 2
    area, perimeter = math.pi * radius**2 + 2 * radius * d, 2 * math.pi * radius + 2 * d
    if p.counterweights:
        opening = 2 * COUNTERWEIGHT_HALF_ANGLE
        area += opening / 2 * ((radius + d) ** 2 - radius**2)
        perimeter += opening * d + 2 * d
    return area, perimeter
