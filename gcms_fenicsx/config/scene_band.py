"""The band of frequencies a scene can excite: what ``[modes] count = "auto"`` keeps.

A body's elastic modes matter to a scene up to a few times the highest frequency the scene
drives them at; above what the time step resolves they cost coordinates and add nothing
(generalized-α damps them as ρ∞ says). So the band is

    f_band = min(BAND_FACTOR · f_excitation, f_step),

- f_excitation = the highest harmonic load frequency plus the highest drive speed Ω/2π: a
  load fixed in space acts on a body turning at Ω/2π at f ± Ω/2π in the body's frame, so a
  constant load on a driven shaft excites Ω/2π (the shaft's first order) and a harmonic one
  its frequency plus that;
- f_step = 1/(STEPS_PER_PERIOD · h): generalized-α resolves a period of ten steps with a
  period error of (ωh)²/12 ≈ 3 %;

and ``count = "auto"`` takes every elastic mode below f_band, at least one (a band below
the first mode keeps the first: the body is then nearly rigid to the scene, and the one
mode carries its quasi-static deflection as well as it can). BAND_FACTOR = 2 is the usual
rule of modal truncation (modes up to twice the highest excitation frequency), the value
``workflows/auto_modes.py`` measures on the default scene (README). No NumPy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gcms_fenicsx.config.scene import Scene

#: Elastic modes up to this multiple of the highest excitation frequency are kept.
BAND_FACTOR = 2.0
#: Steps per period for generalized-α to resolve it (period error (ωh)²/12 ≈ 3 %).
STEPS_PER_PERIOD = 10


@dataclass(frozen=True)
class Band:
    """The band of ``count = "auto"``: its upper end, what set it, and the two bounds."""

    max_frequency_hz: float
    set_by: str             # "loads", "drive" or "time step"
    excitation_hz: float
    resolved_hz: float
    factor: float = BAND_FACTOR

    def to_json(self) -> dict:
        return {"max_frequency_hz": self.max_frequency_hz, "set_by": self.set_by,
                "excitation_hz": self.excitation_hz, "resolved_hz": self.resolved_hz,
                "factor": self.factor, "steps_per_period": STEPS_PER_PERIOD}


def scene_band(scene: Scene) -> Band:
    """The band of frequencies ``scene`` excites (module docstring)."""
    drive_hz = max((abs(j.drive.angular_velocity) for j in scene.joints if j.drive is not None),
                   default=0.0) / (2.0 * math.pi)
    load_hz = max((load.frequency_hz for load in scene.loads), default=0.0)
    excitation = load_hz + drive_hz
    resolved = 1.0 / (STEPS_PER_PERIOD * scene.time_step_s)
    if excitation == 0.0 or BAND_FACTOR * excitation >= resolved:
        return Band(resolved, "time step", excitation, resolved)
    return Band(BAND_FACTOR * excitation, "loads" if load_hz >= drive_hz else "drive",
                excitation, resolved)
