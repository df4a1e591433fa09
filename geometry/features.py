"""The smallest features of a body, checked before Gmsh runs.

A feature is a length the model has to resolve: a wall, flange, web or leg of a section, a
polygon's shortest edge, narrowest spike or notch and 2A/P, a crankshaft's journals, pins,
webs and the shoulders of its nose and flange, a beam's length, a connecting rod's bores,
eye walls and widths, its shank's flanges, web and length, and the steps where the shank
meets an eye. Each is checked twice:

- Against the geometry kernel. OpenCASCADE takes points closer than 1e-7 model units
  (``Precision::Confusion``) for one, and ``geometry.meshing`` models the body in units of
  the power of ten nearest its largest extent; ``geometry.faces`` finds the named surfaces
  to 1e-6 of the extent.
  A feature must be at least ``KERNEL_RESOLUTION`` = 1e-5 of the largest extent, ten times
  the face tolerance: measured, features of 1e-7 of the extent or less end in "Line
  Loop is not closed", "BRepSweep_Translation", "Fuse operation cannot be performed" or a
  fusion into two solids, and from 3e-7 up they build.
- Against ``[mesh] size`` h: at least ``MIN_FEATURE_PER_SIZE[order]`` · h, at least twice the
  largest ratio measured to fail (docs/geometry_checks.md: beams at h = 5 mm, a one-throw
  crankshaft at h = 10 mm, feature/h from 1 down to 0.001). A tube wall of 0.03 h stops
  Gmsh's 3D mesher ("PLC Error: A segment and a facet intersect") and one of 0.1 h folds
  curved order-2 cells, a crank web's rim of 0.05 h folds them too, a polygon's spike or
  sliver of 0.003 h stops the surface mesher; a wall of 0.05 h (order 1) or 0.2 h (order
  2) meshes. Straight walls mesh at any ratio, their worst cell flattening with it. The
  check reads ``[mesh] size`` as given: a finer ``refine`` near a group does not relax it.

Pure Python; the checks raise GeometryError naming the key that sets the feature.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from geometry.conrod_layout import shank_length
from geometry.crank_layout import FLANGE_LENGTH, NOSE_DIAMETER
from geometry.errors import GeometryError
from geometry.polygon import narrowest_gap, shortest_edge
from geometry.sections import Dimensions
from geometry.shapes import Polygon

if TYPE_CHECKING:
    from geometry.params import ConrodParams, CrankshaftParams, Geometry

#: Features below this fraction of the body's largest extent are refused (module docstring).
KERNEL_RESOLUTION = 1e-5
#: Features below this fraction of [mesh] size are refused, by element order (docstring).
MIN_FEATURE_PER_SIZE = {1: 0.1, 2: 0.2}
#: A feature this close below a limit (relative) is at the limit: the limit's own product
#: (0.2 · 0.0125 = 0.0025000000000000005) and a feature's sums are off by a few ε.
ROUND_OFF = 1e-12
#: Significant digits of a suggested [mesh] size (rounded down, so it passes the check).
SUGGESTED_DIGITS = 3


@dataclass(frozen=True)
class Feature:
    """A length the model must resolve, and the ``[geometry]`` key that sets it."""

    key: str
    what: str  # for messages: "the tube wall (thickness)"
    size: float  # m


def _flanged(d: Dimensions, flanges: int, centred_web: bool) -> list[Feature]:
    """I (two flanges, centred web), T (one flange, centred web), C (two, web at an edge)."""
    overhang = (d["width"] - d["web_thickness"]) / (2.0 if centred_web else 1.0)
    return [Feature("flange_thickness", "a flange (flange_thickness)", d["flange_thickness"]),
            Feature("web_thickness", "the web (web_thickness)", d["web_thickness"]),
            Feature("web_thickness", "the flanges' overhang beyond the web (width − web_thickness)"
                    + ("/2" if centred_web else ""), overhang),
            Feature("flange_thickness", "the web's height between the flanges (height − "
                    + (f"{flanges}·" if flanges > 1 else "") + "flange_thickness)",
                    d["height"] - flanges * d["flange_thickness"])]


def _polygon(d: Dimensions) -> list[Feature]:
    vertices = d["vertices"]
    shape = Polygon(vertices)
    return [Feature("vertices", "the shortest edge", shortest_edge(vertices)),
            Feature("vertices", "the narrowest spike or notch (a vertex's distance to an edge "
                    "not ending at it)", narrowest_gap(vertices)),
            Feature("vertices", "2·area/perimeter", 2.0 * shape.area / shape.perimeter)]


_SECTION_FEATURES: dict[str, Callable[[Dimensions], list[Feature]]] = {
    "square": lambda d: [Feature("side", "the side", d["side"])],
    "rectangle": lambda d: [Feature("width", "the width", d["width"]),
                            Feature("height", "the height", d["height"])],
    "circle": lambda d: [Feature("radius", "the diameter (2·radius)", 2.0 * d["radius"])],
    "tube": lambda d: [Feature("thickness", "the wall (thickness)", d["thickness"]),
                       Feature("thickness", "the hole's diameter (2·(radius − thickness))",
                               2.0 * (d["radius"] - d["thickness"]))],
    "box": lambda d: [Feature("thickness", "the wall (thickness)", d["thickness"]),
                      Feature("thickness", "the hole's smaller side (min(width, height) − "
                              "2·thickness)", min(d["width"], d["height"]) - 2.0 * d["thickness"])],
    "I": lambda d: _flanged(d, flanges=2, centred_web=True),
    "T": lambda d: _flanged(d, flanges=1, centred_web=True),
    "C": lambda d: _flanged(d, flanges=2, centred_web=False),
    "L": lambda d: [Feature("thickness", "a leg (thickness)", d["thickness"]),
                    Feature("thickness", "the shorter leg beyond the corner (min(width, height) "
                            "− thickness)", min(d["width"], d["height"]) - d["thickness"])],
    "polygon": _polygon,
}


def _crankshaft(p: CrankshaftParams) -> list[Feature]:
    rim = (p.web_width - max(p.journal_diameter, p.pin_diameter)) / 2.0
    found = [Feature("journal_diameter", "a main journal (journal_diameter)", p.journal_diameter),
             Feature("journal_length", "a main journal (journal_length)", p.journal_length),
             Feature("pin_diameter", "a crank pin (pin_diameter)", p.pin_diameter),
             Feature("pin_length", "a crank pin (pin_length)", p.pin_length),
             Feature("web_thickness", "a web (web_thickness)", p.web_thickness),
             Feature("web_width", "the web's rim around the journal or pin (web_width − "
                     "max(journal_diameter, pin_diameter))/2", rim),
             Feature("stroke", "a web's straight edges and counterweight's reach (stroke/2)",
                     p.stroke / 2.0)]
    if p.nose:
        found.append(Feature("journal_diameter", "the shoulder between the nose and journal_0 "
                             f"({(1.0 - NOSE_DIAMETER) / 2:g}·journal_diameter)",
                             (1.0 - NOSE_DIAMETER) / 2.0 * p.journal_diameter))
    if p.flange:
        found.append(Feature("journal_diameter", f"the flange's length ({FLANGE_LENGTH:g}·"
                             "journal_diameter)", FLANGE_LENGTH * p.journal_diameter))
    return found


def _conrod(p: ConrodParams) -> list[Feature]:
    found = [Feature("length", "the shank between the eyes (length − big_end_diameter/2 − "
                     "small_end_diameter/2)", shank_length(p)),
             Feature("flange_thickness", "a flange (flange_thickness)", p.flange_thickness),
             Feature("web_thickness", "the web (web_thickness)", p.web_thickness),
             Feature("web_thickness", "the flanges' overhang beyond the web (shank_width − "
                     "web_thickness)/2", (p.shank_width - p.web_thickness) / 2),
             Feature("flange_thickness", "the web's height between the flanges (shank_height − "
                     "2·flange_thickness)", p.shank_height - 2 * p.flange_thickness)]
    for end, eye in (("big_end", "the big eye"), ("small_end", "the small eye")):
        bore, diameter, width = (getattr(p, f"{end}_{key}")
                                 for key in ("bore", "diameter", "width"))
        found += [Feature(f"{end}_bore", f"{eye}'s bore ({end}_bore)", bore),
                  Feature(f"{end}_bore", f"{eye}'s wall ({end}_diameter − {end}_bore)/2",
                          (diameter - bore) / 2),
                  Feature(f"{end}_width", f"{eye}'s width ({end}_width)", width),
                  Feature("shank_height", f"{eye} beyond the shank ({end}_diameter − "
                          "shank_height)/2", (diameter - p.shank_height) / 2)]
        if width > p.shank_width:  # flush faces are no feature; a step beside the shank is
            found.append(Feature("shank_width", f"the step from the shank to {eye}'s faces "
                                 f"({end}_width − shank_width)/2", (width - p.shank_width) / 2))
    return found


def features(geom: Geometry) -> list[Feature]:
    """Every feature of ``geom`` that the kernel and the mesh must resolve."""
    if geom.kind == "crankshaft":
        return _crankshaft(geom)
    if geom.kind == "conrod":
        return _conrod(geom)
    return [*_SECTION_FEATURES[geom.section](geom.dimensions),
            Feature("length", "the length", geom.length)]


def key_value(geom: Geometry, key: str) -> Any:
    """The value of the ``[geometry]`` key ``key`` of ``geom``, as the user gave it."""
    if geom.kind == "beam" and key != "length":
        return geom.dimensions[key]
    return getattr(geom, key)


def _smallest(geom: Geometry, minimum: float) -> Feature | None:
    """The smallest feature below ``minimum`` by more than ROUND_OFF, or None."""
    small = [f for f in features(geom) if f.size < minimum * (1.0 - ROUND_OFF)]
    return min(small, key=lambda f: f.size, default=None)


def rounded_down(value: float, digits: int = SUGGESTED_DIGITS) -> float:
    """``value`` > 0 rounded down to ``digits`` significant digits: 0.012499 → 0.0124."""
    unit = 10.0 ** (math.floor(math.log10(value)) - digits + 1)
    return float(f"{math.floor(value / unit * (1.0 + ROUND_OFF)) * unit:.{digits}g}")


def _refuse(geom: Geometry, feature: Feature, allowed: str) -> GeometryError:
    return GeometryError(f"[geometry] {feature.key}", key_value(geom, feature.key),
                       f"{feature.what} is {feature.size:.3g} m, {allowed}")


def check_kernel_resolution(geom: Geometry, extent: float) -> None:
    """GeometryError if a feature is below KERNEL_RESOLUTION of the largest ``extent``."""
    minimum = KERNEL_RESOLUTION * extent
    feature = _smallest(geom, minimum)
    if feature:
        raise _refuse(geom, feature, f"must be >= {KERNEL_RESOLUTION:g} × the body's largest "
                      f"extent {extent:g} m = {minimum:.3g} m: the geometry kernel merges "
                      "points closer than about 1e-7 of the extent")


def check_mesh_resolution(geom: Geometry, size: float, order: int) -> None:
    """GeometryError if a feature is below MIN_FEATURE_PER_SIZE[order] of ``size``."""
    ratio = MIN_FEATURE_PER_SIZE[order]
    feature = _smallest(geom, ratio * size)
    if feature:
        raise _refuse(geom, feature, f"must be >= {ratio:g} × [mesh] size {size:g} m = "
                      f"{ratio * size:.3g} m at order {order} (a thinner feature does not "
                      "mesh into valid cells): enlarge it or set a smaller [mesh] size "
                      f"(<= {rounded_down(feature.size / ratio):g} m)")
