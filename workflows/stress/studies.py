"""The studies the suite runs, as nested dicts written out as TOML files: the generic beam
and pendulum scene, the built-in default study, and each probe class's bodies and ranges."""
from __future__ import annotations

import json
import math
import tomllib
from typing import Any

import numpy as np

from stress import REPO

STEEL = {"E": 210e9, "nu": 0.3, "rho": 7850.0}

# 1. symmetry perturbation (and 2. units and size: the same beam)
SIDE_M, BEAM_LENGTH_M, SQUARE_SIZE_M, SQUARE_MODES = 0.03, 0.5, 0.0075, 10
EPSILONS = (0.0, 1e-6, 1e-4, 1e-3, 1e-2, 0.1)
PENDULUM_END_S, PENDULUM_STEP_S = 0.2, 1e-3
CUT_PAIR_MODES = 6
# 3. slenderness
SLENDERNESS = (10, 30, 100, 200, 500, 1000)
THICK_M = 0.01
# 4. many modes
MODE_COUNTS = (10, 20, 50, 100)
SHORT_STEPS = 200
# 5. long runs
LONG_STEPS = 20_000
DRIVE_FACTORS = (1, 3, 10)
# 6. material extremes (7. MPI ranks: the same beam)
NUS = (0.3, 0.45, 0.49, 0.499)
E_VALUES = tuple(10.0 ** k for k in range(5, 16))
E_REFERENCE = 1e10
MAT_B, MAT_H, MAT_L = 0.03, 0.02, 0.5   # width (y), height (z), length


def toml_value(v: Any) -> str:
    """One TOML value: numbers, strings, booleans, arrays and inline tables."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if math.isnan(v):
            return "nan"
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML form for {v!r}")


def toml_text(study: dict) -> str:
    """The study (tables as nested dicts, arrays of tables as lists of dicts) as a TOML file."""
    lines: list[str] = []
    for name, table in study.items():
        if isinstance(table, list):             # a top-level array of tables ([[joints]])
            for item in table:
                lines += [f"[[{name}]]", *(f"{k} = {toml_value(v)}" for k, v in item.items()),
                          ""]
            continue
        arrays = {k: v for k, v in table.items()
                  if isinstance(v, list) and v and all(isinstance(x, dict) for x in v)}
        lines.append(f"[{name}]")
        lines += [f"{k} = {toml_value(v)}" for k, v in table.items() if k not in arrays]
        for key, items in arrays.items():
            for item in items:
                lines += ["", f"[[{name}.{key}]]"]
                lines += [f"{k} = {toml_value(v)}" for k, v in item.items()]
        lines.append("")
    return "\n".join(lines)


def beam_study(section: str, dims: dict, length: float, size: float, modes: int,
               material: dict | None = None) -> dict:
    """A beam of ``section`` (its dimensions ``dims``) along x, meshed at ``size`` with P2
    elements, of ``material`` (steel by default), with ``modes`` elastic modes."""
    return {"geometry": {"kind": "beam", "section": section, **dims, "length": length},
            "mesh": {"size": size, "order": 2},
            "material": dict(STEEL if material is None else material),
            "modes": {"count": modes}}


def pendulum_scene(end_time: float, step: float, gravity: float = 9.81) -> dict:
    """Pinned at end face x = 0 by a revolute joint about y, released horizontally at rest."""
    return {"end_time": end_time, "time_step": step, "gravity": [0.0, 0.0, -gravity],
            "outputs": {"groups": ["end_xL"]},
            "joints": [{"type": "revolute", "group": "end_x0", "axis": [0.0, 1.0, 0.0]}]}


def default_study() -> dict:
    """The built-in default study of ``gcms run`` (the driven inline-4 crankshaft)."""
    return tomllib.loads((REPO / "gcms_fenicsx" / "data" / "default.toml").read_text())


def mm_t_s(study: dict) -> dict:
    """The study in mm, t, s: lengths ×1e3, E in MPa, ρ in t/mm³, gravity in mm/s²."""
    s = json.loads(json.dumps(study))
    g = s["geometry"]
    for key in ("side", "width", "height", "length"):
        if key in g:
            g[key] *= 1e3
    s["mesh"]["size"] *= 1e3
    s["material"]["E"] *= 1e-6        # Pa = N/m² → N/mm² = MPa
    s["material"]["rho"] *= 1e-12     # kg/m³ → t/mm³ (1e-3 t / 1e9 mm³)
    if "scene" in s:
        s["scene"]["gravity"] = [1e3 * x for x in s["scene"]["gravity"]]
    return s


def square_beam(width_factor: float = 1.0, scale: float = 1.0, section: str = "rectangle",
                material: dict | None = None) -> dict:
    """The steel square beam (30 mm, 0.5 m, 7.5 mm P2 mesh, ten modes) as a rectangle of width
    side·width_factor, all lengths times ``scale``."""
    dims = ({"side": SIDE_M * scale} if section == "square" else
            {"width": SIDE_M * width_factor * scale, "height": SIDE_M * scale})
    return beam_study(section, dims, BEAM_LENGTH_M * scale, SQUARE_SIZE_M * scale,
                      SQUARE_MODES, material)


def swinging_square_beam(width_factor: float = 1.0, modes: int = SQUARE_MODES) -> dict:
    """:func:`square_beam` widened by ``width_factor`` with ``modes`` modes, swinging as the
    pendulum of :func:`pendulum_scene` for 0.2 s."""
    study = square_beam(width_factor)
    study["modes"] = {"count": modes}
    study["scene"] = pendulum_scene(PENDULUM_END_S, PENDULUM_STEP_S)
    return study


def slender_beam(lh: int) -> tuple[dict, float]:
    """The 10 mm square steel beam of L/h = ``lh`` with four modes and its mesh size (h/2 up to
    L/h = 200, h above)."""
    size = THICK_M / 2 if lh <= 200 else THICK_M
    return beam_study("square", {"side": THICK_M}, THICK_M * lh, size, 4), size


def modes_beam(nm: int) -> dict:
    """The 50×40 mm × 1 m steel beam with ``nm`` modes and a pendulum scene of SHORT_STEPS."""
    study = beam_study("rectangle", {"width": 0.05, "height": 0.04}, 1.0, 0.01, nm)
    study["scene"] = pendulum_scene(SHORT_STEPS * 1e-4, 1e-4)
    return study


def modes_crankshaft(nm: int) -> dict:
    """The default crankshaft with ``nm`` modes and SHORT_STEPS of its scene."""
    study = default_study()
    study["modes"] = {"count": nm}
    study["scene"]["end_time"] = SHORT_STEPS * study["scene"]["time_step"]
    return study


def flexible_pendulum(steps: int) -> dict:
    """The flexible pendulum of gcms_fenicsx.pendulum.STUDY (a soft 1 m polymer beam, 20 mm
    square) swinging for ``steps`` steps of 1 ms."""
    study = beam_study("square", {"side": 0.02}, 1.0, 0.01, 10,
                       {"E": 1.0e8, "nu": 0.35, "rho": 1150.0})
    return dict(study, scene=pendulum_scene(steps * 1e-3, 1e-3))


def driven_crankshaft(factor: float, steps: int | None = None, step_factor: float = 1.0) -> dict:
    """The default crankshaft study with its drive ×``factor``, its time step ×``step_factor``
    (outputs kept at the same times) and, when ``steps`` is given, that many steps of the
    original time step."""
    study = default_study()
    scene = study["scene"]
    if steps is not None:
        scene["end_time"] = steps * scene["time_step"]
    if step_factor != 1.0:
        scene["time_step"] *= step_factor
        scene["outputs"]["every"] = round(scene["outputs"].get("every", 1) / step_factor)
    scene["joints"][0]["drive"]["angular_velocity"] *= factor
    return study


def rotation_per_step(study: dict) -> float:
    """How far the drive of ``study``'s first joint turns in one time step, rad."""
    scene = study["scene"]
    return scene["joints"][0]["drive"]["angular_velocity"] * scene["time_step"]


def material_beam(material: dict, size: float) -> dict:
    """The 30×20 mm × 0.5 m beam of ``material`` meshed at ``size`` with six modes."""
    return beam_study("rectangle", {"width": MAT_B, "height": MAT_H}, MAT_L, size, 6, material)
