"""Rotations of 3-vectors: the polar decomposition of the body's affine map, its derivative,
and the skew-matrix helpers the co-rotated forces are written with (docs/design.md §6).

All functions take single 3×3 matrices or stacks ``(..., 3, 3)`` and 3-vectors or stacks
``(..., 3)``, so a tangent can be built for many directions at once.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gcms_fenicsx.numerics.lapack import svd


class InvertedBodyError(ArithmeticError):
    """The body's affine map has a non-positive determinant or is degenerate: no rotation can be
    taken from it. ``det`` and ``singular_values`` are the map's; :attr:`numbers` says them."""

    def __init__(self, det: float, singular_values: np.ndarray) -> None:
        self.det = float(det)
        self.singular_values = tuple(float(s) for s in singular_values)
        super().__init__(f"affine map of the body has {self.numbers}: the body is inverted or "
                         "collapsed")

    def __reduce__(self):  # picklable, so MPI can send it from the rank that saw it
        return (type(self), (self.det, self.singular_values))

    @property
    def numbers(self) -> str:
        s = self.singular_values
        return f"det = {self.det:.3e} (singular values {s[0]:.3e}, {s[1]:.3e}, {s[2]:.3e})"


#: [w]× = (w @ SKEW_ROWS).reshape(3, 3): row k holds the flattened [e_k]×.
SKEW_ROWS = np.array([[0, 0, 0, 0, 0, -1, 0, 1, 0],
                      [0, 0, 1, 0, 0, 0, -1, 0, 0],
                      [0, -1, 0, 1, 0, 0, 0, 0, 0]], dtype=float)
#: w(Y) = Y.ravel() @ AXIAL_ROWS (:func:`axial`): Y : [e_k]× in column k, i.e. SKEW_ROWSᵀ.
AXIAL_ROWS = SKEW_ROWS.T.copy()


def skew(w: np.ndarray) -> np.ndarray:
    """[w]× with [w]× v = w × v, for a 3-vector or a stack of them."""
    w = np.asarray(w)
    return (w @ SKEW_ROWS).reshape(w.shape[:-1] + (3, 3))


def axial(Y: np.ndarray) -> np.ndarray:
    """w(Y) = (Y₃₂ − Y₂₃, Y₁₃ − Y₃₁, Y₂₁ − Y₁₂), twice the axial vector of Y's skew part.

    It is the vector with Y : [b]× = w(Y) · b for every b (Frobenius product).
    """
    if Y.ndim == 2:
        (a, b, c), (d, e, f), (g, h, i) = Y.tolist()
        return np.array([h - f, c - g, d - b])
    return np.stack([Y[..., 2, 1] - Y[..., 1, 2], Y[..., 0, 2] - Y[..., 2, 0],
                     Y[..., 1, 0] - Y[..., 0, 1]], axis=-1)


class Polar(NamedTuple):
    """A = R U from one SVD A = W Σ Vᵀ: R = W Vᵀ, U = V Σ Vᵀ."""

    rotation: np.ndarray
    values: np.ndarray     # Σ
    vt: np.ndarray         # Vᵀ
    trace: float           # tr Σ = tr U

    @property
    def stretch(self) -> np.ndarray:
        """U = V Σ Vᵀ."""
        return (self.vt.T * self.values) @ self.vt

    @property
    def rate_operator_inverse(self) -> np.ndarray:
        """S⁻¹ for :func:`rotation_rate`: S = tr U · I − U = V (tr Σ · I − Σ) Vᵀ."""
        return (self.vt.T / (self.trace - self.values)).dot(self.vt)

    def rate_solve(self, w: np.ndarray) -> np.ndarray:
        """S⁻¹ w = V (Vᵀ w / (tr Σ − Σ)), without forming S⁻¹."""
        return self.vt.T.dot(self.vt.dot(w) / (self.trace - self.values))


def polar(A: np.ndarray) -> Polar:
    """The polar decomposition A = R U, R a rotation and U symmetric positive definite.

    Unique for det A > 0; a reflected or degenerate A (and one that is not finite) raises
    :class:`InvertedBodyError`.
    """
    W, s, Vt = svd(A)
    R = W.dot(Vt)
    s0, s1, s2 = s.tolist()
    if not (_det3(R) > 0.0 and s2 > 1e-12 * s0):
        raise InvertedBodyError(np.linalg.det(A), s)
    return Polar(R, s, Vt, s0 + s1 + s2)


def _det3(M: np.ndarray) -> float:
    (a, b, c), (d, e, f), (g, h, i) = M.tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def rotation_rate(R: np.ndarray, S_inv: np.ndarray, dA: np.ndarray) -> np.ndarray:
    """ω with dR = R [ω]× for a change dA of A = R U (one 3×3 or a stack).

    From Rᵀ dA = [ω]× U + dU with dU symmetric: the skew part gives [ω]× U + U [ω]× =
    [(tr U · I − U) ω]× = Rᵀ dA − dAᵀ R, so ω = S⁻¹ w(Rᵀ dA) with S = tr U · I − U
    (positive definite whenever U is).
    """
    return axial(R.T @ dA) @ S_inv.T


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula: the rotation by ``angle`` (rad) about the unit vector ``axis``."""
    K = skew(axis)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)
