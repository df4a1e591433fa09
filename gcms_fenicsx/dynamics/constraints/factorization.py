"""Factorising the integrator's constant matrices, and saying why one is singular.

``dense_factorization`` inverts a small dense matrix once (the reduced body's S₀ and Mr);
a sparse LU serves the full-order references (``references.full_order``). Either raises
:class:`~gcms_fenicsx.dynamics.stepping.errors.SingularMatrixError`, and the callers here turn it into
the cause a user can act on: dependent fields (Mr) or a time step too large for the body
(S₀, :func:`singular_iteration_matrix`).
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.stepping.alpha import AlphaParameters, newton_coefficients
from gcms_fenicsx.dynamics.bodies.body import Body, elastic_modes
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.stepping.errors import IntegrationError, SingularMatrixError
from gcms_fenicsx.config.scene import SceneError

Solve = Callable[[np.ndarray], np.ndarray]
Factorize = Callable[[Any], Solve]
#: ``dense_factorization`` refuses a matrix whose computed inverse leaves |A A⁻¹ − I| above this.
INVERSE_DEFECT_LIMIT = 1e-6
EPS = float(np.finfo(float).eps)


def dense_factorization(A: np.ndarray) -> Solve:
    """x = A⁻¹ b by one mat-vec with the explicit inverse (A small and dense): its bound ``dot``.
    The inverse of a symmetric A is made exactly symmetric (:func:`symmetric_inverses`), so
    that the compiled step, which reads one triangle of it (``kernel_data.SYMMETRIC_FROM``),
    applies the very matrix this one does — where that is an inverse to
    ``INVERSE_DEFECT_LIMIT`` too (else the LU's inverse is kept).

    Raises :class:`SingularMatrixError` if A is singular or so ill-conditioned that A A⁻¹ is
    not I to ``INVERSE_DEFECT_LIMIT``; the caller knows what A is and says why
    (:func:`mass_factorization`, :func:`singular_iteration_matrix`).
    """
    A = np.asarray(A)
    try:
        inv = np.linalg.inv(A)
    except np.linalg.LinAlgError as exc:
        raise SingularMatrixError(np.inf, np.inf) from exc
    defect = inverse_defect(A, inv)
    if not defect < INVERSE_DEFECT_LIMIT:
        raise SingularMatrixError(defect, np.linalg.cond(A))
    if np.array_equal(A, A.T):
        for symmetric in symmetric_inverses(A, inv):
            if inverse_defect(A, symmetric) < INVERSE_DEFECT_LIMIT:
                return symmetric.dot
    return inv.dot


def symmetric_inverses(A: np.ndarray, X: np.ndarray) -> Iterator[np.ndarray]:
    """Exactly symmetric inverses of the symmetric A, the LU's inverse X given: X's symmetric
    part, then — A positive definite — L⁻ᵀ L⁻¹ from A = L Lᵀ. The first is as good as X where X
    is accurate from both sides; but the LU's inverse is accurate from the right (|A X − I| ~
    cond(A) ε), not always from the left: for an S₀ of cond 1.1e9 (the stiff pendulum at 450
    coordinates) |A X − I| = 5.9e-12, |X A − I| = 5.5e-6, and its symmetric part leaves
    |A X − I| at 2.7e-6, the Cholesky factor's inverse at 2.6e-7 (cond(A) ε from both sides:
    at most 0.9× the symmetric part's on the matrices of tests/dynamics/test_factorization)."""
    yield 0.5 * (X + X.T)
    try:
        inverse_factor = np.linalg.inv(np.linalg.cholesky(A))
    except np.linalg.LinAlgError:
        return
    product = inverse_factor.T @ inverse_factor
    yield 0.5 * (product + product.T)


def inverse_defect(A: np.ndarray, inverse: np.ndarray) -> float:
    """max |A A⁻¹ − I|."""
    return float(np.abs(A @ inverse - np.eye(len(A))).max())


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


def _one_two_five_below(h: float, decades: int = 20) -> Iterator[float]:
    """1, 2, 5 × 10^k below h, descending, over ``decades`` decades."""
    top = math.floor(math.log10(h))
    for k in range(top, top - decades, -1):
        for m in (5.0, 2.0, 1.0):
            if m * 10.0 ** k < h:
                yield m * 10.0 ** k


def singular_iteration_matrix(body: Body, parameters: AlphaParameters, time_step_s: float,
                              damping: RayleighDamping, factorize: Factorize,
                              exc: SingularMatrixError) -> Exception:
    """Why S₀ = β'Mr + Kr (+ damping) is singular, and what to change.

    Either Mr itself is (dependent fields: :func:`mass_factorization` raises), or the time
    step is so large that β' ~ 1/h² sinks into the round-off of Kr on rigid motion: the six
    rigid eigenvalues of (Kr, Mr) are zero only to ε·λ_max(Kr, Mr), so S₀ has eigenvalues
    β' ± ε·λ_max (in the Mr metric) on rigid motion against β' + λ_max on the stiffest mode,
    and the rigid motions lose their inertia in S₀. The step that works is the largest of
    1, 2, 5 × 10^k below h whose S₀ ``factorize`` accepts.
    """
    mass_factorization(body, factorize)
    if not isinstance(body.mass, np.ndarray):
        return exc

    def factorizes(h: float) -> bool:
        try:
            factorize(damping.iteration_matrix(body, *newton_coefficients(parameters, h)))
        except SingularMatrixError:
            return False
        return True

    beta_p, _ = newton_coefficients(parameters, time_step_s)
    noise = EPS * float(elastic_modes(body)[0][-1])
    works = next((h for h in _one_two_five_below(time_step_s) if factorizes(h)), None)
    remedy = (f"time_step = {works:g} s works" if works is not None else
              "no time step down to 1e-20 of it works")
    return SceneError(
        f"[scene] time_step = {time_step_s:g}: the iteration matrix S0 = β'Mr + Kr is "
        f"numerically singular ({exc.numbers}): β' = {beta_p:.2e} 1/s² is only "
        f"{beta_p / noise:.1e} times the round-off of Kr on rigid motion, ε·λ_max(Kr, Mr) = "
        f"{noise:.1e} 1/s² (cond(Mr) = {np.linalg.cond(body.mass):.1e} is fine); {remedy}")
