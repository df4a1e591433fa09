"""Is a list of vertices a usable polygon section? Simplicity and degeneracy checks.

A user's ``vertices`` must describe a simple polygon (no edge crosses or touches a
non-adjacent one, no edge folds back onto its neighbour), without zero-length edges and
with non-zero area; either orientation is fine. Every test works to a tolerance relative
to the polygon's size, so a vertex 1e-12 m off another counts as touching it.
"""
from __future__ import annotations

import math
from itertools import combinations

from geometry.shapes import Point, Polygon, turn

#: Lengths below this fraction of the polygon's bounding-box diagonal count as zero.
RELATIVE_TOLERANCE = 1e-9


def polygon_defect(vertices: tuple[Point, ...]) -> str | None:
    """What makes ``vertices`` unusable as a section, or None if they form a simple polygon."""
    n = len(vertices)
    if n < 3:
        return f"it has {n} vertices, not at least 3"
    ys, zs = zip(*vertices)
    diagonal = math.hypot(max(ys) - min(ys), max(zs) - min(zs))
    tol = RELATIVE_TOLERANCE * diagonal
    for i in range(n):
        j = (i + 1) % n
        if math.dist(vertices[i], vertices[j]) <= tol:
            return (f"vertex {j} repeats vertex {i} (a zero-length edge; list each vertex "
                    "once, without closing the loop)")
    edges = [(vertices[i], vertices[(i + 1) % n]) for i in range(n)]
    for i in range(n):  # adjacent edges (i-1, i) meet at vertex i and must not overlap
        before, after = edges[i - 1][0], edges[i][1]
        if (_distance_to_segment(before, *edges[i]) <= tol
                or _distance_to_segment(after, *edges[i - 1]) <= tol):
            return f"the outline folds back on itself at vertex {i} (its two edges there overlap)"
    for i, k in combinations(range(n), 2):
        if k == i + 1 or (i == 0 and k == n - 1):
            continue
        if _segments_meet(*edges[i], *edges[k], tol):
            return f"edge {i}-{(i + 1) % n} and edge {k}-{(k + 1) % n} cross or touch"
    if Polygon(vertices).area <= RELATIVE_TOLERANCE * diagonal**2:
        return "its area is (almost) zero"
    return None


def shortest_edge(vertices: tuple[Point, ...]) -> float:
    """The length of the polygon's shortest edge."""
    return min(math.dist(a, b) for a, b in zip(vertices, vertices[1:] + vertices[:1]))


def narrowest_gap(vertices: tuple[Point, ...]) -> float:
    """The smallest distance of a vertex to an edge that does not end at it: the width of
    a spike or a notch, a triangle's smallest altitude."""
    n = len(vertices)
    return min(_distance_to_segment(vertices[i], vertices[k], vertices[(k + 1) % n])
               for i in range(n) for k in range(n) if i not in (k, (k + 1) % n))


def _distance_to_segment(p: Point, a: Point, b: Point) -> float:
    """Euclidean distance from p to the closed segment ab."""
    dy, dz = b[0] - a[0], b[1] - a[1]
    t = ((p[0] - a[0]) * dy + (p[1] - a[1]) * dz) / (dy * dy + dz * dz)
    t = min(1.0, max(0.0, t))
    return math.dist(p, (a[0] + t * dy, a[1] + t * dz))


def _segments_meet(a: Point, b: Point, c: Point, d: Point, tol: float) -> bool:
    """Do the closed segments ab and cd intersect (a proper crossing, or an end point
    within ``tol`` of the other segment)?"""
    if turn(a, b, c) * turn(a, b, d) < 0 and turn(c, d, a) * turn(c, d, b) < 0:
        return True
    return min(_distance_to_segment(c, a, b), _distance_to_segment(d, a, b),
               _distance_to_segment(a, c, d), _distance_to_segment(b, c, d)) <= tol
