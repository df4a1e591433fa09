"""Plane shapes in section coordinates (y, z): circles, polygons and circular sectors.

These are the pieces beam sections and crank webs are drawn with. They are pure data
with their exact area, centroid, perimeter and extent where a caller needs them;
``geometry.occ_shapes`` turns them into OCC faces. No Gmsh here, so parameters can be
validated and sized before any model exists.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

Point = tuple[float, float]
SecondMoments = tuple[float, float, float]  # (∫y², ∫z², ∫yz) dA


def turn(o: Point, a: Point, b: Point) -> float:
    """z-component of (a − o) × (b − o): > 0 when o → a → b turns counter-clockwise,
    0 when the three points are collinear."""
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


@dataclass(frozen=True)
class Circle:
    """A disc of ``radius`` about ``centre``."""

    radius: float
    centre: Point = (0.0, 0.0)

    @property
    def area(self) -> float:
        return math.pi * self.radius**2

    @property
    def centroid(self) -> Point:
        return self.centre

    @property
    def perimeter(self) -> float:
        return 2.0 * math.pi * self.radius

    @property
    def extent(self) -> Point:
        """Width along y and height along z of the bounding box."""
        return (2.0 * self.radius, 2.0 * self.radius)

    def shifted(self, dy: float, dz: float) -> Circle:
        return Circle(self.radius, (self.centre[0] + dy, self.centre[1] + dz))

    @property
    def second_moments(self) -> SecondMoments:
        """(∫y², ∫z², ∫yz) dA about the origin: πr⁴/4 about the centre, plus A·c cᵀ."""
        (cy, cz), a = self.centre, self.area
        own = math.pi * self.radius**4 / 4.0
        return (own + a * cy * cy, own + a * cz * cz, a * cy * cz)


@dataclass(frozen=True)
class Polygon:
    """A simple polygon through ``vertices`` (either orientation, not repeating the first)."""

    vertices: tuple[Point, ...]

    def _edges(self):
        v = self.vertices
        return zip(v, v[1:] + v[:1])

    @property
    def signed_area(self) -> float:
        """Shoelace formula: A = ½ Σ (y_i z_{i+1} − y_{i+1} z_i), > 0 counter-clockwise."""
        return 0.5 * sum(y0 * z1 - y1 * z0 for (y0, z0), (y1, z1) in self._edges())

    @property
    def area(self) -> float:
        return abs(self.signed_area)

    @property
    def centroid(self) -> Point:
        """Shoelace centroid: c_y = Σ (y_i + y_{i+1}) w_i / (6A), c_z likewise,
        with w_i = y_i z_{i+1} − y_{i+1} z_i and A the signed area."""
        a6 = 6.0 * self.signed_area
        cy = sum((y0 + y1) * (y0 * z1 - y1 * z0) for (y0, z0), (y1, z1) in self._edges())
        cz = sum((z0 + z1) * (y0 * z1 - y1 * z0) for (y0, z0), (y1, z1) in self._edges())
        return (cy / a6, cz / a6)

    @property
    def perimeter(self) -> float:
        return sum(math.dist(p, q) for p, q in self._edges())

    @property
    def extent(self) -> Point:
        ys, zs = zip(*self.vertices)
        return (max(ys) - min(ys), max(zs) - min(zs))

    def shifted(self, dy: float, dz: float) -> Polygon:
        return Polygon(tuple((y + dy, z + dz) for y, z in self.vertices))

    @property
    def second_moments(self) -> SecondMoments:
        """(∫y², ∫z², ∫yz) dA about the origin by the shoelace sums, with w_i as for the
        centroid: Σ w_i (y_i² + y_i y_{i+1} + y_{i+1}²)/12, likewise for z, and
        Σ w_i (y_i z_{i+1} + 2 y_i z_i + 2 y_{i+1} z_{i+1} + y_{i+1} z_i)/24; the sign of the
        signed area makes either orientation positive."""
        sign = math.copysign(1.0, self.signed_area)
        yy = zz = yz = 0.0
        for (y0, z0), (y1, z1) in self._edges():
            w = y0 * z1 - y1 * z0
            yy += w * (y0 * y0 + y0 * y1 + y1 * y1)
            zz += w * (z0 * z0 + z0 * z1 + z1 * z1)
            yz += w * (y0 * z1 + 2.0 * y0 * z0 + 2.0 * y1 * z1 + y1 * z0)
        return (sign * yy / 12.0, sign * zz / 12.0, sign * yz / 24.0)


@dataclass(frozen=True)
class Sector:
    """The circular sector about the origin of ``radius`` between two polar angles
    (radians from +y towards +z, counter-clockwise, opening less than π)."""

    radius: float
    start: float
    stop: float

    def point(self, angle: float) -> Point:
        return (self.radius * math.cos(angle), self.radius * math.sin(angle))


Shape = Circle | Polygon | Sector
