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
(``corotated.local_frame_update``). S₀ is factorised once for the whole run (``factorization``);
per step R is taken at the first iteration and kept (modified Newton), and the linear
system is solved by ``kkt`` as the ``jacobian`` policy says.

A rotor body (``rotor``: coordinates p, q = B p, turning about one axis) runs the same
scheme with its own co-rotated law, frame T(ψ) and rank-2 change of frame (``body.frame``
carries the turning of coordinates for either kind of body).

The solve with S₀ goes through a ``factorize`` callable, so the same integrator runs the
dense reduced body (NumPy, default) and the full finite-element model (a sparse LU); the
internal force goes through an ``elastic`` callable (default: co-rotated linear
elasticity), so a geometrically nonlinear model (the reduced Saint Venant–Kirchhoff law,
``svk``, or the full-order reference) can be stepped by the same scheme. Its iteration
matrix is T S₀ Tᵀ alone (the rank-9 term belongs to the co-rotated forces), so its Newton
converges linearly at a rate set by how far its tangent is from the linear one. Where that
is too far (a slender body turned fast: the SVK tangent couples bending to the axial
stiffness), a step that converges slowly switches to β' Mr + ∂²V/∂q² from the law's exact
tangent (``kkt.TangentKKT``, for a dense body whose elastic states have ``tangent()``): a
step whose correction shrinks by less than ``TANGENT_RATE``, whose iterate leaves the
states with a rotation, or which does not converge in ``max_iterations``, is redone from its
predictor with that matrix (with ``max_iterations`` of its own; the step's iterations count
both attempts); the next step tries the cheap one again. Co-rotated damping is not combined with another elastic law.
"""
from __future__ import annotations

import math
from functools import partial

import numpy as np

from gcms_fenicsx.dynamics.stepping.alpha import AlphaParameters, newton_coefficients, step_matrices
from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.bodies.corotated import elastic_state, local_frame_update
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.stepping.kernel_data import law_kind
from gcms_fenicsx.dynamics.stepping.errors import IntegrationError, SingularMatrixError
from gcms_fenicsx.dynamics.constraints.factorization import (Factorize, Solve, dense_factorization,
                                                 singular_iteration_matrix)
from gcms_fenicsx.dynamics.constraints.jacobian import TANGENT_RATE, UPGRADE_RATE, JacobianPolicy
from gcms_fenicsx.dynamics.constraints.joints import Constraints
from gcms_fenicsx.dynamics.constraints.kkt import AssembledKKT, BorderedKKT, TangentKKT
from gcms_fenicsx.dynamics.bodies.loads import ExternalForces
from gcms_fenicsx.numerics.rotation import InvertedBodyError
from gcms_fenicsx.dynamics.bodies.rotor import RotorBody, rotor_frame_update, rotor_state
from gcms_fenicsx.config.scene import Solver
from gcms_fenicsx.dynamics.stepping.state import Elastic, State, StepInfo


class GeneralizedAlpha:
    """The stepper: constant step h, the body's forces, joints and Newton settings.

    Everything that does not change during a run is prepared here (the generalized-α
    coefficients as small matrices acting on the stacked state, S₀⁻¹, the constraint matrix
    when no drive turns it); a step makes the few NumPy calls its formulas need
    (docs/integrator_profile.md counts them).
    """

    def __init__(self, body: Body | RotorBody, constraints: Constraints,
                 forces: ExternalForces, time_step_s: float, rho_inf: float,
                 damping: RayleighDamping, solver: Solver,
                 factorize: Factorize = dense_factorization,
                 elastic: Elastic | None = None) -> None:
        self.body, self.constraints, self.forces = body, constraints, forces
        self.frame = body.frame
        corotated = elastic is None
        if isinstance(body, RotorBody):
            if not corotated:
                raise ValueError("a rotor body runs its own co-rotated law")
            self.elastic: Elastic = partial(rotor_state, body)
            frame_update, rank = partial(rotor_frame_update, body), 2
        else:
            self.elastic = elastic or partial(elastic_state, body)
            frame_update, rank = partial(local_frame_update, body), 9
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
        self.predictor, self.update = step_matrices(self.p, time_step_s)
        m = constraints.count
        C = constraints.jacobian(constraints.directions) if m else None
        #: (U, C, Cᵀ) when no drive turns the rows (None: computed at every step's time)
        self.rows = (None if constraints.drives else
                     (constraints.directions, C, C.T if m else None))
        self.damping_force = damping.on(body) if damping.active else None
        S0 = damping.iteration_matrix(body, self.beta_p, self.gamma_p)
        apply_A = damping.frame_operator(body, self.gamma_p)
        if solver.jacobian == "assembled":
            self.linear: BorderedKKT | AssembledKKT = AssembledKKT(body, constraints, S0,
                                                                    apply_A, frame_update)
        else:
            self.linear = BorderedKKT(body, constraints, self._factorized(S0, factorize),
                                      apply_A, frame_update, rank)
        #: the exact-tangent Newton matrix of another elastic law, for the steps that need it
        self.tangent_kkt = (TangentKKT(body, constraints, self.beta_p)
                            if not corotated and isinstance(body.mass, np.ndarray)
                            and hasattr(self.elastic(body.q0), "tangent") else None)
        self.with_tangent = False
        #: the compiled step's name for the elastic law (``kernel_data``), None for another
        self.law_kind = law_kind(body, self.elastic, corotated)

    def _factorized(self, S0, factorize: Factorize) -> Solve:
        """S₀⁻¹; a singular S₀ explained (``factorization.singular_iteration_matrix``)."""
        try:
            return factorize(S0)
        except SingularMatrixError as exc:
            raise singular_iteration_matrix(self.body, self.p, self.h, self.damping, factorize,
                                            exc) from exc

    def step(self, s: State) -> tuple[State, StepInfo]:
        """Advance one step h by Newton (module docstring); IntegrationError if it fails.

        Newton stops when the increment δ (mass-weighted RMS, metres) is below the
        tolerance, or when the error left after it, estimated from the observed contraction
        ρ = δ_k / δ_{k−1} as δ_k ρ / (1 − ρ), is. An iterate whose affine map has no rotation
        (``rotation.polar``) ends the step as Newton divergence, with its increments.

        The state's rows move together: the predictor is one product with Z = [q; q̇; q̈; a]
        and a correction Δq adds u Δq to all four (``alpha.step_matrices``).
        """
        t1 = s.t + self.h
        Z = self.predictor.dot(s.Z)                  # predicted Z_{n+1} (q̈_{n+1} = q̈_n)
        q, v, acc = Z[0], Z[1], Z[2]
        lam = s.lam.copy()
        c, elastic = self.constraints, self.elastic
        linear = self.tangent_kkt if self.with_tangent else self.linear
        damping = self.damping_force
        U, C, CT = self.rows or self._rows_at(t1)
        constrained = C is not None
        f_ext = self.forces(t1)
        tol, mass, total_mass, update = (self.tolerance_m, self.body.mass_product,
                                         self.body.total_mass_kg, self.update)
        targets, sqrt, inf, in_frame = c.targets, math.sqrt, math.inf, self.frame.residual
        g = lam[:0]
        dissipation = 0.0
        previous = inf
        increments: list[float] = []
        lin = self.policy.start_step()
        for iteration in range(1, self.solver.max_iterations + 1):
            try:
                es = elastic(q)
            except InvertedBodyError as exc:
                if self._can_switch(linear):
                    return self._step_with_tangent(s, iteration - 1)
                raise self._divergence(t1, iteration, increments, exc) from exc
            y = mass.dot(acc)                        # Mr q̈ + f_d − f_ext + Cᵀλ
            y -= f_ext
            gradient = es.local_gradient                 # Tᵀ(∂V/∂q + f_d), body frame
            if damping is not None:
                fd, dissipation = damping.local_force(v, es)
                gradient = gradient + fd
            if constrained:
                y += CT.dot(lam)
                g = C.dot(q) - targets
            if iteration == 1 or lin.every_iteration:
                linear.prepare(es, U, C, lin.exact,
                               relinearise=lin.relinearise or lin.every_iteration)
            r = in_frame(y, gradient, es.rotation, linear.R)
            dq, dlam = linear.solve(r, g)
            delta = sqrt(abs(dq.dot(mass.dot(dq))) / total_mass)
            if not lin.every_iteration and delta > UPGRADE_RATE * previous:
                if self._can_switch(linear):
                    if delta > TANGENT_RATE * previous:
                        return self._step_with_tangent(s, iteration)
                else:
                    lin = self.policy.upgrade(lin)
                    linear.prepare(es, U, C, lin.exact)
                    r = in_frame(y, gradient, es.rotation, linear.R)
                    dq, dlam = linear.solve(r, g)
                    delta = sqrt(abs(dq.dot(mass.dot(dq))) / total_mass)
            if not delta < inf:
                raise IntegrationError(f"the state is no longer finite at t = {t1:.6g} s "
                                       f"(Newton iteration {iteration})", t1)
            Z += update * dq
            lam += dlam
            increments.append(delta)
            if delta <= tol or delta * delta <= tol * (previous - delta) < inf:
                break
            previous = delta
        else:
            if self._can_switch(linear):
                return self._step_with_tangent(s, iteration)
            raise self._no_convergence(t1, iteration, delta, r, g)
        return State(t1, Z, lam), StepInfo(es, dissipation, U, iteration, f_ext, C)

    def _can_switch(self, linear) -> bool:
        """Whether this step runs with the cheap matrix of a law that has an exact tangent, so
        it can be redone with the tangent."""
        return self.tangent_kkt is not None and linear is not self.tangent_kkt

    def _step_with_tangent(self, s: State, discarded: int) -> tuple[State, StepInfo]:
        """The step from ``s`` redone from its predictor with β' Mr + ∂²V/∂q² (module
        docstring): the ``discarded`` iterations of the slow or diverging attempt are counted
        in its iterations, their iterates dropped."""
        self.with_tangent = True
        try:
            state, info = self.step(s)
        finally:
            self.with_tangent = False
        return state, info._replace(iterations=info.iterations + discarded)

    def _rows_at(self, t: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """(U, C, Cᵀ) at time t, for joints whose rows a drive turns."""
        c = self.constraints
        U = c.directions_at(t)
        C = c.jacobian(U) if c.count else None
        return U, C, (C.T if C is not None else None)

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

