"""Generalized-α time integration of the constrained GCMS body: the time step and its Newton
iteration (docs/design.md §6).

Equations of motion, with constant Mr (no quadratic velocity terms) and linear constraints:

    Mr q̈ + f_d(q, q̇) + ∂V/∂q = f_ext(t) − Cᵀ λ,     g(q, t) = C(t) q − d = 0.

Time stepping: the generalized-α method of Chung & Hulbert (J. Appl. Mech. 60, 1993) in the
form of Arnold & Brüls (Multibody Syst. Dyn. 18, 2007) for index-3 constraints, with the
acceleration-like variable a:

    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n
    q_{n+1} = q_n + h q̇_n + h² (½ − β) a_n + h² β a_{n+1}
    q̇_{n+1} = q̇_n + h (1 − γ) a_n + h γ a_{n+1}

and the equations of motion and constraints enforced at t_{n+1} (constants: ``alpha``).

Newton on (q_{n+1}, λ_{n+1}): a correction Δq changes q̈ by β'Δq and q̇ by γ'Δq, so the
iteration matrix is S = β' Mr + J_eᵀ (γ' D₀ + Kr) J_e + G (damping's ∂f_d/∂q, a few per
mille of γ'∂f_d/∂q̇, left out). With T = I ⊗ R and S₀ = β' Mr + γ' D₀ + Kr (``damping``),
Mr = G ⊗ I3 commutes with T, so S = T S₀ Tᵀ + X Y with X Y of rank 9
(``corotated.frame_update``). S₀ is factorised once for the whole run (``factorization``);
per step R is taken at the first iteration and kept (modified Newton), and the linear
system is solved by ``kkt`` as the ``jacobian`` policy says.

The solve with S₀ goes through a ``factorize`` callable, so the same integrator runs the
dense reduced body (NumPy, default) and the full finite-element model (a sparse LU); the
internal force goes through an ``elastic`` callable (default: co-rotated linear
elasticity), so a full-order geometrically nonlinear model can be stepped by the same
scheme. Its iteration matrix is T S₀ Tᵀ alone (the rank-9 term belongs to the co-rotated
forces), so its Newton converges linearly at a rate set by how far its tangent is from the
linear one; co-rotated damping is not combined with another elastic law.
"""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.dynamics.alpha import AlphaParameters, newton_coefficients
from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.corotated import ElasticState, elastic_state
from gcms_fenicsx.dynamics.damping import RayleighDamping
from gcms_fenicsx.dynamics.errors import IntegrationError, SingularMatrixError
from gcms_fenicsx.dynamics.factorization import (Factorize, Solve, dense_factorization,
                                                 singular_iteration_matrix)
from gcms_fenicsx.dynamics.jacobian import UPGRADE_RATE, JacobianPolicy, Linearisation
from gcms_fenicsx.dynamics.joints import Constraints
from gcms_fenicsx.dynamics.kkt import AssembledKKT, BorderedKKT
from gcms_fenicsx.dynamics.loads import ExternalForces
from gcms_fenicsx.dynamics.rotation import InvertedBodyError
from gcms_fenicsx.dynamics.scene import Solver
from gcms_fenicsx.dynamics.state import Elastic, State, StepInfo


class GeneralizedAlpha:
    """The stepper: constant step h, the body's forces, joints and Newton settings."""

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 time_step_s: float, rho_inf: float, damping: RayleighDamping,
                 solver: Solver, factorize: Factorize = dense_factorization,
                 elastic: Elastic | None = None) -> None:
        self.body, self.constraints, self.forces = body, constraints, forces
        self.elastic = elastic or (lambda q: elastic_state(body, q))
        corotated = elastic is None
        if not corotated and (solver.jacobian != "rotated" or damping.active):
            raise ValueError("another elastic model than the co-rotated one runs with "
                             'jacobian = "rotated" and without damping')
        if solver.jacobian == "assembled" and not isinstance(body.mass, np.ndarray):
            raise ValueError('jacobian = "assembled" needs a dense body')
        self.h = time_step_s
        self.p = AlphaParameters.from_rho_inf(rho_inf)
        self.beta_p, self.gamma_p = newton_coefficients(self.p, time_step_s)
        self.damping = damping
        self.solver = solver
        self.tolerance_m = solver.tolerance * body.size_m
        self.policy = JacobianPolicy(solver.jacobian, corotated)
        S0 = damping.iteration_matrix(body, self.beta_p, self.gamma_p)
        apply_A = damping.frame_operator(body, self.gamma_p)
        if solver.jacobian == "assembled":
            self.linear: BorderedKKT | AssembledKKT = AssembledKKT(body, constraints, S0,
                                                                    apply_A)
        else:
            self.linear = BorderedKKT(body, constraints, self._factorized(S0, factorize),
                                      apply_A)

    def _factorized(self, S0, factorize: Factorize) -> Solve:
        """S₀⁻¹; a singular S₀ explained (``factorization.singular_iteration_matrix``)."""
        try:
            return factorize(S0)
        except SingularMatrixError as exc:
            raise singular_iteration_matrix(self.body, self.p, self.h, self.damping, factorize,
                                            exc) from exc

    def residual(self, f_ext: np.ndarray, q: np.ndarray, v: np.ndarray, acc: np.ndarray,
                 lam: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, ElasticState, float]:
        """r = Mr q̈ + f_d + ∂V/∂q − f_ext + Cᵀλ, the elastic state and the damping's power."""
        es = self.elastic(q)
        r = self.body.mass @ acc + es.force - f_ext
        dissipation = 0.0
        if self.damping.active:
            fd, dissipation = self.damping.force(self.body, v, es)
            r += fd
        if self.constraints.count:
            r += self.constraints.transpose_times(lam, U)
        return r, es, dissipation

    def step(self, s: State) -> tuple[State, StepInfo]:
        """Advance one step h by Newton (module docstring); IntegrationError if it fails.

        Newton stops when the increment δ (mass-weighted RMS, metres) is below the
        tolerance, or when the error left after it, estimated from the observed contraction
        ρ = δ_k / δ_{k−1} as δ_k ρ / (1 − ρ), is. An iterate whose affine map has no rotation
        (``rotation.polar``) ends the step as Newton divergence, with its increments.
        """
        p, h = self.p, self.h
        t1 = s.t + h
        acc = s.acc.copy()                       # predictor: q̈_{n+1} = q̈_n
        a1 = (p.alpha_f * s.acc - p.alpha_m * s.a + (1.0 - p.alpha_f) * acc) / (1.0 - p.alpha_m)
        v = s.v + h * ((1.0 - p.gamma) * s.a + p.gamma * a1)
        q = s.q + h * s.v + h * h * ((0.5 - p.beta) * s.a + p.beta * a1)
        lam = s.lam.copy()
        c = self.constraints
        U = c.directions_at(t1)
        f_ext = self.forces(t1)
        previous = np.inf
        increments: list[float] = []
        lin = self.policy.start_step()
        for iteration in range(1, self.solver.max_iterations + 1):
            try:
                r, es, dissipation = self.residual(f_ext, q, v, acc, lam, U)
            except InvertedBodyError as exc:
                raise self._divergence(t1, iteration, increments, exc) from exc
            g = c.residual(q, U)
            lin, dq, dlam, delta = self._correction(lin, iteration, previous, es, U, r, g)
            if not delta < np.inf:
                raise IntegrationError(f"the state is no longer finite at t = {t1:.6g} s "
                                       f"(Newton iteration {iteration})", t1)
            q += dq
            v += self.gamma_p * dq
            acc += self.beta_p * dq
            lam += dlam
            increments.append(delta)
            if delta <= self.tolerance_m or \
                    delta * delta <= self.tolerance_m * (previous - delta) < np.inf:
                break
            previous = delta
        else:
            raise self._no_convergence(t1, iteration, delta, r, g)
        a1 = a1 + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * (acc - s.acc)
        return (State(t=t1, q=q, v=v, acc=acc, a=a1, lam=lam),
                StepInfo(es, dissipation, U, iteration, f_ext))

    def _correction(self, lin: Linearisation, iteration: int, previous: float,
                    es: ElasticState, U: np.ndarray, r: np.ndarray, g: np.ndarray
                    ) -> tuple[Linearisation, np.ndarray, np.ndarray, float]:
        """The Newton correction of one iteration, linearised as the policy says; a correction
        that does not shrink by UPGRADE_RATE is recomputed with full Newton (``jacobian``)."""
        if iteration == 1 or lin.every_iteration:
            self.linear.prepare(es, U, lin.exact,
                                relinearise=lin.relinearise or lin.every_iteration)
        dq, dlam = self.linear.solve(r, g)
        delta = self._norm(dq)
        if not lin.every_iteration and delta > UPGRADE_RATE * previous:
            lin = self.policy.upgrade(lin)
            self.linear.prepare(es, U, lin.exact)
            dq, dlam = self.linear.solve(r, g)
            delta = self._norm(dq)
        return lin, dq, dlam, delta

    def _no_convergence(self, t1: float, iteration: int, delta: float, r: np.ndarray,
                        g: np.ndarray) -> IntegrationError:
        g_norm = np.linalg.norm(g) if self.constraints.count else 0.0
        return IntegrationError(
            f"Newton did not converge at t = {t1:.6g} s: {iteration} iterations, last "
            f"increment {delta:.3e} m (tolerance {self.tolerance_m:.1e} m), residual before it "
            f"|r| = {np.linalg.norm(r):.3e}, |g| = {g_norm:.3e}; reduce [scene] time_step or "
            "raise [scene.solver] max_iterations", t1)

    def _divergence(self, t1: float, iteration: int, increments: list[float],
                    exc: InvertedBodyError) -> IntegrationError:
        """The step to t1 failed because an iterate left the states that have a rotation: Newton
        diverged (or, at iteration 1, the predictor q + h q̇ + … already did)."""
        remedy = f"reduce [scene] time_step (now {self.h:g} s)"
        if iteration == 1:
            return IntegrationError(
                f"the step to t = {t1:.6g} s failed before Newton: its predictor gives the body's "
                f"affine map {exc.numbers}: the motion is too fast for the step; {remedy}", t1)
        shown = ", ".join(f"{d:.2e}" for d in increments[-6:])
        more = f"the last 6 of {len(increments)} " if len(increments) > 6 else ""
        return IntegrationError(
            f"Newton diverged at t = {t1:.6g} s: iteration {iteration} reached a state whose "
            f"affine map has {exc.numbers}, after {more}increments {shown} m (tolerance "
            f"{self.tolerance_m:.1e} m); {remedy} or the loads", t1)

    def _norm(self, dq: np.ndarray) -> float:
        """The mass-weighted RMS size of a correction, √(Δqᵀ Mr Δq / m) (metres)."""
        return float(np.sqrt(abs(dq @ (self.body.mass @ dq)) / self.body.total_mass_kg))
