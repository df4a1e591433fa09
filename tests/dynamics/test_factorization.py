"""``factorization.dense_factorization`` on symmetric matrices: the inverse it applies is exactly
symmetric (the compiled step reads one triangle of it) and an inverse to the matrix's
conditioning, cond(A) ε — also where the LU's inverse is accurate from the right only and its
symmetric part is not."""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.dynamics.constraints.factorization import (INVERSE_DEFECT_LIMIT,
                                                             dense_factorization,
                                                             inverse_defect,
                                                             symmetric_inverses)

EPS = float(np.finfo(float).eps)


def positive_definite(n: int, cond: float, graded: float, seed: int) -> np.ndarray:
    """Q diag(1 … cond) Qᵀ for a random orthogonal Q, rows and columns scaled by 1 … ``graded``
    (which raises the condition number further), symmetric to the last bit."""
    Q = np.linalg.qr(np.random.default_rng(seed).standard_normal((n, n)))[0]
    D = np.logspace(0, np.log10(graded), n)
    A = D[:, None] * ((Q * np.logspace(0, np.log10(cond), n)) @ Q.T) * D[None, :]
    return 0.5 * (A + A.T)


@pytest.mark.parametrize("cond, graded", [(1e3, 1.0), (1e9, 1.0), (1e5, 1e3)])
def test_a_symmetric_matrix_gets_a_symmetric_inverse_to_its_conditioning(cond, graded):
    """Measured |A A⁻¹ − I| against cond(A) ε: 3.3e-14 / 2.2e-13, 2.9e-08 / 2.2e-07,
    9.1e-09 / 5.2e-07 (n = 300)."""
    A = positive_definite(300, cond, graded, seed=1)
    inverse = dense_factorization(A).__self__
    assert np.array_equal(inverse, inverse.T)
    assert inverse_defect(A, inverse) <= np.linalg.cond(A) * EPS


def test_the_cholesky_inverse_serves_where_the_lus_symmetric_part_does_not():
    """An inverse accurate from the right only — X + A⁻¹ F for a small F: |A X − I| = |F|,
    |X A − I| = |A⁻¹ F A|, up to cond(A) |F| — as the LU's of the stiff pendulum's S₀ is: its
    symmetric part misses ``INVERSE_DEFECT_LIMIT`` and L⁻ᵀ L⁻¹ does not. Measured: |A X − I|
    8.5e-09, |X A − I| 1.7e-04; the symmetric part 8.7e-05, L⁻ᵀ L⁻¹ 1.7e-08 (cond(A) ε 2.2e-07)."""
    A = positive_definite(200, 1e9, 1.0, seed=2)
    F = 1e-12 * np.random.default_rng(4).standard_normal(A.shape)
    right_only = np.linalg.inv(A) + np.linalg.solve(A, F)
    assert inverse_defect(A, right_only) < INVERSE_DEFECT_LIMIT
    plain, cholesky = symmetric_inverses(A, right_only)
    assert not inverse_defect(A, plain) < INVERSE_DEFECT_LIMIT, inverse_defect(A, plain)
    assert np.array_equal(cholesky, cholesky.T)
    assert inverse_defect(A, cholesky) <= np.linalg.cond(A) * EPS, inverse_defect(A, cholesky)


def test_dense_factorization_takes_the_cholesky_inverse_when_the_lus_is_one_sided(monkeypatch):
    """``dense_factorization`` itself, given the right-only inverse of the test above by the LU:
    it applies L⁻ᵀ L⁻¹ (exactly symmetric, equal to what ``symmetric_inverses`` gives second),
    not the LU's inverse nor its symmetric part."""
    A = positive_definite(200, 1e9, 1.0, seed=2)
    F = 1e-12 * np.random.default_rng(4).standard_normal(A.shape)
    right_only = np.linalg.inv(A) + np.linalg.solve(A, F)
    inverse = np.linalg.inv
    monkeypatch.setattr(np.linalg, "inv", lambda M: right_only if M is A else inverse(M))
    applied = dense_factorization(A).__self__
    cholesky = list(symmetric_inverses(A, right_only))[1]
    assert np.array_equal(applied, cholesky)
    assert np.array_equal(applied, applied.T)


def test_a_symmetric_matrix_that_is_not_positive_definite_keeps_its_lu_inverse():
    """No Cholesky factor: the symmetric part or, failing it, the LU's inverse itself (measured
    1.3e-14 against cond(A) ε 2.1e-13)."""
    A = positive_definite(50, 1e3, 1.0, seed=3)
    A[0, 0] = -A[0, 0]
    assert len(list(symmetric_inverses(A, np.linalg.inv(A)))) == 1
    inverse = dense_factorization(A).__self__
    assert inverse_defect(A, inverse) <= np.linalg.cond(A) * EPS
