"""A run of an assembly: the steps from t = 0, the rows it records, and its energy balance
(docs/design.md §10).

Energy (J), as the single body's recorder keeps it (``run.recorder``): kinetic T = ½ q̇ᵀ Mr q̇,
the members' elastic energy V, the gravity potential −q · f_g, and the work integrals
accumulated by the trapezoidal rule over every step: the loads' ∫ f_load · q̇ dt, the
rows' ∫ −λ · (C q̇) dt (a path's work: a driven crank's) and the damping's dissipation
D = ∫ ėᵀ D₀ ė dt. The balance error (T + V + V_g)(t) − (T + V + V_g)(0) − W_load − W_rows
+ D is zero for the exact solution, and the relative drift is its largest magnitude over the
largest of T + V, the two works and D.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.stepping.errors import IntegrationError
from gcms_fenicsx.dynamics.stepping.state import State
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper
from gcms_fenicsx.runtime.progress import Progress, quiet

#: A recorded quantity: the state ↦ an array (its shape fixed over the run).
Probe = Callable[[State], np.ndarray]


@dataclass(frozen=True)
class AssemblyRun:
    """The recorded rows (every ``every``-th step and the last) and the run's totals."""

    time_s: np.ndarray
    multipliers: np.ndarray          # λ (rows, m)
    iterations: np.ndarray           # Newton iterations of the recorded steps
    energy: dict[str, np.ndarray]    # kinetic, elastic, gravity, load_work, row_work,
    #                                  damping_dissipation, balance
    probes: dict[str, np.ndarray]
    steps: int
    newton_iterations: int           # over every step
    wall_time_s: float               # the stepping alone
    velocity_change: float           # initial_state's relative change of q̇
    complete: bool = True            # False: a step failed; the rows end before it
    message: str = ""                # why it stopped

    @property
    def energy_drift_rel(self) -> float:
        """max |balance error| / max(T + V, |W_load|, |W_rows|, D) (module docstring)."""
        e = self.energy
        scale = max(float(np.max(e["kinetic"] + e["elastic"])),
                    float(np.max(np.abs(e["load_work"]))), float(np.max(np.abs(e["row_work"]))),
                    float(np.max(e["damping_dissipation"])))
        return float(np.max(np.abs(e["balance"]))) / scale if scale > 0 else 0.0


class StoppedEarly(IntegrationError):
    """A step failed: the IntegrationError's message and time, and ``run``, the rows up to
    the last step that converged (``complete`` False)."""

    def __init__(self, run: AssemblyRun, cause: IntegrationError) -> None:
        super().__init__(str(cause), cause.time_s)
        self.run = run

    def __reduce__(self):
        return (type(self), (self.run, IntegrationError(str(self), self.time_s)))


class _Energy:
    """The energy terms of a state, and the work integrals carried from step to step."""

    def __init__(self, stepper: AssemblyStepper) -> None:
        self.stepper = stepper
        self.load_work = self.row_work = self.dissipation = 0.0
        self.powers: tuple[float, float, float] | None = None
        self.start: float | None = None

    def terms(self, s: State, states: list) -> dict[str, float]:
        st = self.stepper
        a = st.assembly
        v = s.v
        load = st.external(s.t) - a.gravity_force
        C = st.C if st.C is not None else a.jacobian(s.q, s.t)
        powers = (float(load.dot(v)), -float(s.lam.dot(C.dot(v))),
                  st.damping(v, states)[1] if st.damped else 0.0)
        if self.powers is not None:
            self.load_work += 0.5 * st.h * (self.powers[0] + powers[0])
            self.row_work += 0.5 * st.h * (self.powers[1] + powers[1])
            self.dissipation += 0.5 * st.h * (self.powers[2] + powers[2])
        self.powers = powers
        kinetic = 0.5 * float(v.dot(a.mass.dot(v)))
        elastic = float(sum(x.energy for x in states if x is not None))
        gravity = -float(s.q.dot(a.gravity_force))
        total = kinetic + elastic + gravity
        if self.start is None:
            self.start = total
        return {"kinetic": kinetic, "elastic": elastic, "gravity": gravity,
                "load_work": self.load_work, "row_work": self.row_work,
                "damping_dissipation": self.dissipation,
                "balance": (total - self.start - self.load_work - self.row_work
                            + self.dissipation)}


def march(stepper: AssemblyStepper, start: tuple[State, float], end_time_s: float,
          every: int = 1, probes: dict[str, Probe] | None = None,
          progress: Progress = quiet) -> AssemblyRun:
    """Step from ``start`` (``stepper.initial_state``'s state and velocity change) to the first
    step at or beyond ``end_time_s``, recording every ``every``-th step (and the last) with
    ``probes``. A step that fails (IntegrationError: Newton diverged or did not converge)
    ends the run there: :class:`StoppedEarly`, an IntegrationError, carries the rows up to
    the last step that converged (``complete`` False, ``message`` saying why)."""
    state, change = start
    probes = probes or {}
    # the run ends at the first step at or beyond the end time, as a scene's (Scene.steps)
    steps = max(1, math.ceil(checks.positive("end_time_s (s)", end_time_s) / stepper.h - 1e-9))
    if int(every) != every or every < 1:
        raise ValueError(f"every must be a whole number ≥ 1 of steps, got {every!r}")
    energy = _Energy(stepper)
    _, states = stepper.internal(state.q)
    rows = [_row(state, 0, energy.terms(state, states), probes)]
    total_iterations = 0
    begun = time.perf_counter()
    report_at = begun + 5.0
    stopped: IntegrationError | None = None
    done, watched = 0, bool(stepper.assembly.dropped_keys)
    for n in range(1, steps + 1):
        try:
            state, states, iterations = stepper.step(state)
        except IntegrationError as exc:     # the rows so far are the run's, marked incomplete
            stopped = exc
            break
        done, total_iterations = n, total_iterations + iterations
        terms = energy.terms(state, states)
        stopped = _dropped_rows_hold(stepper.assembly, state) if watched else None
        if n % every == 0 or n == steps or stopped is not None:
            rows.append(_row(state, iterations, terms, probes))
        if stopped is not None:
            break
        if time.perf_counter() > report_at:
            progress(f"assembly: t = {state.t:.4g} of {end_time_s:g} s ({n} steps)")
            report_at += 5.0
    if stopped is not None and done % every and done != steps and rows[-1][0] != state.t:
        rows.append(_row(state, iterations, terms, probes))     # the last step that converged
    wall = time.perf_counter() - begun
    run = AssemblyRun(
        time_s=np.array([r[0] for r in rows]), multipliers=np.array([r[1] for r in rows]),
        iterations=np.array([r[2] for r in rows]),
        energy={k: np.array([r[3][k] for r in rows]) for k in rows[0][3]},
        probes={k: np.array([r[4][k] for r in rows]) for k in probes},
        steps=done, newton_iterations=total_iterations, wall_time_s=wall,
        velocity_change=change, complete=stopped is None,
        message="" if stopped is None else str(stopped))
    if stopped is not None:
        raise StoppedEarly(run, stopped) from stopped
    return run


#: A row dropped at the start as implied by the others may stray by this much of the
#: largest member's size (m; rad for a moment row) before the run says it no longer holds:
#: far above an elastic member's deflection from a rigid implication, far below a mechanism
#: leaving a guide it was only tangent to at a dead centre.
DROPPED_ROW_SLACK = 1e-3


def _dropped_rows_hold(a: Any, s: State) -> IntegrationError | None:
    """None while every row dropped at the start stays within :data:`DROPPED_ROW_SLACK` of
    holding; else the IntegrationError that ends the run: such a row was implied by the
    others only at the start (a dead centre: the guide is tangent to the crank's circle there),
    or the mass that made it so is too small to count, and nothing holds its joint."""
    gap = a.dropped_gap(s.q, s.t)
    if not gap.size:
        return None
    limits = np.array([DROPPED_ROW_SLACK * (a.size_m if r.kind == "force" else 1.0) + 1e-12
                       for r in a.dropped])
    worst = int(np.argmax(np.abs(gap) / limits))
    if abs(gap[worst]) <= limits[worst]:
        return None
    row = a.dropped[worst]
    return IntegrationError(
        f"joint {row.joint.split('/')[0]!r}: its row along {np.round(row.axis, 3).tolist()}, "
        f"dropped at the start as implied by the other joints, no longer holds at t = "
        f"{s.t:.6g} s (off by {abs(gap[worst]):.3g} {'m' if row.kind == 'force' else 'rad'}): "
        "it was implied only at the start (a dead centre?) or by a mass too small to count; "
        "start the mechanism away from that position, or remove the joint", s.t)


def _row(s: State, iterations: int, terms: dict[str, float], probes: dict[str, Probe]) -> tuple:
    return (s.t, s.lam.copy(), iterations, terms,
            {k: np.array(p(s), float) for k, p in probes.items()})
