"""The ``[engine]`` table of a system study: gas pressure on its pistons over the four-stroke
cycle (``dynamics.system.gas_pressure``; docs/study-file.md "System studies").

Cylinder k (1 … n) is the point-mass piston ``pistons[k-1]``; the gas pushes it along
``towards_crank`` with (p(φ) − 1 bar) π D²/4, φ the crank angle from its firing TDC: the angle
of the driven joint ``crank_drive`` (the crankshaft's drive) less the cylinder's firing angle
from ``firing_order`` (720°/n apart, the first at ``first_firing_deg``). The pressure curve is
the built-in full-load petrol curve or a table over the 720° cycle; ``ramp_time`` lets the gas
forces rise as ½ (1 − cos πt/T) so the run does not start with a force step.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from gcms_fenicsx.config.table import Table

#: m: a bore beyond this is a length in the wrong unit (an 82 mm bore is 0.082).
MAX_BORE_M = 10.0

BUILT_IN_CURVES = ("petrol_full_load",)


@dataclass(frozen=True)
class EngineSpec:
    pistons: tuple[str, ...]
    bore_m: float
    towards_crank: tuple[float, ...]
    firing_order: tuple[int, ...]
    first_firing_deg: float
    crank_drive: str
    #: "petrol_full_load", or (angles (degrees), pressures (Pa)) of a table
    pressure: str | tuple[tuple[float, ...], tuple[float, ...]]
    ramp_time_s: float = 0.0


def _pressure(t: Table) -> str | tuple[tuple[float, ...], tuple[float, ...]]:
    value = t.get("pressure", "petrol_full_load")
    if isinstance(value, str):
        if value not in BUILT_IN_CURVES:
            raise t.error("pressure", value, "must be one of " + ", ".join(
                repr(c) for c in BUILT_IN_CURVES) + ", or a table {angles_deg = [...], "
                "pressures_bar = [...]}")
        return value
    p = Table(f"{t.name}.pressure", t.subtable("pressure"))
    angles, bars = p.number_list("angles_deg"), p.number_list("pressures_bar")
    p.finish()
    if len(angles) != len(bars) or len(angles) < 2:
        raise p.error("pressures_bar", bars, f"one pressure per angle ({len(angles)}), at least "
                      "two")
    if angles[0] < 0 or angles[-1] >= 720.0 or (np.diff(angles) <= 0).any():
        raise p.error("angles_deg", angles, "must ascend within [0, 720): the crank angle from "
                      "the cylinder's firing TDC")
    if min(bars) < 0:
        raise p.error("pressures_bar", bars, "must be ≥ 0 (absolute pressures, bar)")
    return tuple(angles), tuple(b * 1e5 for b in bars)


def parse_engine(raw: Mapping[str, Any] | None, bodies: Mapping[str, Any],
                 drives: Mapping[str, Any]) -> EngineSpec | None:
    """The validated ``[engine]`` table (None without one); ``bodies`` the system's bodies by
    name (the pistons must be point masses: ``kind == "point_mass"``), ``drives`` its joints
    with a drive by name."""
    if raw is None:
        return None
    t = Table("engine", raw)
    pistons = t.string_list("pistons")
    for name in pistons:
        if name not in bodies or bodies[name].kind != "point_mass":
            raise t.error("pistons", pistons, f"{name!r} is not a point-mass body of the system "
                          "(a piston is one)")
    if not pistons or len(set(pistons)) != len(pistons):
        raise t.error("pistons", pistons, "must name each cylinder's piston once, cylinder 1 "
                      "first")
    order = t.get("firing_order", list(range(1, len(pistons) + 1)))
    if (not isinstance(order, list) or not all(isinstance(k, int) for k in order)
            or sorted(order) != list(range(1, len(pistons) + 1))):
        raise t.error("firing_order", order, f"must name every cylinder 1 … {len(pistons)} once")
    towards = t.direction("towards_crank")
    drive = t.get("crank_drive")
    if not isinstance(drive, str) or drive not in drives:
        raise t.error("crank_drive", drive, "must be a joint with a drive (the crankshaft's): "
                      + (", ".join(drives) or "the system has none"))
    spec = EngineSpec(pistons=tuple(pistons),
                      bore_m=t.number("bore", low=0.0, high=MAX_BORE_M, low_open=True),
                      towards_crank=towards,
                      firing_order=tuple(order),
                      first_firing_deg=t.number("first_firing_deg", 0.0),
                      crank_drive=drive, pressure=_pressure(t),
                      ramp_time_s=t.number("ramp_time", 0.0, low=0.0))
    t.finish()
    return spec

