"""The ``[geometry]`` and ``[mesh]`` tables, read into the geometry package's parameter types.

Every check runs here, before Gmsh is touched: a bad value raises ConfigError naming the key
(``[geometry] thickness``), the value and what is allowed, including constraints between
keys (a wall thicker than half the section, a pin that does not fit the throw, a connecting
rod's bore wider than its eye, a mesh size larger than the body) and features too small for the geometry kernel or the mesh size
(``geometry.features``, whose GeometryError becomes the same ConfigError). Unknown keys are
rejected. Lengths in metres.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Mapping, TypeVar

from geometry.errors import GeometryError
from geometry.extent import largest_extent
from geometry.features import check_kernel_resolution, check_mesh_resolution
from geometry.conrod_layout import conrod_violation
from geometry.params import (CONROD_DEFAULTS, CONROD_LENGTHS, CRANK_LENGTHS, CRANKSHAFT_DEFAULTS,
                             KINDS, MAX_THROWS, BeamParams, ConrodParams, CrankshaftParams,
                             Geometry, MeshParams, crank_violation, default_crank_angles,
                             default_mesh_size, surface_groups)
from geometry.sections import SECTION_KEYS, SECTIONS, section_violation

from gcms_fenicsx.config.table import ConfigError, Table

G = TypeVar("G", BeamParams, CrankshaftParams, ConrodParams)


def _checked(check: Callable[..., None], *args: Any) -> None:
    """``check(*args)`` with its GeometryError as the ConfigError of the same key and value."""
    try:
        check(*args)
    except GeometryError as exc:
        raise ConfigError(exc.key, exc.value, exc.allowed) from exc


def parse_geometry(raw: Mapping[str, Any] | None) -> Geometry:
    """Validate ``[geometry]``: ``kind`` (required) and the keys of that kind."""
    table = Table("geometry", raw)
    kind = table.choice("kind", KINDS)
    parse = {"beam": _parse_beam, "crankshaft": _parse_crankshaft, "conrod": _parse_conrod}
    return parse[kind](table)


def _resolvable(t: Table, violation: tuple[str, str] | None, values: Mapping[str, Any],
                geom: G) -> G:
    """``geom``, unless ``violation`` (key, what is allowed) names a key of ``values`` that
    does not fit the others, or a feature is below the kernel's resolution."""
    if violation:
        key, allowed = violation
        raise t.error(key, values[key], allowed)
    _checked(check_kernel_resolution, geom, largest_extent(geom))
    return geom


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
    _checked(check_kernel_resolution, beam, largest_extent(beam))
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
    lengths = {key: t.positive(key, d[key]) for key in CRANK_LENGTHS}
    flags = {key: t.boolean(key, d[key]) for key in ("counterweights", "nose", "flange")}
    t.finish()
    violation = crank_violation(lengths, [key for key in CRANK_LENGTHS if t.has(key)])
    return _resolvable(t, violation, lengths, CrankshaftParams(
        throws=throws, crank_angles_deg=tuple(angles), **lengths, **flags))


def _parse_conrod(t: Table) -> ConrodParams:
    lengths = {key: t.positive(key, CONROD_DEFAULTS[key]) for key in CONROD_LENGTHS}
    t.finish()
    violation = conrod_violation(lengths, [key for key in CONROD_LENGTHS if t.has(key)])
    return _resolvable(t, violation, lengths, ConrodParams(**lengths))


def parse_mesh(raw: Mapping[str, Any] | None, geom: Geometry) -> MeshParams:
    """Validate ``[mesh]`` for the geometry ``geom``: ``size``, ``order``, ``refine``."""
    t = Table("mesh", raw)
    default = default_mesh_size(geom)   # kept as derived (its repr says so) when not set
    size = t.positive("size") if t.has("size") else t.get("size", default)
    order = t.integer("order", 2, low=1, high=2)
    refine_raw = t.subtable("refine")
    t.finish()
    extent = largest_extent(geom)
    if size > extent:
        raise t.error("size", size, f"must be <= {extent:g}, the largest extent of the "
                                    f"{geom.kind} (a mesh size larger than the body)")
    _checked(check_mesh_resolution, geom, size, order)
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
