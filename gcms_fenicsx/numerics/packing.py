"""svec and smat: symmetric nf × nf matrices as packed vectors of their nf(nf+1)/2 entries
(a, b), a ≤ b, row by row, the off-diagonal ones scaled by √2 so that
svec(X) · svec(Y) = X : Y — the coordinates of the Saint Venant–Kirchhoff energy
(docs/design.md §7.2, ``dynamics.bodies.svk``) and of its coefficients
(``fe.svk_coefficients``). NumPy only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class Packing:
    """svec and smat for nf × nf symmetric matrices: the entries (a, b), a ≤ b, row by row,
    the off-diagonal ones scaled by √2 (module docstring)."""

    field_count: int

    @cached_property
    def rows(self) -> np.ndarray:
        return np.triu_indices(self.field_count)[0]

    @cached_property
    def cols(self) -> np.ndarray:
        return np.triu_indices(self.field_count)[1]

    @cached_property
    def scale(self) -> np.ndarray:
        return np.where(self.rows == self.cols, 1.0, SQRT2)

    def svec(self, P: np.ndarray) -> np.ndarray:
        """The packed vector of symmetric P (nf × nf), or of the symmetric parts of a stack
        (..., nf, nf): the (a, b) and (b, a) entries averaged."""
        upper = P[..., self.rows, self.cols]
        lower = P[..., self.cols, self.rows]
        return 0.5 * (upper + lower) * self.scale

    @cached_property
    def index(self) -> np.ndarray:
        """(nf × nf): the position in svec of entry (a, b), the same for (b, a)."""
        index = np.empty((self.field_count, self.field_count), dtype=np.intp)
        index[self.rows, self.cols] = np.arange(len(self.rows))
        index[self.cols, self.rows] = np.arange(len(self.rows))
        return index

    def jacobian_weights(self, Q: np.ndarray) -> np.ndarray:
        """(nf, nf, 3): W[f, b, l] = ∂ svec(Q Qᵀ)[index[f, b]] / ∂Q_fl — 2 Q_fl for b = f,
        √2 Q_bl otherwise — so column (f, l) of L = ∂p/∂q holds W[f, :, l] at rows index[f]."""
        W = np.broadcast_to(SQRT2 * Q, (len(Q), *Q.shape)).copy()
        f = np.arange(len(Q))
        W[f, f, :] = 2.0 * Q
        return W

    def smat(self, y: np.ndarray) -> np.ndarray:
        """The symmetric S with S : X = y · svec(X) for every symmetric X."""
        S = np.zeros((self.field_count, self.field_count))
        entries = y / self.scale               # y_aa on the diagonal, y_ab / √2 off it
        S[self.rows, self.cols] = entries
        S[self.cols, self.rows] = entries
        return S


@lru_cache(maxsize=8)
def packing(field_count: int) -> Packing:
    """The :class:`Packing` of nf fields, made once per nf."""
    return Packing(field_count)
