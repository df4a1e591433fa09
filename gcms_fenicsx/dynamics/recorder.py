"""What a simulation records while it runs, and the energy balance it keeps every step.

Energy (all in J): kinetic T = ½ q̇ᵀ Mr q̇, elastic V (co-rotated), gravity potential
V_g = −q · f_g, and the work integrals, accumulated by the trapezoidal rule over every
step (not only recorded ones): the loads' work ∫ f_load · q̇ dt, the constraint forces'
work ∫ −λ · (C q̇) dt (a drive's work; ~0 for fixed joints) and the damping dissipation
∫ ėᵀ D ė dt. The balance error

    (T + V + V_g)(t) − (T + V + V_g)(0) − W_load − W_constraint + D

is zero for the exact solution; the integrator's numerical dissipation (ρ∞ < 1) and its
error show up in it (:attr:`Extremes.energy_drift`).

Rows are filled into a buffer of :attr:`RecordPlan.block_rows` rows (``results.block_rows``)
and handed to a sink
(``results``: memory or a streamed file) when it is full, so what the recorder holds does
not grow with the run; the maxima the summary reports are kept as the blocks pass.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.state import State, StepInfo
from gcms_fenicsx.dynamics.joints import Constraints
from gcms_fenicsx.dynamics.loads import ExternalForces
from gcms_fenicsx.dynamics.results import (ENERGY_NAMES, MULTIPLIERS, Series, Sink, block_rows,
                                           series_layout)
from gcms_fenicsx.dynamics.scene import Outputs, Scene


@dataclass(frozen=True)
class RecordPlan:
    """What a run will record, known before it starts: the series, the number of steps and
    of recorded rows (at most), the field snapshots (step indices) and the block size."""

    layout: tuple[Series, ...]
    steps: int
    rows: int
    snapshot_steps: frozenset[int]
    nodes: int
    block_rows: int

    @property
    def row_bytes(self) -> int:
        return sum(s.row_bytes for s in self.layout)

    @property
    def series_bytes(self) -> int:
        return self.rows * self.row_bytes

    @property
    def snapshot_bytes(self) -> int:
        """The snapshots (time and N × 3 displacements each) and the nodes they refer to."""
        per_node = 3 * 8
        return len(self.snapshot_steps) * (8 + self.nodes * per_node) + (
            self.nodes * per_node if self.snapshot_steps else 0)

    @property
    def total_bytes(self) -> int:
        return self.series_bytes + self.snapshot_bytes


def recorded_rows(steps: int, every: int) -> int:
    """Rows of a run of ``steps`` steps recording steps 0, every, 2·every, … and the last."""
    return steps // every + 1 + (1 if steps % every else 0)


def record_plan(body: Body, constraints: Constraints, scene: Scene) -> RecordPlan:
    """The plan of what ``scene`` records on ``body`` with ``constraints``."""
    out, steps = scene.outputs, scene.steps
    layout = series_layout(out.groups, out.energy,
                           constraints.count if out.constraint_forces else 0,
                           body.dofs if out.coordinates else 0)
    rows = recorded_rows(steps, out.every)
    snapshots = frozenset(min(steps, int(round(t / scene.time_step_s))) for t in out.field_times)
    return RecordPlan(layout=layout, steps=steps, rows=rows, snapshot_steps=snapshots,
                      nodes=len(body.nodes_m), block_rows=block_rows(layout, rows))


class Extremes:
    """The maxima over the recorded rows that the summary reports, kept as blocks pass."""

    def __init__(self) -> None:
        self.rows = 0
        self.iterations = 0
        self.energy = False
        self.balance = 0.0          # max |balance error|
        self.motion = -math.inf     # max (kinetic + elastic)
        self.load_work = 0.0        # max |load work|
        self.constraint_work = 0.0  # max |constraint work|
        self.momentum0: np.ndarray | None = None
        self.momentum_change = 0.0  # max |p − p0| (componentwise)

    def update(self, block: Mapping[str, np.ndarray]) -> None:
        self.rows += len(block["time"])
        self.iterations = max(self.iterations, int(block["newton_iterations"].max(initial=0)))
        p = block["momentum/linear"]
        if self.momentum0 is None:
            self.momentum0 = p[0].copy()
        self.momentum_change = max(self.momentum_change,
                                   float(np.abs(p - self.momentum0).max()))
        if "energy/kinetic" in block:
            self.energy = True
            self.balance = max(self.balance, float(np.max(np.abs(block["energy/balance_error"]))))
            self.motion = max(self.motion, float(np.max(block["energy/kinetic"]
                                                        + block["energy/elastic"])))
            self.load_work = max(self.load_work, float(np.max(np.abs(block["energy/load_work"]))))
            self.constraint_work = max(self.constraint_work,
                                       float(np.max(np.abs(block["energy/constraint_work"]))))

    @property
    def energy_drift(self) -> float | None:
        """max |balance error| over the run / max (kinetic + elastic, |load work|, |constraint
        work|): the relative energy drift; None without energies or with one row."""
        if not self.energy or self.rows < 2:
            return None
        scale = max(self.motion, self.load_work, self.constraint_work)
        return self.balance / scale if scale > 0 else self.balance


class Recorder:
    """Rows for the steps ``0, every, 2·every, …`` and the last one, handed to ``sink`` in
    blocks of ``plan.block_rows``; field snapshots at ``plan.snapshot_steps``."""

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 outputs: Outputs, plan: RecordPlan, time_step_s: float, sink: Sink) -> None:
        self.body, self.c, self.forces, self.out = body, constraints, forces, outputs
        self.plan, self.sink = plan, sink
        self.h = time_step_s
        self.buffer = {s.name: np.zeros((plan.block_rows, *s.shape), s.dtype)
                       for s in plan.layout}
        b = self.buffer
        self.filled = 0
        self.last_time: float | None = None
        self.extremes = Extremes()
        self.groups = [(body.groups[g], b[f"groups/{g}/position"], b[f"groups/{g}/velocity"])
                       for g in outputs.groups]
        self.energy = {n: b[f"energy/{n}"] for n in ENERGY_NAMES} if outputs.energy else {}
        self.multipliers = b[MULTIPLIERS] if b[MULTIPLIERS].shape[1] else None
        self.coordinates = ((b["coordinates/q"], b["coordinates/v"]) if outputs.coordinates
                            else None)
        self._work = np.zeros(3)     # load, constraint, damping
        self._power: np.ndarray | None = None
        self._initial_energy = 0.0

    def _powers(self, s: State, info: StepInfo) -> np.ndarray:
        # f_ext without gravity: the loads, whose power is their work rate
        load = float((info.external_force - self.forces.gravity_force) @ s.v) \
            if self.forces.loads else 0.0
        constraint = -float(s.lam @ self.c.values(s.v, info.directions)) if self.c.count else 0.0
        return np.array([load, constraint, info.dissipation_w])

    def step(self, index: int, s: State, info: StepInfo, last: bool = False) -> None:
        """Account for step ``index`` (0 = initial state) and record it if it is due."""
        if self.energy:
            power = self._powers(s, info)
            if self._power is not None:
                self._work += 0.5 * self.h * (self._power + power)
            self._power = power
        if index in self.plan.snapshot_steps:
            self.sink.snapshot(s.t, self.body.displacement(s.q))
        if last or index % self.out.every == 0:
            self.record(s, info)

    def record(self, s: State, info: StepInfo) -> None:
        """Write a row for a state already accounted for by :meth:`step`."""
        k = self.filled
        b = self.buffer
        b["time"][k] = s.t
        b["newton_iterations"][k] = info.iterations
        Q, V = s.q.reshape(-1, 3), s.v.reshape(-1, 3)
        for rows, pos, vel in self.groups:
            pos[k] = Q.T @ rows.position
            vel[k] = V.T @ rows.position
        kinetic, b["momentum/linear"][k], b["momentum/angular"][k] = self.body.momenta(s.q, s.v)
        if self.multipliers is not None:
            self.multipliers[k] = s.lam
        if self.coordinates is not None:
            self.coordinates[0][k], self.coordinates[1][k] = s.q, s.v
        if self.energy:
            e = self.energy
            e["kinetic"][k] = kinetic
            e["elastic"][k] = info.elastic.energy
            e["gravity"][k] = self.forces.gravity_potential(s.q)
            e["load_work"][k], e["constraint_work"][k], e["damping_dissipation"][k] = self._work
            total = e["kinetic"][k] + e["elastic"][k] + e["gravity"][k]
            if self.last_time is None:
                self._initial_energy = total
            e["balance_error"][k] = (total - self._initial_energy - self._work[0]
                                     - self._work[1] + self._work[2])
        self.last_time = s.t
        self.filled += 1
        if self.filled == len(b["time"]):
            self.flush()

    def flush(self) -> None:
        """Hand the buffered rows to the sink."""
        if self.filled:
            block = {name: rows[:self.filled] for name, rows in self.buffer.items()}
            self.extremes.update(block)
            self.sink.append(block)
            self.filled = 0
