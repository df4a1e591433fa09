"""What a simulation records while it runs, and the energy balance it keeps every step.

Energy (all in J): kinetic T = ½ q̇ᵀ Mr q̇, elastic V (co-rotated), gravity potential
V_g = −q · f_g, and the work integrals, accumulated by the trapezoidal rule over every
step (not only recorded ones): the loads' work ∫ f_load · q̇ dt, the constraint forces'
work ∫ −λ · (C q̇) dt (a drive's work; ~0 for fixed joints) and the damping dissipation
∫ ėᵀ D ė dt. The balance error

    (T + V + V_g)(t) − (T + V + V_g)(0) − W_load − W_constraint + D

is zero for the exact solution; the integrator's numerical dissipation (ρ∞ < 1) and its
error show up in it (:attr:`Extremes.energy_drift`).

Rows are kept raw in a block of at most :attr:`RecordPlan.block_rows` rows
(``results.block_rows``), turned into the recorded series and handed to a sink (``results``:
memory or a streamed file) when it is full, so what the recorder holds does not grow with
the run and the time loop does no more per recorded step than copy the state; the maxima
the summary reports are kept as the blocks pass.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.run.stress_recovery import StressRecovery
from gcms_fenicsx.dynamics.stepping.state import State, StepInfo
from gcms_fenicsx.dynamics.constraints.joints import Constraints
from gcms_fenicsx.dynamics.bodies.loads import ExternalForces
from gcms_fenicsx.files.results import (BLOCK_BYTES, MULTIPLIERS, Series, Sink, block_rows,
                                           series_layout)
from gcms_fenicsx.config.scene import Outputs, Scene, Solver


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
    stress_steps: frozenset[int] = frozenset()

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


def record_plan(body: Body, constraints: Constraints, scene: Scene,
                stress: tuple[Series, ...] = ()) -> RecordPlan:
    """The plan of what ``scene`` records on ``body`` (the full basis) with
    ``constraints``, and the ``stress`` series (``stress_recovery``) if it asks for them."""
    out, steps = scene.outputs, scene.steps
    layout = series_layout(out.groups, out.energy,
                           constraints.count if out.constraint_forces else 0,
                           body.dofs if out.coordinates else 0) + stress
    rows = recorded_rows(steps, out.every)

    def nearest(times: tuple[float, ...]) -> frozenset[int]:
        return frozenset(min(steps, int(round(t / scene.time_step_s))) for t in times)

    return RecordPlan(layout=layout, steps=steps, rows=rows,
                      snapshot_steps=nearest(out.field_times), nodes=len(body.nodes_m),
                      block_rows=block_rows(layout, rows),
                      stress_steps=nearest(out.stress.times) if out.stress else frozenset())


#: The relative energy drift is measured against at least the kinetic energy of the whole
#: body moving this many Newton tolerances (at the default ``[scene] solver`` tolerance, 1e-10
#: of its size) in one step: a motion the solver does not resolve. In consistent units
#: (m L²/h² is an energy in SI and in mm-t-s alike). A body at rest then reports its
#: round-off (1e-19 J of 1e-19 J: the test beam) as a drift of 4e-8, not of 1.
ENERGY_FLOOR_TOLERANCES = 10.0


def energy_floor_j(body: Body, time_step_s: float) -> float:
    """The least energy scale of the relative drift (``ENERGY_FLOOR_TOLERANCES``)."""
    speed = ENERGY_FLOOR_TOLERANCES * Solver().tolerance * body.size_m / time_step_s
    return 0.5 * body.total_mass_kg * speed ** 2


class Extremes:
    """The maxima over the recorded rows that the summary reports, kept as blocks pass;
    ``floor_j`` is the least scale of the relative energy drift (:func:`energy_floor_j`)."""

    def __init__(self, floor_j: float = 0.0) -> None:
        self.floor_j = floor_j
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
        work|, ``floor_j``): the relative energy drift; None without energies or with one
        row. The floor keeps a body at rest, whose energies are all round-off, from reporting
        its round-off divided by itself."""
        if not self.energy or self.rows < 2:
            return None
        scale = max(self.motion, self.load_work, self.constraint_work, self.floor_j)
        return self.balance / scale if scale > 0 else self.balance

    @property
    def energy_drift_j(self) -> float | None:
        """max |balance error| over the run (J); None when :attr:`energy_drift` is."""
        return None if self.energy_drift is None else self.balance


class RawRows(NamedTuple):
    """The block of raw rows and the work integrals, as arrays: what a recorded step writes,
    in Python (:meth:`Recorder.step`) or in the compiled step (``stepping.compiled``), which
    keeps the same accounts in the same arrays. ``counters``: rows filled, whether ``power``
    holds the previous step's powers."""

    qv: np.ndarray             # (rows, 3, n): q, q̇ and Mr q̇; (rows, 2, n) where rows are p
    multipliers: np.ndarray    # (rows, m or 0)
    scalars: np.ndarray        # (rows, 6): t, Newton iterations, V, load, constraint, damping work
    work: np.ndarray           # (3,): load, constraint, damping work so far
    power: np.ndarray          # (3,): their powers at the last step accounted
    counters: np.ndarray       # int64 (2,)
    every: int
    last_step: int
    energy: bool
    loads: bool
    half_step: float


class Recorder:
    """Rows for the steps ``0, every, 2·every, …`` and the last one, handed to ``sink`` in
    blocks; field snapshots at ``plan.snapshot_steps``.

    In the time loop a step only adds its powers to the work integrals (the trapezoidal rule
    takes every step) and, when it is recorded, copies its raw row into preallocated arrays:
    q and q̇ in one copy, Mr q̇ where the rows are the body's own coordinates (the compiled step
    keeps it as it steps, the NumPy step's rows make it here, so a block's momenta need no
    product with G), λ, and a tuple of scalars (t, iterations, V, the works). The derived
    series (group positions, momenta, energies) are computed for a whole block of rows at
    once when it is handed on (:meth:`flush`). A block holds ``plan.block_rows`` rows, fewer
    where the raw rows of a large body would exceed ``BLOCK_BYTES``
    (docs/integrator_profile.md).

    ``lift``: B when the run's coordinates are p with q = B p (the rotor basis): the rows
    hold p, and every series, ``coordinates/q`` and ``coordinates/v`` too, is the full basis
    ``body``'s, taken at B p (so results.h5 reads with reduced.h5 in either basis; a body on
    static shapes in the full basis is its own model's, ``static_shapes.shape_model``, and so
    are its coordinates).

    ``stress``: the run's stress recovery (``stress_recovery``), fed every block of rows and
    the states of ``plan.stress_steps``.
    """

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 outputs: Outputs, plan: RecordPlan, time_step_s: float, sink: Sink,
                 lift: np.ndarray | None = None, stress: StressRecovery | None = None) -> None:
        self.body, self.c, self.forces, self.out = body, constraints, forces, outputs
        self.plan, self.sink, self.lift, self.stress = plan, sink, lift, stress
        n = body.dofs if lift is None else lift.shape[1]
        m = constraints.count if outputs.constraint_forces else 0
        kept = 3 if lift is None else 2          # with Mr q̇ for the momenta (:meth:`record`)
        rows = max(1, min(plan.block_rows, BLOCK_BYTES // (8 * (kept * n + m + 6))))
        self.raw = RawRows(qv=np.zeros((rows, kept, n)), multipliers=np.zeros((rows, m)),
                           scalars=np.zeros((rows, 6)), work=np.zeros(3), power=np.zeros(3),
                           counters=np.zeros(2, dtype=np.int64), every=outputs.every,
                           last_step=plan.steps, energy=outputs.energy,
                           loads=bool(forces.loads), half_step=0.5 * time_step_s)
        self.last_time: float | None = None
        self.extremes = Extremes(energy_floor_j(body, time_step_s))
        self._initial_energy: float | None = None

    @property
    def filled(self) -> int:
        """Rows in the block not yet handed to the sink."""
        return int(self.raw.counters[0])

    def step(self, index: int, s: State, info: StepInfo, last: bool = False) -> None:
        """Account for step ``index`` (0 = initial state) and record it if it is due: add the
        powers of the loads (f_ext without gravity), of the constraint forces (−λ · C q̇) and
        of the damping to the work integrals (the trapezoidal rule over every step)."""
        raw = self.raw
        if raw.energy:
            v = s.Z[1]
            load = (info.external_force - self.forces.gravity_force).dot(v) if raw.loads \
                else 0.0
            constraint = -s.lam.dot(info.jacobian.dot(v)) if info.jacobian is not None else 0.0
            power, w = raw.power, raw.work
            if raw.counters[1]:
                w += raw.half_step * (power + (load, constraint, info.dissipation_w))
            power[:] = load, constraint, info.dissipation_w
            raw.counters[1] = 1
        self.snapshot(index, s)
        if last or index % raw.every == 0:
            self.record(s, info)

    def snapshot(self, index: int, s: State) -> None:
        """The field snapshot and the whole body's stress of step ``index``, if the plan
        asks for them."""
        fields, stress = index in self.plan.snapshot_steps, index in self.plan.stress_steps
        if fields or (stress and self.stress is not None):
            q = s.q if self.lift is None else self.lift.dot(s.q)
            if fields:
                self.sink.snapshot(s.t, self.body.displacement(q))
            if stress and self.stress is not None:
                self.stress.snapshot(s.t, q)

    def record(self, s: State, info: StepInfo) -> None:
        """Copy the raw row of a state already accounted for by :meth:`step`."""
        raw = self.raw
        k = self.filled
        raw.qv[k, :2] = s.Z[:2]
        if self.lift is None:
            raw.qv[k, 2] = self.body.mass_product.dot(s.Z[1])
        if raw.multipliers.shape[1]:
            raw.multipliers[k] = s.lam
        raw.scalars[k, :3] = s.t, info.iterations, info.elastic.energy if raw.energy else 0.0
        raw.scalars[k, 3:] = raw.work
        self.last_time = s.t
        raw.counters[0] = k + 1
        if k + 1 == len(raw.qv):
            self.flush()

    def flush(self) -> None:
        """Compute the block's series from its raw rows and hand them to the sink."""
        k, raw = self.filled, self.raw
        if not k:
            return
        body, out = self.body, self.out
        scalars = raw.scalars[:k]
        block = {"time": scalars[:, 0].copy(),
                 "newton_iterations": scalars[:, 1].astype("<i4")}
        if self.lift is None:
            qv = raw.qv[:k]
            Q = qv[:, 0].reshape(k, -1, 3)
            V = qv[:, 1].reshape(k, -1, 3)
            for g in out.groups:
                h = body.groups[g].position
                block[f"groups/{g}/position"] = np.matmul(h, Q)
                block[f"groups/{g}/velocity"] = np.matmul(h, V)
            kinetic, block["momentum/linear"], block["momentum/angular"] = body.momenta(
                Q, V, qv[:, 2].reshape(k, -1, 3))
        else:
            kinetic = self._lifted_series(block, raw.qv[:k, 0], raw.qv[:k, 1])
        block[MULTIPLIERS] = raw.multipliers[:k].copy()
        if out.coordinates:
            qv = raw.qv[:k, :2] if self.lift is None else raw.qv[:k, :2].dot(self.lift.T)
            block["coordinates/q"], block["coordinates/v"] = qv[:, 0], qv[:, 1]
        if self.stress is not None:
            q = raw.qv[:k, 0] if self.lift is None else raw.qv[:k, 0].dot(self.lift.T)
            block.update(self.stress.block(block["time"], q.reshape(k, -1, 3)))
        if raw.energy:
            elastic, w = scalars[:, 2].copy(), scalars[:, 3:].copy()
            gravity = self.forces.gravity_potential(raw.qv[:k, 0])
            total = kinetic + elastic + gravity
            if self._initial_energy is None:
                self._initial_energy = float(total[0])
            block.update({"energy/kinetic": kinetic, "energy/elastic": elastic,
                          "energy/gravity": gravity, "energy/load_work": w[:, 0],
                          "energy/constraint_work": w[:, 1],
                          "energy/damping_dissipation": w[:, 2],
                          "energy/balance_error": (total - self._initial_energy - w[:, 0]
                                                   - w[:, 1] + w[:, 2])})
        self.extremes.update(block)
        self.sink.append(block)
        raw.counters[0] = 0

    def _lifted_series(self, block: dict, p: np.ndarray, pd: np.ndarray) -> np.ndarray:
        """The full basis's group positions and velocities and momenta of rows p, ṗ (k × np)
        with q = B p, from matrices in p made once (:meth:`_lifted`): all are linear or
        bilinear in (q, q̇), so they never need the k rows of q (``Body.momenta``: kinetic
        ½ q̇ᵀ Mr q̇, linear Q̇ᵀ g1, angular Σ_f Q_f × (G Q̇)_f = [qᵀ (G ⊗ ε_a) q̇]_a). Returns the
        kinetic energy."""
        groups, Mp, linear, angular = self._lifted
        for g, rows in groups.items():
            block[f"groups/{g}/position"] = p.dot(rows.T)
            block[f"groups/{g}/velocity"] = pd.dot(rows.T)
        block["momentum/linear"] = pd.dot(linear.T)
        block["momentum/angular"] = np.stack([(p.dot(form) * pd).sum(axis=1)
                                              for form in angular], axis=1)
        return 0.5 * (pd.dot(Mp) * pd).sum(axis=1)

    @cached_property
    def _lifted(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray]:
        """(group rows (3 × np) by name, Mp, the linear momentum's rows (3 × np), the angular
        momentum's forms (3, np, np)) for q = B p (:meth:`_lifted_series`)."""
        body, B = self.body, self.lift
        nf, columns = body.field_count, B.shape[1]
        Bf = B.reshape(nf, 3, columns)                   # [f, l, j]: q_(f, l) = Σ_j B_(f, l) j p_j
        GB = np.asarray(body.gram @ B.reshape(nf, 3 * columns)).reshape(nf, 3, columns)
        groups = {g: np.tensordot(body.groups[g].position, Bf, axes=1) for g in self.out.groups}
        angular = np.array([Bf[:, b].T.dot(GB[:, c]) - Bf[:, c].T.dot(GB[:, b])
                            for b, c in ((1, 2), (2, 0), (0, 1))])   # (q × G q̇)_a, a = x, y, z
        return (groups, B.T.dot(GB.reshape(3 * nf, columns)),
                np.tensordot(body.field_mass, Bf, axes=1), angular)
