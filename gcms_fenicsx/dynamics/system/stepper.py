"""The generalized-α step of an assembly: Newton on the KKT system, solved block by block
with a Schur complement on the multipliers (docs/design.md §10).

The equations of motion and the rows, with Mr = diag(Mr_b) constant (``rows``, C = ∂g/∂q):

    Mr q̈ + f_int(q) = f_ext(t) − C(q, t)ᵀ λ,      g(q, t) = 0,

stepped by the single body's scheme (``stepping.integrator``, docs/design.md §6: Arnold and
Brüls' generalized-α with the constraints at t_{n+1}; ``alpha.step_matrices``). Newton's matrix
is [S Cᵀ; C 0], S = diag(S_b) with each member's iteration matrix (``members``: T_b S₀_b T_bᵀ
for a flexible body, S₀_b factorised once, T_b turned once per step; β' m I for a point
mass). With the residuals r, g a correction is

    W = S⁻¹ Cᵀ,  A = C W  (m × m, once per step: the joints' coupling),
    Δλ = A⁻¹ (g − C S⁻¹ r),     Δq = −S⁻¹ r − W Δλ,

so no member's solve sees another's coordinates: the members couple only through A. W and A
are taken at the step's first iterate; C in the residuals at every iterate (it changes with q
for bilinear rows and with t for driven ones: a modified Newton, as the frames' T_b).
Newton ends as the single body's does: the mass-weighted RMS increment below the tolerance,
or the error left after it (estimated from the contraction) below it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.stepping.alpha import AlphaParameters, newton_coefficients, step_matrices
from gcms_fenicsx.dynamics.stepping.errors import IntegrationError, SingularMatrixError
from gcms_fenicsx.dynamics.stepping.state import State
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.dynamics.system.assembly import Assembly
from gcms_fenicsx.dynamics.system.blocks import Block, BlockDiagonal
from gcms_fenicsx.numerics.rotation import InvertedBodyError

#: t ↦ external force on the assembly's coordinates (N,), besides gravity (gas forces on
#: pistons: ``gas_pressure.cylinder_loads``).
Loads = Callable[[float], np.ndarray]


@dataclass(frozen=True)
class StepSettings:
    """h (s), ρ∞, the Newton tolerance (relative to the assembly's size) and iteration limit."""

    time_step_s: float
    rho_inf: float = 0.8
    tolerance: float = 1e-10
    max_iterations: int = 25

    def __post_init__(self) -> None:
        checks.positive("time_step_s (s)", self.time_step_s)
        checks.within("rho_inf", self.rho_inf, 0.0, 1.0)
        checks.within("tolerance", self.tolerance, 1e-15, 1e-3)
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise ValueError(f"max_iterations must be a whole number ≥ 1, got "
                             f"{self.max_iterations!r}")


class AssemblyStepper:
    """Steps of one assembly (module docstring); everything constant is prepared here."""

    def __init__(self, assembly: Assembly, settings: StepSettings,
                 loads: Loads | None = None) -> None:
        self.assembly, self.settings, self.loads = assembly, settings, loads
        if loads is not None:
            f = np.asarray(loads(0.0))
            if f.shape != (assembly.dofs,) or not np.isfinite(f).all():
                raise ValueError(f"loads(t) must give {assembly.dofs} finite numbers (the "
                                 f"assembly's coordinates), gave shape {f.shape} at t = 0")
        self.h = settings.time_step_s
        p = AlphaParameters.from_rho_inf(settings.rho_inf)
        beta_p, gamma_p = newton_coefficients(p, self.h)
        self.predictor, self.update = step_matrices(p, self.h)
        self.solvers = [(block, self._iteration(block, beta_p, gamma_p))
                        for block in assembly.blocks]
        self.damped = [(k, block) for k, (block, _) in enumerate(self.solvers) if block.damped]
        self.mass = assembly.mass
        self.C = assembly.matrix if assembly.constant else None
        self.tolerance_m = settings.tolerance * assembly.size_m

    def _iteration(self, block: Block, beta_p: float, gamma_p: float) -> Any:
        """The member's Newton solves; a singular S₀ = β' Mr + Kr explained: β' = O(1/h²) makes
        it Mr's scale for any sane h, so it is singular when h is far too large for the member
        (its Mr and Kr are then of different orders, Kr's near-zero rigid part decides) or when
        its Mr is."""
        try:
            return block.iteration(beta_p, gamma_p)
        except SingularMatrixError as exc:
            names = ", ".join(repr(m.name) for m in block.members)
            raise IntegrationError(
                f"member {names}: its iteration matrix β' M + γ' D + K is singular "
                f"({exc.numbers}) at time_step_s = {self.h:g} s: the step is far too large for "
                "the member (a step in µs given in s?), or its reduced mass matrix is singular",
                0.0) from exc

    def internal(self, q: np.ndarray) -> tuple[np.ndarray, list[Any]]:
        """f_int(q) (N,) and each block's elastic state (None for a point mass)."""
        f = np.zeros_like(q)
        states = []
        for block, _ in self.solvers:
            state = block.state(q[block.where])
            if state is not None:
                f[block.where] = state.force
            states.append(state)
        return f, states

    def damping(self, v: np.ndarray, states: list[Any]) -> tuple[np.ndarray, float]:
        """The damped members' forces f_d (N,) at the velocity v and their elastic ``states``,
        and the power they dissipate."""
        f, power = np.zeros_like(v), 0.0
        for k, block in self.damped:
            force, dissipated = block.damping_force(v[block.where], states[k])
            f[block.where] = force
            power += dissipated
        return f, power

    def external(self, t: float) -> np.ndarray:
        """f_ext(t): gravity and the loads."""
        f = self.assembly.gravity_force
        return f + self.loads(t) if self.loads is not None else f

    def linearise(self, states: list[Any], q: np.ndarray, t: float
                  ) -> tuple[BlockDiagonal, np.ndarray]:
        """S⁻¹ (block by block) and W = S⁻¹ Cᵀ at the blocks' ``states`` and (q, t) (module
        docstring)."""
        W = np.zeros((len(q), self.assembly.count))
        solves = []
        directions = self.assembly.directions(q, t)
        for (block, iteration), state in zip(self.solvers, states):
            at = iteration(state)
            solves.append((block.where, at.solve))
            rows = block.scatter
            if len(rows.terms):
                rows.add_to(W, at.rows(directions[rows.terms]))
        return BlockDiagonal(tuple(solves)), W

    def step(self, s: State) -> tuple[State, list[Any], int]:
        """Advance one step h (module docstring): (the state, the blocks' elastic states at
        its last iterate, Newton iterations); IntegrationError if Newton does not converge."""
        t1 = s.t + self.h
        Z = self.predictor.dot(s.Z)
        q, acc = Z[0], Z[2]
        lam = s.lam.copy()
        a, mass, update = self.assembly, self.mass, self.update
        f_ext = self.external(t1)
        total, tol = a.total_mass_kg, self.tolerance_m
        previous, delta = math.inf, math.inf
        for iteration in range(1, self.settings.max_iterations + 1):
            try:
                f_int, states = self.internal(q)
            except InvertedBodyError as exc:
                raise IntegrationError(
                    f"Newton diverged at t = {t1:.6g} s: iteration {iteration} reached a state "
                    f"whose affine map has {exc.numbers}; reduce the time step (now "
                    f"{self.h:g} s) or the loads", t1) from exc
            if self.damped:
                f_int = f_int + self.damping(Z[1], states)[0]
            C = self.C if self.C is not None else a.jacobian(q, t1)
            r = mass.dot(acc) + f_int - f_ext + C.T.dot(lam)
            g = a.residual(q, t1)
            if iteration == 1:
                solve, W = self.linearise(states, q, t1)
                coupling = np.linalg.inv(C.dot(W)) if len(C) else np.zeros((0, 0))
            u = solve.dot(r)
            dlam = coupling.dot(g - C.dot(u))
            dq = -u - W.dot(dlam)
            delta = math.sqrt(abs(dq.dot(mass.dot(dq))) / total)
            if not delta < math.inf:
                raise IntegrationError(f"the state is no longer finite at t = {t1:.6g} s "
                                       f"(Newton iteration {iteration})", t1)
            Z += update * dq
            lam += dlam
            if delta <= tol or delta * delta <= tol * (previous - delta) < math.inf:
                return State(t1, Z, lam), states, iteration
            previous = delta
        raise IntegrationError(
            f"Newton did not converge at t = {t1:.6g} s: {self.settings.max_iterations} "
            f"iterations, last increment {delta:.3e} m (tolerance {tol:.1e} m); reduce the "
            "time step or raise max_iterations", t1)


def initial_state(stepper: AssemblyStepper, velocity: np.ndarray | None = None
                  ) -> tuple[State, float]:
    """The state at t = 0 from q_start and ``velocity`` (default: at rest): the velocity made
    consistent with the rows, Cq̇ + ∂g/∂t = 0, by its least change in kinetic energy (q̇ ←
    q̇ − Mr⁻¹Cᵀ(C Mr⁻¹Cᵀ)⁻¹(Cq̇ − ḋ)), then q̈ and λ from [Mr Cᵀ; C 0][q̈; λ] = [f_ext −
    f_int − f_d(q̇); d̈(0)], and a = q̈. Returns the state and the relative size of the velocity's
    change √(Δq̇ᵀ Mr Δq̇ / q̇ᵀ Mr q̇) (0 when none was needed)."""
    a = stepper.assembly
    q = a.q_start.copy()
    v = (np.zeros_like(q) if velocity is None
         else checks.vector("velocity (the assembly's q̇ at t = 0)", velocity, a.dofs).copy())
    C, mass = a.matrix, a.mass
    inverse = a.mass_inverse()
    f_int, states = stepper.internal(q)
    force = stepper.external(0.0) - f_int
    change = 0.0
    if len(C):
        W = inverse.dot(C.T)
        A = C.dot(W)
        rate, _ = a.rates(q, v, 0.0)
        dv = -W.dot(np.linalg.solve(A, C.dot(v) + rate))
        energy = float(v.dot(mass.dot(v)))
        change = math.sqrt(float(dv.dot(mass.dot(dv))) / energy) if energy > 0 else 0.0
        v += dv
    if stepper.damped:
        force = force - stepper.damping(v, states)[0]
    if len(C):
        lam = np.linalg.solve(A, C.dot(inverse.dot(force)) - a.rates(q, v, 0.0)[1])
        force = force - C.T.dot(lam)
    else:
        lam = np.zeros(0)
    acc = inverse.dot(force)
    return State.of(0.0, q, v, acc, acc.copy(), lam), change

