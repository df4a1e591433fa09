"""Where the parts of a connecting rod go, and which of its lengths fit together.

The rod lies in the x–y plane, symmetric about y = 0 and z = 0: the big eye (a cylinder of
``big_end_diameter`` and ``big_end_width`` along z) about the z axis, the small eye about
the parallel axis through (length, 0, 0), and between them an I-section shank along x:
two flanges ``shank_width`` wide (along z) and ``flange_thickness`` thick at y = ±
shank_height/2, joined by a web ``web_thickness`` thick (along z) in the plane of the rod.
The shank runs from one bore centre to the other and is fused with both eyes, whose bores
(``big_end_bore``, ``small_end_bore``: diameters) are then cut; the bores' cylindrical
faces are the groups ``big_end`` and ``small_end`` (``geometry.groups``).

Pure Python: the extent of the body and its constraints are known before Gmsh runs.
"""
from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING

from geometry import groups
from geometry.sections import Profile, section_profile
from geometry.shapes import Polygon

if TYPE_CHECKING:
    from geometry.params import ConrodParams


@dataclass(frozen=True)
class Eye:
    """One eye of the rod: an annular cylinder along z, centred on z = 0."""

    name: str  # the group of its bore: big_end or small_end
    x: float  # the bore's centre on the x axis
    bore: float  # the bore's radius
    radius: float  # the outer radius
    width: float  # along z


def eyes(p: ConrodParams) -> tuple[Eye, Eye]:
    """The big eye (bore centre at the origin) and the small one (at x = length)."""
    return (Eye(groups.BIG_END, 0.0, p.big_end_bore / 2, p.big_end_diameter / 2, p.big_end_width),
            Eye(groups.SMALL_END, p.length, p.small_end_bore / 2, p.small_end_diameter / 2,
                p.small_end_width))


def shank_profile(p: ConrodParams) -> Profile:
    """The shank's I-section in body coordinates (y, z), centroid at the origin: the beam
    section ``I`` with its flanges turned to run along z (their width) and its height
    along y."""
    section = section_profile("I", {"width": p.shank_width, "height": p.shank_height,
                                    "flange_thickness": p.flange_thickness,
                                    "web_thickness": p.web_thickness})
    return Profile(Polygon(tuple((z, y) for y, z in section.outer.vertices)))


def bounding_box(p: ConrodParams) -> tuple[float, float, float]:
    """The edges of the body's bounding box along x, y and z."""
    big, small = eyes(p)
    return (p.length + big.radius + small.radius, 2.0 * max(big.radius, small.radius),
            max(big.width, small.width))


def largest_extent(p: ConrodParams) -> float:
    """The largest edge of the body's bounding box (its length over both eyes)."""
    return max(bounding_box(p))


def shank_length(p: ConrodParams) -> float:
    """The shank's length between the eyes on the rod's axis."""
    big, small = eyes(p)
    return p.length - big.radius - small.radius


@dataclass(frozen=True)
class Fit:
    """``scale`` · ``smaller`` must be < ``larger`` (<= unless ``strict``), because ``why``."""

    smaller: str
    larger: str
    why: str
    scale: float = 1.0
    strict: bool = True


FITS = (
    Fit("big_end_bore", "big_end_diameter", "the big eye needs a wall around its bore"),
    Fit("small_end_bore", "small_end_diameter", "the small eye needs a wall around its bore"),
    Fit("web_thickness", "shank_width", "the web would be as wide as the flanges"),
    Fit("flange_thickness", "shank_height", "the flanges would fill the shank's height", 2.0),
    Fit("shank_height", "big_end_diameter", "the shank must end inside the big eye"),
    Fit("shank_height", "small_end_diameter", "the shank must end inside the small eye"),
    Fit("shank_width", "big_end_width", "the shank must not stick out of the big eye's "
        "faces", strict=False),
    Fit("shank_width", "small_end_width", "the shank must not stick out of the small eye's "
        "faces", strict=False),
)


def conrod_violation(lengths: dict[str, float],
                     given: Collection[str]) -> tuple[str, str] | None:
    """(key, what is allowed) for connecting-rod lengths that do not fit together, else None.

    The key blamed is one the user set (``given``): a shank too high for the default small
    eye is the shank's; when both or neither are set, the smaller one's."""
    def shown(key: str, scale: float = 1.0) -> str:
        value = f"{lengths[key] / scale:g}" + ("" if key in given else " (its default)")
        return f"{key}{'' if scale == 1.0 else f'/{scale:g}'} = {value}"

    for fit in FITS:
        small, large = fit.scale * lengths[fit.smaller], lengths[fit.larger]
        if small < large or (small == large and not fit.strict):
            continue
        less, more = ("<", ">") if fit.strict else ("<=", ">=")
        if fit.larger in given and fit.smaller not in given:
            scaled = f"{fit.scale:g}·" if fit.scale != 1.0 else ""
            value = f"{small:g}" + ("" if fit.smaller in given else " (its default)")
            return fit.larger, f"must be {more} {scaled}{fit.smaller} = {value}: {fit.why}"
        return fit.smaller, f"must be {less} {shown(fit.larger, fit.scale)}: {fit.why}"
    return _eyes_apart(lengths, given)


def _eyes_apart(lengths: dict[str, float], given: Collection[str]) -> tuple[str, str] | None:
    """``length`` must exceed the sum of the eyes' outer radii, leaving a shank between."""
    reach = (lengths["big_end_diameter"] + lengths["small_end_diameter"]) / 2
    if lengths["length"] > reach:
        return None
    why = ("the eyes would touch or overlap and leave no shank between them (length is the "
           "distance between the bore centres)")
    eye = next((key for key in ("big_end_diameter", "small_end_diameter") if key in given), None)
    if eye is not None and "length" not in given:
        other = "small_end_diameter" if eye == "big_end_diameter" else "big_end_diameter"
        limit = 2 * lengths["length"] - lengths[other]
        return eye, (f"must be < 2·length − {other} = {limit:g} (length = "
                     f"{lengths['length']:g}, its default): {why}")
    return "length", f"must be > (big_end_diameter + small_end_diameter)/2 = {reach:g}: {why}"
