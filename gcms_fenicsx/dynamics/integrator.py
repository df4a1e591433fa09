"""Generalized-α time integration of the constrained GCMS body (DESIGN §5).

Equations of motion, with constant Mr (no quadratic velocity terms) and linear constraints:

    Mr q̈ + f_d(q, q̇) + ∂V/∂q = f_ext(t) − Cᵀ λ,     g(q, t) = C(t) q − d = 0.

Time stepping: the generalized-α method of Chung & Hulbert (J. Appl. Mech. 60, 1993) in the
form of Arnold & Brüls (Multibody Syst. Dyn. 18, 2007) for index-3 constraints, with the
acceleration-like variable a:

    (1 − α_m) a_{n+1} + α_m a_n = (1 − α_f) q̈_{n+1} + α_f q̈_n
    q_{n+1} = q_n + h q̇_n + h² (½ − β) a_n + h² β a_{n+1}
    q̇_{n+1} = q̇_n + h (1 − γ) a_n + h γ a_{n+1}

and the equations of motion and constraints enforced at t_{n+1}. From the spectral radius
ρ∞: α_m = (2ρ∞ − 1)/(ρ∞ + 1), α_f = ρ∞/(ρ∞ + 1), γ = ½ + α_f − α_m, β = ¼ (γ + ½)².
Second-order accurate; ρ∞ = 1 is the undamped trapezoidal case.

Newton on (q_{n+1}, λ_{n+1}): a correction Δq changes q̈ by β'Δq and q̇ by γ'Δq,
β' = (1 − α_m)/(β h² (1 − α_f)), γ' = γ/(β h), so the iteration matrix is
S = β' Mr + J_eᵀ (γ' D₀ + Kr) J_e + G (damping's ∂f_d/∂q, a few per mille of γ'∂f_d/∂q̇,
left out). With T = I ⊗ R and S₀ = β' Mr + γ' D₀ + Kr, Mr = G ⊗ I3 commutes with T, so

    S = T S₀ Tᵀ + X Y,   X Y of rank 9 (``corotated.frame_update``: the change of frame).

S₀ is factorised once for the whole run. Per step, R is taken at the first iteration and
kept (modified Newton); the constraints and, when used, the rank-9 term enter by the
Woodbury identity as a border of m + 9 columns solved once per step, with S₀⁻¹ Cᵀ built
from solves precomputed per distinct row vector (``joints``). An iteration then costs one
solve with S₀ and small dense algebra. ``[scene.solver] jacobian``:

- "rotated" (default): T S₀ Tᵀ alone — linear convergence at a rate set by the neglected
  change-of-frame terms (strain-sized, but multiplied by 1 + γ'β under stiffness-
  proportional damping). Once a step has needed them (below), every later step starts
  with the rank-9 term as well, kept in the body frame (X = T X_loc, Y = Y_loc Tᵀ, which
  depend only on the slowly changing local state) and re-linearised every
  ``LOCAL_REUSE_STEPS`` steps: near-Newton convergence at the cost of a rotation.
In every mode, a correction that is not smaller than ``UPGRADE_RATE`` times the previous
one is discarded and recomputed with the iteration matrix re-linearised at the current
iterate (R, and the rank-9 term where the elastic model allows), and the rest of that step
is full Newton (re-linearised at every iterate): a step with a large, fast change of frame
converges quadratically instead of slowly or not at all.
- "exact": T S₀ Tᵀ + X Y from the first iteration of every step.
- "assembled": the same exact S, assembled densely and LU-factorised in every iteration —
  the textbook Newton, kept as the baseline the benchmarks compare against (dense bodies).

Damping is Rayleigh damping in the co-rotated frame: the dissipation function
½ ėᵀ (α Mr + β Kr) ė of the deformation rate ė = Π d/dt vec(Q R), so rigid motion is not
damped; its force is f_d = (∂e/∂q)ᵀ (α Mr + β Kr) ė (``corotated.frame_force``).

The solve with S₀ goes through a ``factorize`` callable, so the same integrator runs the
dense reduced body (NumPy, default) and the full finite-element model (a sparse LU); the
internal force goes through an ``elastic`` callable (default: co-rotated linear
elasticity), so a full-order geometrically nonlinear model can be stepped by the same
scheme. Its iteration matrix is T S₀ Tᵀ alone (the rank-9 term belongs to the co-rotated
forces), so its Newton converges linearly at a rate set by how far its tangent is from
the linear one; co-rotated damping is not combined with another elastic law.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.body import Body, elastic_modes
from gcms_fenicsx.dynamics.corotated import (ElasticState, elastic_state, frame_force,
                                             frame_update, translation_free_force,
                                             without_translation)
from gcms_fenicsx.dynamics.joints import Constraints
from gcms_fenicsx.dynamics.loads import ExternalForces
from gcms_fenicsx.dynamics.rotation import InvertedBodyError, rotation_rate, skew
from gcms_fenicsx.dynamics.scene import SceneError, Solver
from gcms_fenicsx.errors import ComputationFailed

Solve = Callable[[np.ndarray], np.ndarray]
Factorize = Callable[[Any], Solve]
#: A Newton correction that does not shrink by this factor switches the rest of the step to
#: full Newton (with the rank-9 term). A re-linearisation costs about three iterations, so
#: it pays only where the plain iteration is slow or diverges (under strong stiffness-
#: proportional damping the rate exceeds 1).
UPGRADE_RATE = 0.6
#: The rank-9 term, kept in the body frame, is re-linearised after this many steps: the
#: local state it depends on changes slowly compared with the step.
LOCAL_REUSE_STEPS = 10
#: q ↦ an object with ``force`` (∂V/∂q), ``energy`` (V) and ``rotation`` (R of the frame).
Elastic = Callable[[np.ndarray], Any]
#: ``dense_factorization`` refuses a matrix whose computed inverse leaves |A A⁻¹ − I| above this.
INVERSE_DEFECT_LIMIT = 1e-6
EPS = float(np.finfo(float).eps)


class IntegrationError(ComputationFailed):
    """Newton did not converge, the state stopped being finite, or the iteration matrix is
    singular: says when and how far."""

    def __init__(self, message: str, time_s: float) -> None:
        super().__init__(message)
        self.time_s = time_s

    def __reduce__(self):  # picklable, so MPI can send it from the rank that saw it
        return (type(self), (str(self), self.time_s))


class SingularMatrixError(IntegrationError):
    """A matrix the integrator must factorise is singular to working precision: its inverse
    defect |A A⁻¹ − I| and condition number (inf when the LU broke down)."""

    def __init__(self, defect: float, cond: float) -> None:
        self.defect, self.cond = float(defect), float(cond)
        super().__init__(f"matrix is numerically singular: {self.numbers}", 0.0)

    def __reduce__(self):
        return (type(self), (self.defect, self.cond))

    @property
    def numbers(self) -> str:
        return f"|A A^-1 - I| = {self.defect:.1e}, cond {self.cond:.1e}"


def dense_factorization(A: np.ndarray) -> Solve:
    """x = A⁻¹ b by one mat-vec with the explicit inverse (A small and dense).

    Raises :class:`SingularMatrixError` if A is singular or so ill-conditioned that A A⁻¹ is
    not I to ``INVERSE_DEFECT_LIMIT``; the caller knows what A is and says why
    (:func:`mass_factorization`, :class:`GeneralizedAlpha`).
    """
    A = np.asarray(A)
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError as exc:
        raise SingularMatrixError(np.inf, np.inf) from exc
    defect = np.abs(A @ inv - np.eye(len(A))).max()
    if not defect < INVERSE_DEFECT_LIMIT:
        raise SingularMatrixError(defect, np.linalg.cond(A))
    return lambda b: inv @ b


def mass_factorization(body: Body, factorize: Factorize) -> Solve:
    """Mr⁻¹ through ``factorize``; IntegrationError naming the reduced model's selection when Mr
    itself is numerically singular (its fields are nearly dependent: no time step helps)."""
    try:
        return factorize(body.mass)
    except SingularMatrixError as exc:
        raise IntegrationError(
            "the reduced mass matrix Mr is numerically singular "
            f"({exc.numbers.replace('A', 'Mr')}): dependent fields are left in the reduced "
            "model; reduce it again with [selection] orthonormalize = true (the preconditioned "
            "basis has cond(Mr) = 1e1..1e3) or a larger svd_tolerance", 0.0) from exc


def newton_coefficients(p: AlphaParameters, h: float) -> tuple[float, float]:
    """(β', γ') = ((1 − α_m)/(β h² (1 − α_f)), γ/(β h)): how a Newton correction Δq changes q̈
    and q̇ (module docstring)."""
    return (1.0 - p.alpha_m) / (p.beta * h * h * (1.0 - p.alpha_f)), p.gamma / (p.beta * h)


def constant_iteration_matrix(body: Body, beta_p: float, gamma_p: float,
                              damping: tuple[float, float]) -> Any:
    """S₀ = β' Mr + γ' D₀ + Kr = (β' + γ'α) Mr + (1 + γ'β) Kr (module docstring)."""
    alpha, beta = damping
    return (beta_p + gamma_p * alpha) * body.mass + (1.0 + gamma_p * beta) * body.stiffness


def _one_two_five_below(h: float, decades: int = 20) -> Iterator[float]:
    """1, 2, 5 × 10^k below h, descending, over ``decades`` decades."""
    top = math.floor(math.log10(h))
    for k in range(top, top - decades, -1):
        for m in (5.0, 2.0, 1.0):
            if m * 10.0 ** k < h:
                yield m * 10.0 ** k


@dataclass(frozen=True)
class AlphaParameters:
    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @classmethod
    def from_rho_inf(cls, rho_inf: float) -> "AlphaParameters":
        """Chung & Hulbert's optimal parameters for spectral radius ρ∞ ∈ [0, 1]."""
        am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        af = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 + af - am
        return cls(alpha_m=am, alpha_f=af, gamma=gamma, beta=0.25 * (gamma + 0.5) ** 2)


@dataclass
class State:
    """The integrator's state at time t: q, q̇, q̈, a (generalized-α) and λ."""

    t: float
    q: np.ndarray
    v: np.ndarray
    acc: np.ndarray
    a: np.ndarray
    lam: np.ndarray


@dataclass(frozen=True)
class StepInfo:
    """What a converged step leaves for the recorder."""

    elastic: ElasticState
    dissipation_w: float
    directions: np.ndarray   # constraint directions u(t)
    iterations: int
    external_force: np.ndarray  # f_ext(t)


class GeneralizedAlpha:
    """The stepper: constant step h, the body's forces, joints and Newton settings."""

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 time_step_s: float, rho_inf: float, damping: tuple[float, float],
                 solver: Solver, factorize: Factorize = dense_factorization,
                 elastic: Elastic | None = None, mass_solve: Solve | None = None) -> None:
        self.body, self.constraints, self.forces = body, constraints, forces
        self.elastic = elastic or (lambda q: elastic_state(body, q))
        self.corotated = elastic is None
        if not self.corotated and (solver.jacobian != "rotated" or damping != (0.0, 0.0)):
            raise ValueError("another elastic model than the co-rotated one runs with "
                             'jacobian = "rotated" and without damping')
        if solver.jacobian == "assembled" and not isinstance(body.mass, np.ndarray):
            raise ValueError('jacobian = "assembled" needs a dense body')
        self.h = time_step_s
        self.p = AlphaParameters.from_rho_inf(rho_inf)
        self.beta_p, self.gamma_p = newton_coefficients(self.p, time_step_s)
        self.damping = damping
        self.damped = damping != (0.0, 0.0)
        self.solver = solver
        self.S0 = constant_iteration_matrix(body, self.beta_p, self.gamma_p, damping)
        self.factorize = factorize
        self._mass_solve = mass_solve
        self.tolerance_m = solver.tolerance * body.size_m
        self.kkt = _BorderedKKT(body, constraints, self._factorize_S0(), self.apply_A)
        self.frame_terms = False   # "rotated": start steps with the kept rank-9 term
        self.kept_steps = 0        # steps since the kept rank-9 term was re-linearised

    def _factorize_S0(self) -> Solve:
        """S₀⁻¹; a singular S₀ is explained by :meth:`_singular_S0`."""
        try:
            return self.factorize(self.S0)
        except SingularMatrixError as exc:
            raise self._singular_S0(exc) from exc

    def _singular_S0(self, exc: SingularMatrixError) -> Exception:
        """Why S₀ = β'Mr + Kr (+ damping) is singular, and what to change.

        Either Mr itself is (dependent fields: :func:`mass_factorization` raises), or the time
        step is so large that β' ~ 1/h² sinks into the round-off of Kr on rigid motion: the six
        rigid eigenvalues of (Kr, Mr) are zero only to ε·λ_max(Kr, Mr), so S₀ has eigenvalues
        β' ± ε·λ_max (in the Mr metric) on rigid motion against β' + λ_max on the stiffest mode,
        and the rigid motions lose their inertia in S₀. The step that works is the largest of
        1, 2, 5 × 10^k below h whose S₀ ``factorize`` accepts.
        """
        self.mass_solve()
        if not isinstance(self.body.mass, np.ndarray):
            return exc
        lam_max = float(elastic_modes(self.body)[0][-1])
        noise = EPS * lam_max
        works = next((h for h in _one_two_five_below(self.h) if self._factorizes(h)), None)
        remedy = (f"time_step = {works:g} s works" if works is not None else
                  "no time step down to 1e-20 of it works")
        return SceneError(
            f"[scene] time_step = {self.h:g}: the iteration matrix S0 = β'Mr + Kr is numerically "
            f"singular ({exc.numbers}): β' = {self.beta_p:.2e} 1/s² is only "
            f"{self.beta_p / noise:.1e} times the round-off of Kr on rigid motion, "
            f"ε·λ_max(Kr, Mr) = {noise:.1e} 1/s² (cond(Mr) = "
            f"{np.linalg.cond(self.body.mass):.1e} is fine); {remedy}")

    def _factorizes(self, h: float) -> bool:
        """Whether ``factorize`` accepts S₀ at time step h (same ρ∞ and damping)."""
        S0 = constant_iteration_matrix(self.body, *newton_coefficients(self.p, h), self.damping)
        try:
            self.factorize(S0)
        except SingularMatrixError:
            return False
        return True

    def apply_A(self, X: np.ndarray) -> np.ndarray:
        """A X with A = γ' D₀ + Kr = γ'α Mr + (1 + γ'β) Kr, the operator J_e is applied to in
        the rank-9 term."""
        alpha, beta = self.damping
        out = (1.0 + self.gamma_p * beta) * (self.body.stiffness @ X)
        return out + (self.gamma_p * alpha) * (self.body.mass @ X) if alpha else out

    # -- forces ---------------------------------------------------------------------------
    def damping_force(self, v: np.ndarray, es: ElasticState) -> tuple[np.ndarray, float]:
        """(f_d, ėᵀ D₀ ė) of co-rotated Rayleigh damping (module docstring)."""
        alpha, beta = self.damping
        body = self.body
        Vd = v.reshape(-1, 3)
        omega = rotation_rate(es.rotation, es.rate_inv, Vd.T @ body.affine)
        rate = without_translation(body, Vd @ es.rotation + es.local @ skew(omega)).ravel()
        p = alpha * (body.mass @ rate) + beta * (body.stiffness @ rate)
        P = translation_free_force(body, p.reshape(-1, 3))
        _, force = frame_force(body, es.rotation, es.rate_inv, es.local, P)
        return force, float(rate @ p)

    def residual(self, f_ext: np.ndarray, q: np.ndarray, v: np.ndarray, acc: np.ndarray,
                 lam: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, ElasticState, float]:
        """r = Mr q̈ + f_d + ∂V/∂q − f_ext + Cᵀλ, the elastic state and the damping's power."""
        es = self.elastic(q)
        r = self.body.mass @ acc + es.force - f_ext
        dissipation = 0.0
        if self.damped:
            fd, dissipation = self.damping_force(v, es)
            r += fd
        if self.constraints.count:
            r += self.constraints.transpose_times(lam, U)
        return r, es, dissipation

    # -- start ----------------------------------------------------------------------------
    def mass_solve(self) -> Solve:
        """Mr⁻¹ (given, or factorised on first use by :func:`mass_factorization`)."""
        if self._mass_solve is None:
            self._mass_solve = mass_factorization(self.body, self.factorize)
        return self._mass_solve

    def project_velocity(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The initial q̇: v corrected by the rigid velocity nearest it (kinetic-energy norm)
        that makes ġ = C q̇ + Ċ q = 0.

        Correcting within the six rigid velocities (``Body.rigid_velocity`` at q) turns, say,
        a spin the joints forbid into the rotation about the joint they allow, instead of
        putting the difference into the stiffest elastic coordinates; only what no rigid
        velocity can satisfy (a joint that constrains deformation rates) is corrected in
        the Mr-norm over all coordinates.
        """
        c = self.constraints
        if not c.count:
            return v
        U, dU = c.directions_at(t), c.directions_at(t, 1)
        C = c.jacobian(U)
        violation = C @ v + c.values(q, dU)
        E = np.eye(3)
        rigid = np.column_stack([self.body.rigid_velocity(q, E[k], np.zeros(3)) for k in range(3)]
                                + [self.body.rigid_velocity(q, np.zeros(3), E[k])
                                   for k in range(3)])
        # min |W a|²_M  subject to  C W a = −violation  (minimum-norm if C W is rank-deficient)
        CW = C @ rigid
        weight = rigid.T @ np.asarray(self.body.mass @ rigid)
        L_inv = np.linalg.inv(np.linalg.cholesky(weight))
        a = -L_inv.T @ (np.linalg.pinv(CW @ L_inv.T, rcond=1e-10) @ violation)
        v = v + rigid @ a
        rest = C @ v + c.values(q, dU)
        if np.linalg.norm(rest) > 1e-12 * max(np.linalg.norm(violation), 1e-300):
            MinvCt = self.mass_solve()(C.T)
            v = v - MinvCt @ np.linalg.solve(C @ MinvCt, rest)
        return v

    def start(self, q: np.ndarray, v: np.ndarray, t: float = 0.0) -> tuple[State, StepInfo]:
        """The state at t with consistent q̈ and λ: [Mr Cᵀ; C 0] [q̈; λ] = [f; −(2Ċq̇ + C̈q)]."""
        c = self.constraints
        U = c.directions_at(t)
        es = self.elastic(q)
        f_ext = self.forces(t)
        f = f_ext - es.force
        dissipation = 0.0
        if self.damped:
            fd, dissipation = self.damping_force(v, es)
            f = f - fd
        solve = self.mass_solve()
        lam = np.zeros(c.count)
        if c.count:
            C = c.jacobian(U)
            MinvCt = solve(C.T)
            rhs = -(2.0 * c.values(v, c.directions_at(t, 1)) + c.values(q, c.directions_at(t, 2)))
            lam = np.linalg.solve(C @ MinvCt, C @ solve(f) - rhs)
            f = f - C.T @ lam
        acc = solve(f)
        state = State(t=t, q=q.copy(), v=v.copy(), acc=acc, a=acc.copy(), lam=lam)
        return state, StepInfo(es, dissipation, U, 0, f_ext)

    # -- one step -------------------------------------------------------------------------
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
        tol = self.tolerance_m
        previous, full_newton = np.inf, False
        increments: list[float] = []
        jacobian = self.solver.jacobian
        exact = jacobian != "rotated" or self.frame_terms
        relinearise = jacobian == "exact" or self.kept_steps >= LOCAL_REUSE_STEPS
        self.kept_steps = 0 if relinearise else self.kept_steps + 1
        for iteration in range(1, self.solver.max_iterations + 1):
            try:
                r, es, dissipation = self.residual(f_ext, q, v, acc, lam, U)
            except InvertedBodyError as exc:
                raise self._divergence(t1, iteration, increments, exc) from exc
            g = c.residual(q, U)
            if jacobian == "assembled":
                dq, dlam = self._assembled_correction(es, r, g, U)
                delta = self._norm(dq)
            else:
                if iteration == 1 or full_newton:
                    self.kkt.prepare(es, U, exact,
                                     relinearise=relinearise or full_newton)
                dq, dlam = self.kkt.solve(r, g)
                delta = self._norm(dq)
                if not full_newton and delta > UPGRADE_RATE * previous:
                    # slow or diverging with the step's first linearisation: full Newton,
                    # re-linearised at every iterate for the rest of the step, and (rotated)
                    # the change-of-frame term kept for the steps that follow
                    exact = exact or self.corotated
                    self.frame_terms = self.frame_terms or self.corotated
                    full_newton, self.kept_steps = True, 0
                    self.kkt.prepare(es, U, exact)
                    dq, dlam = self.kkt.solve(r, g)
                    delta = self._norm(dq)
            if not delta < np.inf:
                raise IntegrationError(f"the state is no longer finite at t = {t1:.6g} s "
                                       f"(Newton iteration {iteration})", t1)
            q += dq
            v += self.gamma_p * dq
            acc += self.beta_p * dq
            lam += dlam
            increments.append(delta)
            if delta <= tol or delta * delta <= tol * (previous - delta) < np.inf:
                break
            previous = delta
        else:
            raise IntegrationError(
                f"Newton did not converge at t = {t1:.6g} s: {iteration} iterations, last "
                f"increment {delta:.3e} m (tolerance {tol:.1e} m), residual before it |r| = "
                f"{np.linalg.norm(r):.3e}, |g| = {np.linalg.norm(g) if c.count else 0.0:.3e}; "
                "reduce [scene] time_step or raise [scene.solver] max_iterations", t1)
        a1 = a1 + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * (acc - s.acc)
        return (State(t=t1, q=q, v=v, acc=acc, a=a1, lam=lam),
                StepInfo(es, dissipation, U, iteration, f_ext))

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

    def _assembled_correction(self, es: ElasticState, r: np.ndarray,
                              g: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Solve [S Cᵀ; C 0] with S = T S₀ Tᵀ + X Y assembled densely (the baseline)."""
        n, m = self.body.dofs, self.constraints.count
        T = np.kron(np.eye(n // 3), es.rotation)
        X, Y = frame_update(self.body, es, self.apply_A)
        S = T @ self.S0 @ T.T + X @ Y
        C = self.constraints.jacobian(U)
        kkt = np.block([[S, C.T], [C, np.zeros((m, m))]])
        sol = -np.linalg.solve(kkt, np.concatenate([r, g]))
        return sol[:n], sol[n:]


def _rotate(R: np.ndarray, X: np.ndarray) -> np.ndarray:
    """T X = vec(X_f R ᵀ) for the columns of X (n,) or (n, k): each field's 3-vector turned by R."""
    k = X.shape[1:]
    return (R @ X.reshape((-1, 3) + k)).reshape(X.shape) if k else (X.reshape(-1, 3) @ R.T).ravel()


class _BorderedKKT:
    """Newton corrections for S = T S₀ Tᵀ (+ X Y) bordered by the constraints.

    With z = S_T⁻¹ r (S_T = T S₀ Tᵀ, so S_T⁻¹ = T S₀⁻¹ Tᵀ) and the border columns
    B = S_T⁻¹ [Cᵀ | X]:

        [C S_T⁻¹ Cᵀ   C S_T⁻¹ X    ] [Δλ]   [g − C z]
        [Y S_T⁻¹ Cᵀ   I + Y S_T⁻¹ X] [y ] = [−Y z   ],    Δq = −(z + B [Δλ; y])

    is the Woodbury form of [S Cᵀ; C 0] [Δq; Δλ] = −[r; g] (y = Y Δq). For rows
    kron(v_k, u_i), S_T⁻¹ c_i = T Y_k Rᵀu_i with Y_k = S₀⁻¹ [kron(v_k, e_l)]_l solved once,
    and C S_T⁻¹ Cᵀ = [(Rᵀu_i)ᵀ Γ_{k_i k_j} (Rᵀu_j)] with Γ_kl = kron(v_k, I)ᵀ Y_l.
    """

    def __init__(self, body: Body, constraints: Constraints, solve: Solve,
                 apply_A: Callable[[np.ndarray], np.ndarray]) -> None:
        self.body, self.c, self.solve0, self.apply_A = body, constraints, solve, apply_A
        self.local: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        m = constraints.count
        if m:
            nv = len(constraints.vectors)
            basis = np.zeros((body.dofs, nv, 3))
            for l in range(3):
                basis.reshape(body.field_count, 3, nv, 3)[:, l, :, l] = constraints.vectors.T
            Y = np.asarray(solve(basis.reshape(body.dofs, 3 * nv))).reshape(body.dofs, nv, 3)
            gamma = np.einsum("nka,nlb->kalb", basis, Y)
            idx = constraints.index
            self.Y = Y[:, idx, :].reshape(body.dofs, 3 * m)            # columns (i, a)
            self.gamma = gamma[idx][:, :, idx, :].reshape(3 * m, 3 * m)
            self.blocks = np.zeros((3 * m, m))                         # block-diagonal Rᵀu_i
            self.block_index = (np.arange(3 * m), np.repeat(np.arange(m), 3))

    def prepare(self, es: Any, U: np.ndarray, exact: bool,
                relinearise: bool = True) -> None:
        """Fix R, the constraint directions U and (``exact``) the rank-9 term for the step.

        ``es``: the elastic state; without ``exact`` only its rotation is read, so another
        elastic model's state serves (it carries the same frame R = polar(A(q))).

        The rank-9 term is kept in the body frame, X = T X_loc, Y = Y_loc Tᵀ: X_loc and Y_loc
        depend only on the local state (Q_loc, P, U, b), so S₀⁻¹ X_loc and the capacitance
        I + Y S_T⁻¹ X = I + Y_loc S₀⁻¹ X_loc can serve later steps, only turned with the new
        R. ``relinearise`` (or nothing kept yet) recomputes them at ``es``.
        """
        R, m = es.rotation, self.c.count
        self.R, self.U = R, U
        borders = []
        if m:
            B = self.blocks
            B[self.block_index] = (U @ R).ravel()                     # Rᵀ u_i
            borders.append(_rotate(R, self.Y @ B))                    # S_T⁻¹ Cᵀ
            matrix = B.T @ (self.gamma @ B)
        if exact:
            if relinearise or self.local is None:
                X, Y = frame_update(self.body, es, self.apply_A)
                X_loc, Y_loc = _rotate(R.T, X), _rotate(R.T, Y.T).T
                SX_loc = np.asarray(self.solve0(X_loc))
                self.local = (Y_loc, SX_loc, np.eye(X.shape[1]) + Y_loc @ SX_loc)
            Y_loc, SX_loc, inner = self.local
            self.Yrows = _rotate(R, Y_loc.T).T                          # Y = Y_loc Tᵀ
            SX = _rotate(R, SX_loc)                                     # S_T⁻¹ X
            if m:
                schur, matrix = matrix, np.empty((m + len(inner), m + len(inner)))
                matrix[:m, :m] = schur
                matrix[:m, m:] = self.c.values(SX, U)               # C S_T⁻¹ X
                matrix[m:, :m] = self.Yrows @ borders[0]            # Y S_T⁻¹ Cᵀ
                matrix[m:, m:] = inner
            else:
                matrix = inner
            borders.append(SX)
        self.exact = exact
        self.border = np.hstack(borders) if borders else None
        self.inverse = np.linalg.inv(matrix) if borders else None

    def solve(self, r: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Δq, Δλ) for the residuals r, g with what :meth:`prepare` fixed."""
        R, m = self.R, self.c.count
        z = _rotate(R, np.asarray(self.solve0(_rotate(R.T, r))))
        if self.border is None:
            return -z, g[:0]
        rhs = g - self.c.values(z, self.U)
        if self.exact:
            rhs = np.concatenate([rhs, -(self.Yrows @ z)])
        sol = self.inverse @ rhs
        return -(z + self.border @ sol), sol[:m]
