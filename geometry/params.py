"""The parameters of a body and its mesh: frozen dataclasses with their defaults, in metres.

What each ``[geometry]`` and ``[mesh]`` key means and which values the builders take; the
tables themselves are read by the configuration layer (``gcms_fenicsx.config.geometry``),
which calls the checks here and in ``geometry.features``. ``in_units`` expresses a body in
the length unit its model is built in (``model_unit``). Pure Python.
"""
from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field, replace
from typing import Any

from geometry import groups
from geometry.sections import Dimensions, Profile, section_profile

KINDS = ("beam", "crankshaft", "conrod")
MAX_THROWS = 16  # more than any inline engine has; the group tags would allow 99
#: The default crankshaft mesh size as a fraction of web_thickness: about two elements
#: through a web, ~27k nodes at order 2 for the default inline-4.
CRANK_SIZE_PER_WEB_THICKNESS = 0.6

#: Round surfaces get elements no longer than 1/16 of their circumference, whatever
#: ``[mesh] size`` says: a circle section's volume is then within ~3e-5 at order 2
#: (~2e-2 at order 1, faceted), where 2A/P alone would give six edges around.
ELEMENTS_PER_CIRCLE = 16

#: A plausible passenger-car inline-4 crankshaft (metres).
CRANKSHAFT_DEFAULTS: dict[str, Any] = {
    "throws": 4,
    "stroke": 0.086,
    "journal_diameter": 0.055,
    "journal_length": 0.025,
    "pin_diameter": 0.048,
    "pin_length": 0.024,
    "web_thickness": 0.018,
    "web_width": 0.075,
    "counterweights": True,
    "nose": True,
    "flange": True,
}
CRANK_LENGTHS = ("stroke", "journal_diameter", "journal_length", "pin_diameter",
                  "pin_length", "web_thickness", "web_width")

#: The default connecting-rod mesh size as a fraction of its thinner shank wall
#: (min(flange_thickness, web_thickness)): the crankshaft's fraction of its webs.
CONROD_SIZE_PER_WALL = CRANK_SIZE_PER_WEB_THICKNESS

#: A plausible passenger-car inline-4 connecting rod (metres), for the default crankshaft:
#: its big-end bore is the crank pin's diameter and its big end is narrower than the pin.
CONROD_DEFAULTS: dict[str, float] = {
    "length": 0.145,
    "big_end_bore": 0.048,
    "big_end_diameter": 0.068,
    "big_end_width": 0.022,
    "small_end_bore": 0.022,
    "small_end_diameter": 0.032,
    "small_end_width": 0.020,
    "shank_height": 0.024,
    "shank_width": 0.018,
    "flange_thickness": 0.005,
    "web_thickness": 0.006,
}
CONROD_LENGTHS = tuple(CONROD_DEFAULTS)


def default_crank_angles(throws: int) -> tuple[float, ...]:
    """0/180/180/0 for an inline-4 (a flat-plane crank), evenly spread 360°·i/throws otherwise."""
    if throws == 4:
        return (0.0, 180.0, 180.0, 0.0)
    return tuple(360.0 * i / throws for i in range(throws))


#: Significant digits a length keeps in model units (``in_units``).
MODEL_DIGITS = 12


def model_unit(extent: float) -> float:
    """The power of ten nearest to a body's largest ``extent``: the length unit its model is
    built in, so that Gmsh's and OCC's absolute tolerances are relative to the body."""
    return 10.0 ** round(math.log10(extent))


def in_units(length: float, unit: float) -> float:
    """``length`` in units of ``unit``, rounded to MODEL_DIGITS significant digits: the same
    body given at another scale differs in its last bits, and Gmsh's mesh would with them;
    the rounding (5e-13 relative) is far below the kernel's 1e-7."""
    return float(f"{length / unit:.{MODEL_DIGITS}g}")


@dataclass(frozen=True)
class BeamParams:
    """A straight prismatic beam along x from 0 to ``length``; ``dimensions`` holds the
    section's own keys (see ``geometry.sections.SECTION_KEYS``)."""

    section: str
    dimensions: Dimensions
    length: float = 1.0
    kind: str = field(default="beam", init=False)

    def profile(self) -> Profile:
        """The cross-section, centroid at the origin."""
        return section_profile(self.section, self.dimensions)

    def in_units(self, unit: float) -> BeamParams:
        """The same beam with every length divided by ``unit``."""
        dims = {key: (tuple((in_units(y, unit), in_units(z, unit)) for y, z in value)
                      if key == "vertices" else in_units(value, unit))
                for key, value in self.dimensions.items()}
        return BeamParams(self.section, dims, in_units(self.length, unit))


@dataclass(frozen=True)
class CrankshaftParams:
    """A crankshaft along x (see ``geometry.crank_layout`` for where each part goes)."""

    throws: int = CRANKSHAFT_DEFAULTS["throws"]
    crank_angles_deg: tuple[float, ...] = default_crank_angles(CRANKSHAFT_DEFAULTS["throws"])
    stroke: float = CRANKSHAFT_DEFAULTS["stroke"]
    journal_diameter: float = CRANKSHAFT_DEFAULTS["journal_diameter"]
    journal_length: float = CRANKSHAFT_DEFAULTS["journal_length"]
    pin_diameter: float = CRANKSHAFT_DEFAULTS["pin_diameter"]
    pin_length: float = CRANKSHAFT_DEFAULTS["pin_length"]
    web_thickness: float = CRANKSHAFT_DEFAULTS["web_thickness"]
    web_width: float = CRANKSHAFT_DEFAULTS["web_width"]
    counterweights: bool = CRANKSHAFT_DEFAULTS["counterweights"]
    nose: bool = CRANKSHAFT_DEFAULTS["nose"]
    flange: bool = CRANKSHAFT_DEFAULTS["flange"]
    kind: str = field(default="crankshaft", init=False)

    def in_units(self, unit: float) -> CrankshaftParams:
        """The same crankshaft with every length divided by ``unit``."""
        return replace(self, **{key: in_units(getattr(self, key), unit) for key in CRANK_LENGTHS})


@dataclass(frozen=True)
class ConrodParams:
    """A connecting rod in the x–y plane: the big-end bore's centre at the origin, the small
    end's at (length, 0, 0), both bores along z, an I-section shank along x between the two
    eyes (see ``geometry.conrod_layout``), symmetric about y = 0 and z = 0."""

    length: float = CONROD_DEFAULTS["length"]
    big_end_bore: float = CONROD_DEFAULTS["big_end_bore"]
    big_end_diameter: float = CONROD_DEFAULTS["big_end_diameter"]
    big_end_width: float = CONROD_DEFAULTS["big_end_width"]
    small_end_bore: float = CONROD_DEFAULTS["small_end_bore"]
    small_end_diameter: float = CONROD_DEFAULTS["small_end_diameter"]
    small_end_width: float = CONROD_DEFAULTS["small_end_width"]
    shank_height: float = CONROD_DEFAULTS["shank_height"]
    shank_width: float = CONROD_DEFAULTS["shank_width"]
    flange_thickness: float = CONROD_DEFAULTS["flange_thickness"]
    web_thickness: float = CONROD_DEFAULTS["web_thickness"]
    kind: str = field(default="conrod", init=False)

    def in_units(self, unit: float) -> ConrodParams:
        """The same connecting rod with every length divided by ``unit``."""
        return replace(self, **{key: in_units(getattr(self, key), unit) for key in CONROD_LENGTHS})


@dataclass(frozen=True)
class MeshParams:
    """Maximum element size (m), element order (1: 4-node, 2: curved 10-node tetrahedra)
    and finer sizes (m) near named surface groups."""

    size: float
    order: int = 2
    refine: dict[str, float] = field(default_factory=dict)

    def in_units(self, unit: float) -> MeshParams:
        """The same mesh with every size divided by ``unit``."""
        return MeshParams(in_units(self.size, unit), self.order,
                          {name: in_units(size, unit) for name, size in self.refine.items()})


Geometry = BeamParams | CrankshaftParams | ConrodParams


def geometry_keys(geom: Geometry) -> tuple[str, ...]:
    """The ``[geometry]`` keys that shape ``geom`` (besides ``kind``), for messages."""
    if isinstance(geom, BeamParams):
        return ("section", *geom.dimensions, "length")
    if isinstance(geom, ConrodParams):
        return CONROD_LENGTHS
    return ("throws", "crank_angles_deg", *CRANK_LENGTHS, "counterweights", "nose", "flange")


class DerivedLength(float):
    """A length the user did not set, derived from other keys (``how``): a float whose repr
    says so, so that a message naming it (``[mesh] size = …``) does not present it as given.
    Its str, format, JSON and hash are the plain number's."""

    how: str

    def __new__(cls, value: float, how: str) -> DerivedLength:
        length = super().__new__(cls, value)
        length.how = how
        return length

    def __getnewargs__(self) -> tuple[float, str]:  # pickle and deepcopy keep ``how``
        return float(self), self.how

    def __repr__(self) -> str:
        return f"{float(self):.3g} (not set: derived as {self.how})"

    __str__ = float.__repr__


def default_mesh_size(geom: Geometry) -> DerivedLength:
    """Beams: 2A/P of the section (≈ the wall thickness of a thin-walled section, half the
    side of a solid square): about one element through the thinnest wall.
    Crankshafts: 0.6 · web_thickness. Connecting rods: 0.6 · the thinner shank wall."""
    if isinstance(geom, BeamParams):
        return DerivedLength(geom.profile().feature_size,
                             f"2·area/perimeter of the {geom.section} section, the default")
    if isinstance(geom, ConrodParams):
        return DerivedLength(CONROD_SIZE_PER_WALL * min(geom.flange_thickness, geom.web_thickness),
                             f"{CONROD_SIZE_PER_WALL:g} × min(flange_thickness, web_thickness), "
                             "the default")
    return DerivedLength(CRANK_SIZE_PER_WEB_THICKNESS * geom.web_thickness,
                         f"{CRANK_SIZE_PER_WEB_THICKNESS:g} × web_thickness, the default")


def surface_groups(geom: Geometry) -> dict[str, int]:
    """The named surface groups of ``geom`` and their physical tags."""
    if isinstance(geom, ConrodParams):
        return dict(groups.CONROD_TAGS)
    return groups.surface_tags(geom.throws if isinstance(geom, CrankshaftParams) else None)


def crank_violation(lengths: dict[str, float],
                    given: Collection[str] = CRANK_LENGTHS) -> tuple[str, str] | None:
    """(key, what is allowed) for crankshaft lengths that do not fit together, else None.

    The pin must sit off the main axis, and each web must cover the journal and the pin it
    joins (otherwise its edge would coincide with or cut into their surfaces). The key blamed
    is one the user set (``given``): a stroke too small for the default pin is the stroke's.
    """
    def shown(key: str) -> str:
        return f"{key} = {lengths[key]:g}" + ("" if key in given else " (its default)")

    stroke, pin = lengths["stroke"], lengths["pin_diameter"]
    if pin >= stroke:
        axis = (f"a pin of diameter {pin:g} at radius stroke/2 = {stroke / 2:g} would enclose "
                "the main axis")
        if "stroke" in given and "pin_diameter" not in given:
            return "stroke", f"must be > {shown('pin_diameter')}: {axis}"
        return "pin_diameter", f"must be < {shown('stroke')}: {axis}"
    largest = max(("journal_diameter", "pin_diameter"), key=lambda key: lengths[key])
    if lengths["web_width"] <= lengths[largest]:
        cover = "the web must cover the journal and the pin it joins"
        if largest in given and "web_width" not in given:
            return largest, f"must be < {shown('web_width')}: {cover}"
        return "web_width", (f"must be > max(journal_diameter, pin_diameter) = "
                             f"{lengths[largest]:g}: {cover}")
    return None
