"""The linear Newton system of a step, [S Cᵀ; C 0] [Δq; Δλ] = −[r; g], two ways.

:class:`BorderedKKT` (production): S = T S₀ Tᵀ (+ X Y, the rank-9 change of frame) with S₀
factorised once per run; the constraints and X Y enter by the Woodbury identity as a border
solved once per step (docs/design.md §6). :class:`AssembledKKT` (the benchmarks' baseline,
``[scene.solver] jacobian = "assembled"``): the same exact S assembled densely and
LU-factorised at every iteration — textbook Newton. Both have ``prepare`` (fix the
linearisation) and ``solve`` (a correction for residuals r, g). NumPy only.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.corotated import frame_update
from gcms_fenicsx.dynamics.joints import Constraints

Solve = Callable[[np.ndarray], np.ndarray]


def rotate(R: np.ndarray, X: np.ndarray) -> np.ndarray:
    """T X = vec(X_f R ᵀ) for the columns of X (n,) or (n, k): each field's 3-vector turned by R."""
    k = X.shape[1:]
    return (R @ X.reshape((-1, 3) + k)).reshape(X.shape) if k else (X.reshape(-1, 3) @ R.T).ravel()


class BorderedKKT:
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
            borders.append(rotate(R, self.Y @ B))                    # S_T⁻¹ Cᵀ
            matrix = B.T @ (self.gamma @ B)
        if exact:
            if relinearise or self.local is None:
                X, Y = frame_update(self.body, es, self.apply_A)
                X_loc, Y_loc = rotate(R.T, X), rotate(R.T, Y.T).T
                SX_loc = np.asarray(self.solve0(X_loc))
                self.local = (Y_loc, SX_loc, np.eye(X.shape[1]) + Y_loc @ SX_loc)
            Y_loc, SX_loc, inner = self.local
            self.Yrows = rotate(R, Y_loc.T).T                          # Y = Y_loc Tᵀ
            SX = rotate(R, SX_loc)                                     # S_T⁻¹ X
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
        z = rotate(R, np.asarray(self.solve0(rotate(R.T, r))))
        if self.border is None:
            return -z, g[:0]
        rhs = g - self.c.values(z, self.U)
        if self.exact:
            rhs = np.concatenate([rhs, -(self.Yrows @ z)])
        sol = self.inverse @ rhs
        return -(z + self.border @ sol), sol[:m]


class AssembledKKT:
    """Textbook Newton: [S Cᵀ; C 0] with S = T S₀ Tᵀ + X Y assembled densely and solved by LU at
    every ``solve`` (dense bodies only; the baseline the benchmarks compare against)."""

    def __init__(self, body: Body, constraints: Constraints, S0: np.ndarray,
                 apply_A: Callable[[np.ndarray], np.ndarray]) -> None:
        self.body, self.c, self.S0, self.apply_A = body, constraints, S0, apply_A
        self.es: Any = None
        self.U: np.ndarray | None = None

    def prepare(self, es: Any, U: np.ndarray, exact: bool, relinearise: bool = True) -> None:
        """Linearise at ``es`` with the constraint directions U (always exact)."""
        self.es, self.U = es, U

    def solve(self, r: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n, m = self.body.dofs, self.c.count
        T = np.kron(np.eye(n // 3), self.es.rotation)
        X, Y = frame_update(self.body, self.es, self.apply_A)
        S = T @ self.S0 @ T.T + X @ Y
        C = self.c.jacobian(self.U)
        kkt = np.block([[S, C.T], [C, np.zeros((m, m))]])
        sol = -np.linalg.solve(kkt, np.concatenate([r, g]))
        return sol[:n], sol[n:]
