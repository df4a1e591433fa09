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
S = β' Mr + γ' D + K_t. Two choices (``[scene.solver] jacobian``):

- "rotated" (default): S ≈ T S₀ Tᵀ with S₀ = β' Mr + γ' D₀ + Kr and T = I ⊗ R. Mr = G ⊗ I3
  commutes with T, so this is the exact tangent without the change-of-frame terms, and S₀
  is factorised once for the whole run. R is taken at the step's first iteration and kept
  for the step (modified Newton), so the constraints' Schur complement, built from solves
  precomputed per distinct row vector (``joints``), is inverted once per step; an
  iteration costs one solve with S₀ and small dense algebra. Converges linearly at a
  rate set by the neglected terms (strain-sized).
- "exact": the exact elastic tangent (``corotated.elastic_tangent``), assembled and solved
  with the constraints in every iteration (quadratic convergence, n³ per iteration).

Damping is Rayleigh damping in the co-rotated frame: the dissipation function
½ ėᵀ (α Mr + β Kr) ė of the deformation rate ė = Π d/dt vec(Q R), so rigid motion is not
damped; its force is f_d = (∂e/∂q)ᵀ (α Mr + β Kr) ė (``corotated.frame_force``).

The solve with S₀ goes through a ``factorize`` callable, so the same integrator runs the
dense reduced body (NumPy, default) and the full finite-element model (a sparse LU).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.corotated import (ElasticState, elastic_state, elastic_tangent,
                                             frame_force, translation_free_force,
                                             without_translation)
from gcms_fenicsx.dynamics.joints import Constraints
from gcms_fenicsx.dynamics.loads import ExternalForces
from gcms_fenicsx.dynamics.rotation import rotation_rate, skew
from gcms_fenicsx.dynamics.scene import Solver

Solve = Callable[[np.ndarray], np.ndarray]
Factorize = Callable[[Any], Solve]


class IntegrationError(RuntimeError):
    """Newton did not converge, or the state stopped being finite: says when and how far."""

    def __init__(self, message: str, time_s: float) -> None:
        super().__init__(message)
        self.time_s = time_s


def dense_factorization(A: np.ndarray) -> Solve:
    """x = A⁻¹ b by one mat-vec with the explicit inverse (A small and dense).

    Raises IntegrationError if A is singular or so ill-conditioned that A A⁻¹ is not I to
    1e-6.
    """
    A = np.asarray(A)
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError as exc:
        raise IntegrationError(f"iteration matrix is singular: {exc}", 0.0) from exc
    defect = np.abs(A @ inv - np.eye(len(A))).max()
    if not defect < 1e-6:
        raise IntegrationError(f"iteration matrix is numerically singular: |A A^-1 - I| = "
                               f"{defect:.1e} (cond {np.linalg.cond(A):.1e}); are dependent "
                               "fields left in the reduced model?", 0.0)
    return lambda b: inv @ b


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
    damping_force: np.ndarray
    dissipation_w: float
    directions: np.ndarray   # constraint directions u(t)
    iterations: int


class GeneralizedAlpha:
    """The stepper: constant step h, the body's forces, joints and Newton settings."""

    def __init__(self, body: Body, constraints: Constraints, forces: ExternalForces,
                 time_step_s: float, rho_inf: float, damping: tuple[float, float],
                 solver: Solver, factorize: Factorize = dense_factorization) -> None:
        self.body, self.constraints, self.forces = body, constraints, forces
        self.h = time_step_s
        self.p = AlphaParameters.from_rho_inf(rho_inf)
        p, h = self.p, time_step_s
        self.beta_p = (1.0 - p.alpha_m) / (p.beta * h * h * (1.0 - p.alpha_f))
        self.gamma_p = p.gamma / (p.beta * h)
        self.damping = damping
        self.damped = damping != (0.0, 0.0)
        self.solver = solver
        alpha, beta = damping
        self.S0 = ((self.beta_p + self.gamma_p * alpha) * body.mass
                   + (1.0 + self.gamma_p * beta) * body.stiffness)
        self.factorize = factorize
        self._mass_solve: Solve | None = None
        self.tolerance_m = solver.tolerance * body.size_m
        if solver.jacobian == "rotated":
            self._rotated = _RotatedKKT(body, constraints, factorize(self.S0))

    # -- forces ---------------------------------------------------------------------------
    def damping_force(self, q: np.ndarray, v: np.ndarray,
                      es: ElasticState) -> tuple[np.ndarray, float]:
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

    def residual(self, t: float, q: np.ndarray, v: np.ndarray, acc: np.ndarray,
                 lam: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, ElasticState,
                                                          np.ndarray | None, float]:
        """r = Mr q̈ + f_d + ∂V/∂q − f_ext + Cᵀλ, with the elastic and damping terms."""
        es = elastic_state(self.body, q)
        r = self.body.mass @ acc + es.force - self.forces(t)
        fd, dissipation = None, 0.0
        if self.damped:
            fd, dissipation = self.damping_force(q, v, es)
            r += fd
        if self.constraints.count:
            r += self.constraints.transpose_times(lam, U)
        return r, es, fd, dissipation

    # -- start ----------------------------------------------------------------------------
    def mass_solve(self) -> Solve:
        if self._mass_solve is None:
            self._mass_solve = self.factorize(self.body.mass)
        return self._mass_solve

    def project_velocity(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The q̇ nearest v in the Mr-norm with ġ = C q̇ + Ċ q = 0."""
        c = self.constraints
        if not c.count:
            return v
        U, dU = c.directions_at(t), c.directions_at(t, 1)
        C = c.jacobian(U)
        MinvCt = self.mass_solve()(C.T)
        violation = C @ v + c.values(q, dU)
        return v - MinvCt @ np.linalg.solve(C @ MinvCt, violation)

    def start(self, q: np.ndarray, v: np.ndarray, t: float = 0.0) -> tuple[State, StepInfo]:
        """The state at t with consistent q̈ and λ: [Mr Cᵀ; C 0] [q̈; λ] = [f; −(2Ċq̇ + C̈q)]."""
        c = self.constraints
        U = c.directions_at(t)
        es = elastic_state(self.body, q)
        fd, dissipation = self.damping_force(q, v, es) if self.damped else (None, 0.0)
        f = self.forces(t) - es.force - (0.0 if fd is None else fd)
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
        return state, StepInfo(es, fd, dissipation, U, 0)

    # -- one step -------------------------------------------------------------------------
    def step(self, s: State) -> tuple[State, StepInfo]:
        """Advance one step h by Newton (module docstring); IntegrationError if it fails.

        Newton stops when the increment δ (mass-weighted RMS, metres) is below the
        tolerance, or when the error left after it, estimated from the observed contraction
        ρ = δ_k / δ_{k−1} as δ_k ρ / (1 − ρ), is.
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
        mass, total, tol = self.body.mass, self.body.total_mass_kg, self.tolerance_m
        previous = np.inf
        rotated = self._rotated if self.solver.jacobian == "rotated" else None
        for iteration in range(1, self.solver.max_iterations + 1):
            r, es, fd, dissipation = self.residual(t1, q, v, acc, lam, U)
            g = c.residual(q, U)
            if rotated is None:
                dq, dlam = self._exact_correction(q, es, r, g, U)
            else:
                if iteration == 1:
                    rotated.prepare(es.rotation, U)
                dq, dlam = rotated.solve(r, g)
            delta = float(np.sqrt(abs(dq @ (mass @ dq)) / total))
            if not delta < np.inf:
                raise IntegrationError(f"the state is no longer finite at t = {t1:.6g} s "
                                       f"(Newton iteration {iteration})", t1)
            q += dq
            v += self.gamma_p * dq
            acc += self.beta_p * dq
            lam += dlam
            if delta <= tol or delta * delta <= tol * (previous - delta) < np.inf:
                break
            previous = delta
        else:
            raise IntegrationError(
                f"Newton did not converge at t = {t1:.6g} s: {iteration} iterations, last "
                f"increment {delta:.3e} m (tolerance {tol:.1e} m), residual |r| = "
                f"{np.linalg.norm(r):.3e}, |g| = {np.linalg.norm(g) if c.count else 0.0:.3e}; "
                "reduce [scene] time_step or raise [scene.solver] max_iterations", t1)
        a1 = a1 + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * (acc - s.acc)
        return (State(t=t1, q=q, v=v, acc=acc, a=a1, lam=lam),
                StepInfo(es, fd, dissipation, U, iteration))

    def _exact_correction(self, q: np.ndarray, es: ElasticState, r: np.ndarray,
                          g: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Solve [S Cᵀ; C 0] with the exact elastic tangent (damping rotated, as in S₀)."""
        alpha, beta = self.damping
        n, m = self.body.dofs, self.constraints.count
        R = np.kron(np.eye(n // 3), es.rotation)
        D = R @ (alpha * self.body.mass + beta * self.body.stiffness) @ R.T
        S = self.beta_p * self.body.mass + self.gamma_p * D + elastic_tangent(self.body, q, es)
        if not m:
            return -np.linalg.solve(S, r), np.zeros(0)
        C = self.constraints.jacobian(U)
        kkt = np.block([[S, C.T], [C, np.zeros((m, m))]])
        sol = -np.linalg.solve(kkt, np.concatenate([r, g]))
        return sol[:n], sol[n:]


class _RotatedKKT:
    """Newton corrections with S ≈ T S₀ Tᵀ and the constraints' Schur complement.

    For rows kron(v_k, u_i): Tᵀ kron(v, u) = kron(v, Rᵀu), so with Y_k = S₀⁻¹ [kron(v_k, e_l)]_l
    (n × 3, once) and Γ_kl = [kron(v_k, e_a)ᵀ S₀⁻¹ kron(v_l, e_b)]_ab (3 × 3, once):
    C S⁻¹ Cᵀ = [(Rᵀu_i)ᵀ Γ_{k_i k_j} (Rᵀu_j)]_ij, and S⁻¹ Cᵀ Δλ = T Σ_i Δλ_i Y_{k_i} Rᵀu_i.
    Then Δλ = (C S⁻¹ Cᵀ)⁻¹ (g − C S⁻¹ r) and Δq = −S⁻¹ (r + Cᵀ Δλ).
    """

    def __init__(self, body: Body, constraints: Constraints, solve: Solve) -> None:
        self.solve0 = solve
        self.nf = body.field_count
        self.c = constraints
        m = constraints.count
        if m:
            nv = len(constraints.vectors)
            basis = np.zeros((body.dofs, nv, 3))
            for l in range(3):
                basis.reshape(self.nf, 3, nv, 3)[:, l, :, l] = constraints.vectors.T
            Y = np.asarray(solve(basis.reshape(body.dofs, 3 * nv))).reshape(body.dofs, nv, 3)
            gamma = np.einsum("nka,nlb->kalb", basis, Y)
            idx = constraints.index
            self.Y = Y[:, idx, :].reshape(body.dofs, 3 * m)            # columns (i, a)
            self.gamma = gamma[idx][:, :, idx, :].reshape(3 * m, 3 * m)
            self.blocks = np.zeros((3 * m, m))                         # block-diagonal Rᵀu_i
            self.block_index = (np.arange(3 * m), np.repeat(np.arange(m), 3))

    def prepare(self, R: np.ndarray, U: np.ndarray) -> None:
        """Fix T = I ⊗ R and the constraint directions U for the iterations that follow."""
        self.R = R
        if self.c.count:
            self.Ru = U @ R                                         # rows (Rᵀ u_i)ᵀ
            B = self.blocks
            B[self.block_index] = self.Ru.ravel()
            self.schur_inv = np.linalg.inv(B.T @ (self.gamma @ B))

    def solve(self, r: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Δq, Δλ) for the residuals r, g with the prepared R and U."""
        nf, R = self.nf, self.R
        z = self.solve0((r.reshape(nf, 3) @ R).ravel())
        if not self.c.count:
            return -(z.reshape(nf, 3) @ R.T).ravel(), g
        Cz = (self.Ru * (self.c.row_vectors @ z.reshape(nf, 3))).sum(axis=1)
        dlam = self.schur_inv @ (g - Cz)
        y = z + self.Y @ (dlam[:, None] * self.Ru).ravel()
        return -(y.reshape(nf, 3) @ R.T).ravel(), dlam
