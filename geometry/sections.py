"""The beam cross-sections: the keys each one reads, its outline, and whether it can exist.

A section is a :class:`Profile` in the y–z plane, an outer shape with at most one hole,
moved so that its centroid lies on the beam axis. Straight-edged sections (square,
rectangle, I, T, C, L, polygon) are one :class:`~geometry.shapes.Polygon` each, so they
share one code path into Gmsh; round ones are circles; the hollow ones (tube, box) are
an outer shape minus an inner one. Pure Python: checked before Gmsh runs.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from geometry.polygon import polygon_defect
from geometry.shapes import Circle, Point, Polygon, turn

#: Section names accepted by ``[geometry] section``.
SECTIONS = ("square", "rectangle", "circle", "tube", "box", "I", "T", "C", "L", "polygon")

_FLANGED_KEYS = ("width", "height", "flange_thickness", "web_thickness")

#: The keys each section reads (all required; lengths in metres, polygon vertices as [y, z]).
SECTION_KEYS: dict[str, tuple[str, ...]] = {
    "square": ("side",),
    "rectangle": ("width", "height"),
    "circle": ("radius",),
    "tube": ("radius", "thickness"),
    "box": ("width", "height", "thickness"),
    "I": _FLANGED_KEYS,
    "T": _FLANGED_KEYS,
    "C": _FLANGED_KEYS,
    "L": ("width", "height", "thickness"),
    "polygon": ("vertices",),
}

Dimensions = Mapping[str, Any]  # a section's keys → values (floats; a vertex tuple for polygon)


@dataclass(frozen=True)
class Profile:
    """A cross-section: an outer boundary with at most one hole inside it."""

    outer: Circle | Polygon
    hole: Circle | Polygon | None = None

    @property
    def area(self) -> float:
        return self.outer.area - (self.hole.area if self.hole else 0.0)

    @property
    def centroid(self) -> Point:
        """Composite centroid: first moments of the outer shape minus those of the hole."""
        (oy, oz), a = self.outer.centroid, self.outer.area
        if self.hole is None:
            return (oy, oz)
        (hy, hz), b = self.hole.centroid, self.hole.area
        return ((a * oy - b * hy) / (a - b), (a * oz - b * hz) / (a - b))

    @property
    def perimeter(self) -> float:
        return self.outer.perimeter + (self.hole.perimeter if self.hole else 0.0)

    @property
    def feature_size(self) -> float:
        """2A/P, half the hydraulic diameter: the wall thickness of a thin-walled section,
        half the side of a square, the radius of a circle."""
        return 2.0 * self.area / self.perimeter

    @property
    def least_second_moment(self) -> float:
        """The smallest principal second moment of area about the centroid (m⁴): the
        bending stiffness per E about the weakest axis."""
        (oyy, ozz, oyz), (cy, cz), a = self.outer.second_moments, self.centroid, self.area
        hyy, hzz, hyz = self.hole.second_moments if self.hole else (0.0, 0.0, 0.0)
        yy, zz, yz = oyy - hyy - a * cy * cy, ozz - hzz - a * cz * cz, oyz - hyz - a * cy * cz
        return (yy + zz) / 2.0 - math.hypot((yy - zz) / 2.0, yz)

    @property
    def bending_depth(self) -> float:
        """√(12 I_min/A): the depth of the rectangle with the same radius of gyration about
        the weakest axis (the height of a rectangle bent across it, 0.87 d for a circle)."""
        return math.sqrt(12.0 * self.least_second_moment / self.area)

    def centred(self) -> Profile:
        """The same profile moved so that its centroid is at the origin."""
        cy, cz = self.centroid
        return Profile(self.outer.shifted(-cy, -cz),
                       self.hole.shifted(-cy, -cz) if self.hole else None)


def section_profile(section: str, dims: Dimensions) -> Profile:
    """The profile of a section with its centroid at the origin."""
    return _OUTLINES[section](dims).centred()


def section_violation(section: str, dims: Dimensions) -> tuple[str, str] | None:
    """The first constraint between a section's dimensions that they break, as
    (offending key, what is allowed), or None when the section can be built."""
    return next((v for v in _CHECKS.get(section, lambda d: [])(dims) if v), None)


def _rectangle(width: float, height: float) -> Polygon:
    w, h = width / 2.0, height / 2.0
    return Polygon(((-w, -h), (w, -h), (w, h), (-w, h)))


def _flanged(d: Dimensions, *, centred_web: bool, bottom_flange: bool) -> Polygon:
    """I, T and C: a top flange (width × flange_thickness), a web (web_thickness wide,
    centred or at the left edge y = 0) down to z = 0, and optionally a bottom flange.
    Traced counter-clockwise from the web's lower left corner."""
    b, h, tf = d["width"], d["height"], d["flange_thickness"]
    a = (b - d["web_thickness"]) / 2.0 if centred_web else 0.0
    c = a + d["web_thickness"]
    bottom = ([(a, tf), (0.0, tf), (0.0, 0.0), (b, 0.0), (b, tf), (c, tf)] if bottom_flange
              else [(a, 0.0), (c, 0.0)])
    top = [(c, h - tf), (b, h - tf), (b, h), (0.0, h), (0.0, h - tf), (a, h - tf)]
    return Polygon(_corners(bottom + top))


def _corners(points: list[Point]) -> tuple[Point, ...]:
    """Drop repeated points and points lying straight between their neighbours (a web
    flush with the flanges' edge, as in the C section, makes both)."""
    distinct = [p for i, p in enumerate(points) if p != points[i - 1]]
    n = len(distinct)
    return tuple(p for i, p in enumerate(distinct)
                 if turn(distinct[i - 1], p, distinct[(i + 1) % n]) != 0.0)


_OUTLINES: dict[str, Callable[[Dimensions], Profile]] = {
    "square": lambda d: Profile(_rectangle(d["side"], d["side"])),
    "rectangle": lambda d: Profile(_rectangle(d["width"], d["height"])),
    "circle": lambda d: Profile(Circle(d["radius"])),
    "tube": lambda d: Profile(Circle(d["radius"]), Circle(d["radius"] - d["thickness"])),
    "box": lambda d: Profile(_rectangle(d["width"], d["height"]),
                             _rectangle(d["width"] - 2 * d["thickness"],
                                        d["height"] - 2 * d["thickness"])),
    "I": lambda d: Profile(_flanged(d, centred_web=True, bottom_flange=True)),
    "T": lambda d: Profile(_flanged(d, centred_web=True, bottom_flange=False)),
    "C": lambda d: Profile(_flanged(d, centred_web=False, bottom_flange=True)),
    "L": lambda d: Profile(Polygon(((0.0, 0.0), (d["width"], 0.0), (d["width"], d["thickness"]),
                                    (d["thickness"], d["thickness"]), (d["thickness"], d["height"]),
                                    (0.0, d["height"])))),
    "polygon": lambda d: Profile(Polygon(d["vertices"])),
}


def _below(d: Dimensions, key: str, limit: float, limit_name: str,
           why: str) -> tuple[str, str] | None:
    if d[key] < limit:
        return None
    return key, f"must be < {limit_name} = {limit:g} ({why})"


def _flanged_checks(d: Dimensions, flanges: int) -> list[tuple[str, str] | None]:
    limit_name = "height" if flanges == 1 else "height/2"
    return [_below(d, "flange_thickness", d["height"] / flanges, limit_name,
                   "the flanges would fill the whole height"),
            _below(d, "web_thickness", d["width"], "width",
                   "the web would be as wide as the flanges")]


def _polygon_check(d: Dimensions) -> list[tuple[str, str] | None]:
    defect = polygon_defect(d["vertices"])
    return [("vertices", f"must be a simple polygon of [y, z] points, but {defect}")
            if defect else None]


_CHECKS: dict[str, Callable[[Dimensions], list[tuple[str, str] | None]]] = {
    "tube": lambda d: [_below(d, "thickness", d["radius"], "radius",
                              "the inner radius radius - thickness must stay > 0")],
    "box": lambda d: [_below(d, "thickness", min(d["width"], d["height"]) / 2,
                             "min(width, height)/2", "the walls would fill the box")],
    "I": lambda d: _flanged_checks(d, flanges=2),
    "T": lambda d: _flanged_checks(d, flanges=1),
    "C": lambda d: _flanged_checks(d, flanges=2),
    "L": lambda d: [_below(d, "thickness", min(d["width"], d["height"]), "min(width, height)",
                           "a leg would be no longer than the legs are thick")],
    "polygon": _polygon_check,
}
