"""The ``[geometry]`` and ``[mesh]`` tables, parsed, defaulted and validated into dataclasses.

Every check runs here, before Gmsh is touched: a bad value raises
:class:`~gcms_fenicsx.validation.ConfigError` naming the key (``[geometry] thickness``),
the value and what is allowed, including constraints between keys (a wall thicker than
half the section, a pin that does not fit the throw, a mesh size larger than the body) and
features too small for the geometry kernel or the mesh size (``geometry.features``).
Unknown keys are rejected. Lengths are in metres; ``in_units`` expresses a body in the
length unit its model is built in (``model_unit``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from gcms_fenicsx.validation import Table

from geometry import groups
from geometry.crank_layout import CrankLayout, crank_layout
from geometry.features import check_kernel_resolution, check_mesh_resolution
from geometry.sections import SECTION_KEYS, SECTIONS, Dimensions, Profile, section_profile, \
    section_violation

KINDS = ("beam", "crankshaft")
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
_CRANK_LENGTHS = ("stroke", "journal_diameter", "journal_length", "pin_diameter",
                  "pin_length", "web_thickness", "web_width")


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

    def layout(self) -> CrankLayout:
        return crank_layout(self)

    def in_units(self, unit: float) -> CrankshaftParams:
        """The same crankshaft with every length divided by ``unit``."""
        return replace(self, **{key: in_units(getattr(self, key), unit) for key in _CRANK_LENGTHS})


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


Geometry = BeamParams | CrankshaftParams


def parse_geometry(raw: Mapping[str, Any] | None) -> Geometry:
    """Validate ``[geometry]``: ``kind`` (required) and the keys of that kind."""
    table = Table("geometry", raw)
    kind = table.choice("kind", KINDS)
    return _parse_beam(table) if kind == "beam" else _parse_crankshaft(table)


def _parse_beam(t: Table) -> BeamParams:
    length = t.positive("length", 1.0)
    section = t.choice("section", SECTIONS)
    keys = SECTION_KEYS[section]
    for key in keys:  # known before finish(), so a typo is reported as an unknown key
        t.get(key, None)
    t.finish()
    dims = {key: _vertices(t) if key == "vertices" else t.positive(key) for key in keys}
    violation = section_violation(section, dims)
    if violation:
        key, allowed = violation
        raise t.error(key, dims[key], f"{allowed} (section {section!r})")
    beam = BeamParams(section=section, dimensions=dims, length=length)
    check_kernel_resolution(beam, largest_extent(beam))
    return beam


def _vertices(t: Table) -> tuple[tuple[float, float], ...]:
    value = t.get("vertices")
    if not isinstance(value, (list, tuple)) or not all(
            isinstance(v, (list, tuple)) and len(v) == 2 and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c)
                for c in v)
            for v in value):
        raise t.error("vertices", value, "must be a list of [y, z] pairs of finite numbers")
    return tuple((float(y), float(z)) for y, z in value)


def _parse_crankshaft(t: Table) -> CrankshaftParams:
    d = CRANKSHAFT_DEFAULTS
    throws = t.integer("throws", d["throws"], low=1, high=MAX_THROWS)
    angles = t.number_list("crank_angles_deg", list(default_crank_angles(throws)))
    if len(angles) != throws:
        raise t.error("crank_angles_deg", angles,
                      f"must have one angle per throw: {throws} values for throws = {throws}")
    lengths = {key: t.positive(key, d[key]) for key in _CRANK_LENGTHS}
    flags = {key: t.boolean(key, d[key]) for key in ("counterweights", "nose", "flange")}
    t.finish()
    _check_crank_fits(t, lengths)
    crank = CrankshaftParams(throws=throws, crank_angles_deg=tuple(angles), **lengths, **flags)
    check_kernel_resolution(crank, largest_extent(crank))
    return crank


def _check_crank_fits(t: Table, v: dict[str, float]) -> None:
    """The pin must sit off the main axis, and each web must cover the journal and the
    pin it joins (otherwise its edge would coincide with or cut into their surfaces)."""
    if v["pin_diameter"] >= v["stroke"]:
        raise t.error("pin_diameter", v["pin_diameter"],
                      f"must be < stroke = {v['stroke']:g}: a pin at radius stroke/2 = "
                      f"{v['stroke'] / 2:g} would enclose the main axis")
    needed = max(v["journal_diameter"], v["pin_diameter"])
    if v["web_width"] <= needed:
        raise t.error("web_width", v["web_width"],
                      f"must be > max(journal_diameter, pin_diameter) = {needed:g}: the web "
                      "must cover the journal and the pin it joins")


def largest_extent(geom: Geometry) -> float:
    """The largest edge of the body's bounding box (m)."""
    if isinstance(geom, BeamParams):
        return max(geom.length, *geom.profile().outer.extent)
    return geom.layout().largest_extent


def geometry_keys(geom: Geometry) -> tuple[str, ...]:
    """The ``[geometry]`` keys that shape ``geom`` (besides ``kind``), for messages."""
    if isinstance(geom, BeamParams):
        return ("section", *geom.dimensions, "length")
    return ("throws", "crank_angles_deg", *_CRANK_LENGTHS, "counterweights", "nose", "flange")


def default_mesh_size(geom: Geometry) -> float:
    """Beams: 2A/P of the section (≈ the wall thickness of a thin-walled section, half the
    side of a solid square): about one element through the thinnest wall.
    Crankshafts: 0.6 · web_thickness."""
    if isinstance(geom, BeamParams):
        return geom.profile().feature_size
    return CRANK_SIZE_PER_WEB_THICKNESS * geom.web_thickness


def surface_groups(geom: Geometry) -> dict[str, int]:
    """The named surface groups of ``geom`` and their physical tags."""
    return groups.surface_tags(geom.throws if isinstance(geom, CrankshaftParams) else None)


def parse_mesh(raw: Mapping[str, Any] | None, geom: Geometry) -> MeshParams:
    """Validate ``[mesh]`` for the geometry ``geom``: ``size``, ``order``, ``refine``."""
    t = Table("mesh", raw)
    size = t.positive("size", default_mesh_size(geom))
    order = t.integer("order", 2, low=1, high=2)
    refine_raw = t.subtable("refine")
    t.finish()
    extent = largest_extent(geom)
    if size > extent:
        raise t.error("size", size, f"must be <= {extent:g}, the largest extent of the "
                                    f"{geom.kind} (a mesh size larger than the body)")
    check_mesh_resolution(geom, size, order)
    return MeshParams(size=size, order=order, refine=_parse_refine(refine_raw, geom, size))


def _parse_refine(raw: Mapping[str, Any], geom: Geometry, size: float) -> dict[str, float]:
    t = Table("mesh.refine", raw)
    names = list(surface_groups(geom))
    refine = {}
    for name in raw:
        if name not in names:
            raise t.error(name, raw[name],
                          "unknown surface group (valid: " + ", ".join(names) + ")")
        refine[name] = t.positive(name)
        if refine[name] > size:
            raise t.error(name, refine[name], f"must be <= [mesh] size = {size:g} "
                                              "(a refinement coarser than the mesh does nothing)")
    return refine
