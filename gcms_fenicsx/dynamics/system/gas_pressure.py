"""Cylinder gas pressure over the four-stroke cycle and the force it puts on a piston
(docs/design.md §10, docs/assemblies.md).

φ ∈ [0°, 720°) is a cylinder's crank angle from its firing top dead centre: expansion
0–180°, exhaust 180–360°, intake 360–540°, compression 540–720°; every curve is periodic in
720°. A cylinder whose firing TDC is at the crankshaft's angle θ_k sees φ = θ − θ_k
(:func:`firing_angles`: an inline engine's cylinders fire 720°/n apart in their firing order).

:class:`PressureCurve` is a table (φ, p) interpolated linearly and periodically — a measured
curve, or :func:`petrol_full_load`, the built-in curve of a spark-ignition engine at full load
from a zero-dimensional model (J. B. Heywood, *Internal Combustion Engine Fundamentals*,
1988, §9.2 and §14.4):

- the volume V(φ)/V_c = 1 + (ε − 1)/2 (1 − cos φ + (1 − √(1 − λ² sin² φ))/λ) of a slider crank
  of compression ratio ε and crank-to-rod ratio λ;
- intake at p_in, exhaust at p_ex;
- compression and expansion as one polytrope p V^n = p_in V_bdc^n through bottom dead
  centre (540°);
- combustion as Wiebe's burned fraction x_b(φ) = 1 − exp(−a ((φ − φ_s)/Δφ)^(m+1)) from the
  spark at φ_s over Δφ, each burned share raising the pressure at its volume by the factor
  R (heat released at constant volume: p = p_poly (1 + (R − 1) x_b));
- the exhaust blow-down from φ_evo to 180° and the change from exhaust to intake pressure
  around 360° as smooth steps (a pressure jump would be a force step on the piston).

With ε = 10.5, λ = 0.3, n = 1.32, p_in = 1 bar, p_ex = 1.1 bar, spark 15° before TDC, Δφ =
40°, a = 6.9, m = 2, R = 4 and the exhaust opening 50° before bottom dead centre, its peak is
68.7 bar at 11.5° after TDC — the petrol engine's 60–80 bar some 10–15° after TDC — and its
indicated mean effective pressure ∮ p dV / V_d is 11.0 bar, a naturally aspirated petrol
engine's at full load (``tests/dynamics/test_gas_pressure.py``).

The force on a piston of bore D is (p − p_ambient) π D²/4 along the cylinder axis, towards
the crank (:func:`piston_force_n`). NumPy only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Callable

import numpy as np

from gcms_fenicsx.dynamics.system import checks

CYCLE_DEG = 720.0
BAR = 1e5


@dataclass(frozen=True)
class PressureCurve:
    """Cylinder pressure (Pa) against φ (degrees, ascending within [0, 720)), periodic."""

    angles_deg: np.ndarray
    pressures_pa: np.ndarray

    def __post_init__(self) -> None:
        a, p = np.asarray(self.angles_deg, float), np.asarray(self.pressures_pa, float)
        if a.ndim != 1 or a.shape != p.shape or len(a) < 2:
            raise ValueError("a pressure curve needs at least two angles and as many pressures, "
                             f"got {a.shape} angles and {p.shape} pressures")
        if not (np.isfinite(a).all() and np.isfinite(p).all()):
            raise ValueError("a pressure curve's angles and pressures must be finite numbers")
        if a[0] < 0 or a[-1] >= CYCLE_DEG or (np.diff(a) <= 0).any():
            raise ValueError("a pressure curve's angles must ascend within [0°, 720°), got "
                             f"{a[0]:g}° … {a[-1]:g}°")
        if (p < 0).any():
            raise ValueError(f"a pressure curve's pressures must be ≥ 0 Pa, got {p.min():g} Pa")
        object.__setattr__(self, "angles_deg", a)
        object.__setattr__(self, "pressures_pa", p)

    @cached_property
    def _closed(self) -> tuple[np.ndarray, np.ndarray]:
        """The table closed over the cycle once: its last point 720° before its first, its first
        720° after its last, so that every φ in [0°, 720°) lies inside it."""
        a, p = self.angles_deg, self.pressures_pa
        return (np.concatenate([[a[-1] - CYCLE_DEG], a, [a[0] + CYCLE_DEG]]),
                np.concatenate([[p[-1]], p, [p[0]]]))

    def __call__(self, phi_deg: float | np.ndarray) -> float | np.ndarray:
        """p(φ) (Pa), φ taken modulo 720°: linear between the table's points, periodic."""
        return np.interp(np.mod(phi_deg, CYCLE_DEG), *self._closed)

    @property
    def peak(self) -> tuple[float, float]:
        """(the largest pressure, Pa; its angle, degrees)."""
        k = int(np.argmax(self.pressures_pa))
        return float(self.pressures_pa[k]), float(self.angles_deg[k])


def volume_ratio(phi_deg: np.ndarray, compression_ratio: float, crank_rod: float) -> np.ndarray:
    """V(φ)/V_c of a slider crank (module docstring)."""
    phi = np.radians(phi_deg)
    s = np.sin(phi)
    stroke = 1.0 - np.cos(phi) + (1.0 - np.sqrt(1.0 - crank_rod ** 2 * s * s)) / crank_rod
    return 1.0 + 0.5 * (compression_ratio - 1.0) * stroke


def _smooth_step(x: np.ndarray, start: float, end: float) -> np.ndarray:
    """0 before ``start``, 1 after ``end``, 3s² − 2s³ between."""
    s = np.clip((x - start) / (end - start), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def petrol_full_load(compression_ratio: float = 10.5, crank_rod: float = 0.3,
                     polytropic: float = 1.32, intake_pa: float = 1.0 * BAR,
                     exhaust_pa: float = 1.1 * BAR, spark_deg: float = -15.0,
                     burn_deg: float = 40.0, pressure_ratio: float = 4.0,
                     exhaust_opens_deg: float = 130.0, step_deg: float = 0.5) -> PressureCurve:
    """The built-in full-load petrol curve (module docstring), tabulated every ``step_deg``;
    ValueError naming a keyword outside what the model means."""
    if not compression_ratio > 1:
        raise ValueError(f"compression_ratio must be > 1, got {compression_ratio!r}")
    checks.within("crank_rod (crank radius / rod length)", crank_rod, 1e-3, 0.999)
    checks.within("polytropic", polytropic, 1.0, 1.67)
    checks.positive("intake_pa", intake_pa)
    checks.positive("exhaust_pa", exhaust_pa)
    checks.within("spark_deg (before TDC: negative)", spark_deg, -90.0, 0.0)
    checks.within("burn_deg", burn_deg, 1.0, 180.0)
    checks.within("pressure_ratio", pressure_ratio, 1.0, 20.0)
    checks.within("exhaust_opens_deg", exhaust_opens_deg, 90.0, 179.0)
    checks.within("step_deg", step_deg, 1e-3, 10.0)
    phi = np.arange(0.0, CYCLE_DEG, step_deg)
    bdc = volume_ratio(np.array([180.0]), compression_ratio, crank_rod)[0]
    polytrope = intake_pa * (bdc / volume_ratio(phi, compression_ratio, crank_rod)) ** polytropic
    since_spark = np.mod(phi - spark_deg, CYCLE_DEG)
    burned = np.where(since_spark < 360.0, 1.0 - np.exp(-6.9 * (since_spark / burn_deg) ** 3), 0.0)
    closed = polytrope * (1.0 + (pressure_ratio - 1.0) * burned)    # valves shut
    blow_down = _smooth_step(phi, exhaust_opens_deg, 180.0)
    expansion = (1.0 - blow_down) * closed + blow_down * exhaust_pa
    gas_exchange = exhaust_pa + (intake_pa - exhaust_pa) * _smooth_step(phi, 340.0, 380.0)
    pressure = np.where(phi < 180.0, expansion, np.where(phi < 540.0, gas_exchange, closed))
    return PressureCurve(phi, pressure)


def firing_angles(order: tuple[int, ...], first_deg: float = 0.0) -> dict[int, float]:
    """Crankshaft angle (degrees) of each cylinder's firing TDC: cylinder ``order[k]`` fires
    k · 720°/n after ``order[0]`` (an even-firing engine; 1-3-4-2 for an inline four)."""
    if not order or sorted(order) != list(range(1, len(order) + 1)):
        raise ValueError(f"a firing order names every cylinder 1 … n once, got {list(order)}")
    spacing = CYCLE_DEG / len(order)
    return {cylinder: math.fmod(first_deg + k * spacing, CYCLE_DEG)
            for k, cylinder in enumerate(order)}


def piston_force_n(curve: PressureCurve, bore_m: float, phi_deg: float | np.ndarray,
                   ambient_pa: float = 1.0 * BAR) -> float | np.ndarray:
    """(p(φ) − p_ambient) π D²/4 (N), positive towards the crank."""
    return (curve(phi_deg) - ambient_pa) * math.pi * bore_m ** 2 / 4.0


def indicated_work_j(curve: PressureCurve, bore_m: float, crank_m: float, rod_m: float,
                     intervals: int = 72_000) -> float:
    """One cylinder's gas work over a cycle, ∮ (p(φ) − 1 bar) A dx_p, along the exact
    kinematics of its slider crank, x_p = r cos φ + √(L² − r² sin² φ) (r the crank radius,
    L the rod's length, x_p the piston pin from the crank's axis), by the trapezoidal rule
    over ``intervals`` steps of the 720° cycle: IMEP · V_d (less the ambient's zero work)."""
    checks.positive("crank_m", crank_m)
    checks.within("rod_m (longer than the crank)", rod_m, crank_m * (1.0 + 1e-9), math.inf)
    phi = np.linspace(0.0, 4.0 * math.pi, int(intervals) + 1)
    x = crank_m * np.cos(phi) + np.sqrt(rod_m ** 2 - (crank_m * np.sin(phi)) ** 2)
    force = piston_force_n(curve, bore_m, np.degrees(phi))
    return float(np.sum(0.5 * (force[1:] + force[:-1]) * -np.diff(x)))


@dataclass(frozen=True)
class Cylinder:
    """A cylinder whose piston is the point mass ``piston`` of an assembly: its bore (m), the
    unit direction from the piston towards the crank (the gas pushes along it), the
    crankshaft angle of its firing TDC (degrees) and its pressure curve."""

    piston: str
    bore_m: float
    towards_crank: np.ndarray
    firing_deg: float
    curve: PressureCurve

    def __post_init__(self) -> None:
        checks.positive(f"cylinder {self.piston!r}: bore_m", self.bore_m)
        unit = checks.vector(f"cylinder {self.piston!r}: towards_crank", self.towards_crank)
        if abs(np.linalg.norm(unit) - 1.0) > 1e-9:
            raise ValueError(f"cylinder {self.piston!r}: towards_crank must be a unit vector, "
                             f"got {self.towards_crank!r} (length {np.linalg.norm(unit):g})")
        object.__setattr__(self, "towards_crank", unit)


def cylinder_loads(offsets: dict[str, slice], dofs: int, cylinders: tuple[Cylinder, ...],
                   crank_angle_deg: Callable[[float], float]) -> Callable[[float], np.ndarray]:
    """t ↦ the gas forces on the pistons (the assembly's generalized force, N), each cylinder
    at φ = θ(t) − its firing angle, θ the crankshaft's angle (degrees) at t (``stepper.Loads``:
    a driven crankshaft's drive angle, or Ω t)."""
    for c in cylinders:
        checks.known("member", c.piston, "the assembly", offsets)
        if offsets[c.piston].stop - offsets[c.piston].start != 3:
            raise ValueError(f"cylinder {c.piston!r}: a piston is a point mass of the assembly")

    def loads(t: float) -> np.ndarray:
        f = np.zeros(dofs)
        theta = crank_angle_deg(t)
        for c in cylinders:
            f[offsets[c.piston]] += piston_force_n(c.curve, c.bore_m,
                                                   theta - c.firing_deg) * c.towards_crank
        return f
    return loads
