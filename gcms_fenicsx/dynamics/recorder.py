"""What a simulation records while it runs, and the energy balance it keeps every step.

Energy (all in J): kinetic T = ½ q̇ᵀ Mr q̇, elastic V (co-rotated), gravity potential
V_g = −q · f_g, and the work integrals, accumulated by the trapezoidal rule over every
step (not only recorded ones): the loads' work ∫ f_load · q̇ dt, the constraint forces'
work ∫ −λ · (C q̇) dt (a drive's work; ~0 for fixed joints) and the damping dissipation
∫ ėᵀ D ė dt. The balance error

    (T + V + V_g)(t) − (T + V + V_g)(0) − W_load − W_constraint + D

is zero for the exact solution; the integrator's numerical dissipation (ρ∞ < 1) and its
error show up in it (``results.energy_drift``).
"""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.integrator import State, StepInfo
from gcms_fenicsx.dynamics.joints import Constraints
from gcms_fenicsx.dynamics.loads import ExternalForces
from gcms_fenicsx.dynamics.results import ENERGY_NAMES, Trajectory
from gcms_fenicsx.dynamics.scene import Outputs


class Recorder:
    """Preallocated series for the steps ``0, every, 2·every, …`` and the last one."""

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 outputs: Outputs, steps: int, time_step_s: float) -> None:
        self.body, self.c, self.forces, self.out = body, constraints, forces, outputs
        self.h = time_step_s
        k = steps // outputs.every + 2
        self.k = 0
        self.time = np.zeros(k)
        self.iterations = np.zeros(k, dtype=np.int32)
        self.groups = {g: (body.groups[g], np.zeros((k, 3)), np.zeros((k, 3)))
                       for g in outputs.groups}
        self.energy = {name: np.zeros(k) for name in ENERGY_NAMES} if outputs.energy else {}
        self.momentum = {"linear": np.zeros((k, 3)), "angular": np.zeros((k, 3))}
        m = constraints.count if outputs.constraint_forces else 0
        self.multipliers = np.zeros((k, m))
        self.coordinates = ({"q": np.zeros((k, body.dofs)), "v": np.zeros((k, body.dofs))}
                            if outputs.coordinates else {})
        self.snapshot_steps = {min(steps, int(round(t / time_step_s))): t
                               for t in outputs.field_times}
        self.snapshots: list[tuple[float, np.ndarray]] = []
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
        if index in self.snapshot_steps:
            self.snapshots.append((s.t, self.body.displacement(s.q)))
        if last or index % self.out.every == 0:
            self.record(s, info)

    def record(self, s: State, info: StepInfo) -> None:
        """Write a row for a state already accounted for by :meth:`step`."""
        k = self.k
        self.k += 1
        self.time[k] = s.t
        self.iterations[k] = info.iterations
        Q, V = s.q.reshape(-1, 3), s.v.reshape(-1, 3)
        for rows, pos, vel in self.groups.values():
            pos[k] = Q.T @ rows.position
            vel[k] = V.T @ rows.position
        kinetic, self.momentum["linear"][k], self.momentum["angular"][k] = \
            self.body.momenta(s.q, s.v)
        if self.multipliers.shape[1]:
            self.multipliers[k] = s.lam
        for name, series in self.coordinates.items():
            series[k] = s.q if name == "q" else s.v
        if self.energy:
            e = self.energy
            e["kinetic"][k] = kinetic
            e["elastic"][k] = info.elastic.energy
            e["gravity"][k] = self.forces.gravity_potential(s.q)
            e["load_work"][k], e["constraint_work"][k], e["damping_dissipation"][k] = self._work
            total = e["kinetic"][k] + e["elastic"][k] + e["gravity"][k]
            if k == 0:
                self._initial_energy = total
            e["balance_error"][k] = (total - self._initial_energy - self._work[0]
                                     - self._work[1] + self._work[2])

    def trajectory(self, rows: list[dict]) -> Trajectory:
        k = self.k
        snaps = self.snapshots
        return Trajectory(
            time=self.time[:k].copy(), newton_iterations=self.iterations[:k].copy(),
            groups={g: {"position": p[:k].copy(), "velocity": v[:k].copy()}
                    for g, (_, p, v) in self.groups.items()},
            energy={n: a[:k].copy() for n, a in self.energy.items()},
            momentum={n: a[:k].copy() for n, a in self.momentum.items()},
            multipliers=self.multipliers[:k].copy(),
            rows=rows if self.multipliers.shape[1] else [],
            coordinates={n: a[:k].copy() for n, a in self.coordinates.items()},
            field_time=np.array([t for t, _ in snaps]),
            displacement=(np.array([d for _, d in snaps]) if snaps else np.zeros((0, 0, 3))),
            nodes_m=self.body.nodes_m if snaps else np.zeros((0, 3)))
