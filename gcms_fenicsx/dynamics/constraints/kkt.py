"""The linear Newton system of a step, [S Cᵀ; C 0] [Δq; Δλ] = −[r; g], two ways.

:class:`BorderedKKT` (production): S = T S₀ Tᵀ (+ X Y, the rank-9 change of frame) with S₀
factorised once per run; the constraints and X Y enter by the Woodbury identity as a border
solved once per step (docs/design.md §6). :class:`AssembledKKT` (the benchmarks' baseline,
``[scene.solver] jacobian = "assembled"``): the same exact S assembled densely and
LU-factorised at every iteration — textbook Newton. :class:`TangentKKT`: S = β' Mr plus the
exact tangent of an elastic law that provides one (Saint Venant–Kirchhoff, ``svk``),
assembled and inverted densely when prepared. All have ``prepare`` (fix the linearisation
and its frame R) and ``solve`` (a correction for the residuals r_l = Tᵀ r in that frame and
g). NumPy only.
"""
from __future__ import annotations

from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Coordinates
from gcms_fenicsx.dynamics.constraints.joints import Constraints
from gcms_fenicsx.numerics.lapack import dot_into, inverse

Solve = Callable[[np.ndarray], np.ndarray]
#: (elastic state, X ↦ A X) ↦ (X_loc, Y_loc): the change-of-frame term of the co-rotated law
#: in the body frame (``corotated.local_frame_update``, ``rotor.rotor_frame_update``).
Operator = Callable[[np.ndarray], np.ndarray]
FrameUpdate = Callable[[Any, Operator], tuple[np.ndarray, np.ndarray]]


class BorderedKKT:
    """Newton corrections for S = T S₀ Tᵀ (+ X Y) bordered by the constraints, in the body frame.

    With T = I ⊗ R (``body.frame``; T(ψ) in rotor coordinates) fixed for the step,
    Δq = T Δq_l, r_l = Tᵀ r, C_l = C T (rows kron(v_i, Rᵀu_i)), X = T X_loc and
    Y = Y_loc Tᵀ, the system is
    [S₀ + X_loc Y_loc, C_lᵀ; C_l, 0] [Δq_l; Δλ] = −[r_l; g]. With z = S₀⁻¹ r_l, the border
    B = S₀⁻¹ [C_lᵀ | X_loc] and G = [C_l; Y_loc] (Woodbury):

        (G B + [0 0; 0 I]) [Δλ; y] = [g; 0] − G z,    Δq_l = −(z + B [Δλ; y]).

    For rows c(u_i) linear in the direction, c(u) T = c(Rᵀu) (the rows are equivariant), so
    S₀⁻¹ c_l,i = Y_k Rᵀu_i with Y_k = S₀⁻¹ [c_k(e_l)]_l (``Constraints.unit_rows``) solved
    once per run. Per iteration (r_l comes turned, ``integrator``): one solve with S₀, three
    small products and Δq turned back; per step: Bᵀ's and G's constraint rows (one product
    each, written in place), the (m + 9)-square capacitance matrix G B + [0 0; 0 I] (one
    product) and its inverse. Bᵀ, G and the rest are allocated once for each kind of step
    (with the rank-9 term or without; ``rank``: 9, or 2 for rotor coordinates).
    """

    def __init__(self, body: Coordinates, constraints: Constraints, solve: Solve,
                 apply_A: Operator, frame_update: FrameUpdate,
                 rank: int = 9) -> None:
        self.body, self.c, self.solve0, self.apply_A = body, constraints, solve, apply_A
        self.frame, self.frame_update = body.frame, frame_update
        self.kept = False       # the rank-9 term's rows hold a linearisation
        m = self.m = constraints.count
        n = body.dofs
        if m:
            nv = len(constraints.vectors)
            rows = constraints.unit_rows().reshape(3 * nv, n)
            Y = np.asarray(solve(rows.T)).reshape(n, nv, 3)
            self.YT = np.ascontiguousarray(Y[:, constraints.index, :].reshape(n, 3 * m).T)
            self.blocks = np.zeros((m, 3 * m))                   # row i: Rᵀu_i at columns 3i..
            self.diagonal = np.lib.stride_tricks.as_strided(
                self.blocks, shape=(m, 3), strides=((3 * m + 3) * 8, 8))
        self.kinds = {exact: _border(n, m + rank * exact, m) for exact in (False, True)}
        self.BT: np.ndarray | None = None

    def prepare(self, es: Any, U: np.ndarray, C: np.ndarray | None, exact: bool,
                relinearise: bool = True) -> None:
        """Fix R, the constraint directions U and rows C (m × n, None without constraints)
        and (``exact``) the rank-9 term for the step.

        ``es``: the elastic state; without ``exact`` only its rotation is read, so another
        elastic model's state serves (it carries the same frame R = polar(A(q))).

        The rank-9 term is kept in the body frame: X_loc and Y_loc depend only on the local
        state (Q_loc, P, U, b), so S₀⁻¹ X_loc and Y_loc serve later steps as they are.
        ``relinearise`` (or nothing kept yet) recomputes them at ``es``.
        """
        R, m = es.rotation, self.m
        self.R, self.back = R, self.frame.back_operator(R)
        if exact and (relinearise or not self.kept):
            self._relinearise(es)
        if not m and not exact:
            self.BT = None
            return
        BT, G, minus_pad, BT_rows, G_rows = self.kinds[exact]
        if m:
            self.diagonal[...] = self.frame.directions(U, R)              # Rᵀu_i
            dot_into(self.blocks, self.YT, BT_rows)                       # (S₀⁻¹ C_lᵀ)ᵀ
            self.frame.turn_rows(C, R, G_rows)                            # C_l = C T
        self.BT, self.G = BT, G
        self.minus_inverse = inverse(minus_pad - G.dot(BT.T))           # −(G B + [0 0; 0 I])⁻¹

    def _relinearise(self, es: Any) -> None:
        """X_loc, Y_loc of the rank-9 term at ``es``: (S₀⁻¹ X_loc)ᵀ into Bᵀ, Y_loc into G."""
        X_loc, Y_loc = self.frame_update(es, self.apply_A)
        BT, G = self.kinds[True][:2]
        BT[self.m:] = self.solve0(X_loc).T
        G[self.m:] = Y_loc
        self.kept = True

    def solve(self, r_l: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Δq, Δλ) for the residuals r_l = Tᵀ r (in the frame R fixed by :meth:`prepare`)
        and g."""
        z = self.solve0(r_l)                                            # S₀⁻¹ Tᵀ r
        if self.BT is None:
            return self.frame.back(z, self.back), g[:0]
        Gz = self.G.dot(z)
        Gz[:self.m] -= g
        sol = self.minus_inverse.dot(Gz)                              # [Δλ; y]
        z += sol.dot(self.BT)
        return self.frame.back(z, self.back), sol[:self.m]


def _border(n: int, k: int, m: int) -> tuple[np.ndarray, ...]:
    """Bᵀ (k × n), G (k × n), minus the capacitance matrix's identity block [0 0; 0 I]
    (k × k) beyond the m constraint rows, and the constraint rows of Bᵀ and of G, which every
    step rewrites."""
    minus_pad = np.zeros((k, k))
    minus_pad[m:, m:] = -np.eye(k - m)
    BT, G = np.zeros((k, n)), np.zeros((k, n))
    return BT, G, minus_pad, BT[:m], G[:m]


class AssembledKKT:
    """Textbook Newton: [S Cᵀ; C 0] with S = T S₀ Tᵀ + X Y assembled densely and solved by LU at
    every ``solve`` (dense bodies only; the baseline the benchmarks compare against)."""

    def __init__(self, body: Coordinates, constraints: Constraints, S0: np.ndarray,
                 apply_A: Operator, frame_update: FrameUpdate) -> None:
        self.body, self.c, self.S0, self.apply_A = body, constraints, S0, apply_A
        self.frame_update = frame_update
        self.es: Any = None
        self.C: np.ndarray | None = None

    def prepare(self, es: Any, U: np.ndarray, C: np.ndarray | None, exact: bool,
                relinearise: bool = True) -> None:
        """Linearise at ``es`` with the constraint rows C (always exact)."""
        self.es, self.C, self.R = es, C, es.rotation

    def solve(self, r_l: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Δq, Δλ) for the residuals r_l = Tᵀ r (in the frame R of ``prepare``) and g."""
        n, m = self.body.dofs, self.c.count
        frame = self.body.frame
        r = frame.to_global(r_l, self.R)
        T = frame.matrix(self.R, n)
        X, Y = self.frame_update(self.es, self.apply_A)
        S = T @ (self.S0 + X @ Y) @ T.T
        C = self.C if m else np.zeros((0, n))
        kkt = np.block([[S, C.T], [C, np.zeros((m, m))]])
        sol = -np.linalg.solve(kkt, np.concatenate([r, g]))
        return sol[:n], sol[n:]


class TangentKKT:
    """Newton corrections with S = β' Mr + ∂²V/∂q² (the elastic state's ``tangent()``), the
    bordered matrix [S Cᵀ; C 0] assembled and inverted when prepared and reused by every
    ``solve`` until the next ``prepare`` (dense bodies only)."""

    def __init__(self, body: Coordinates, constraints: Constraints, beta_p: float) -> None:
        self.c, self.frame = constraints, body.frame
        self.inertia = beta_p * np.asarray(body.mass)
        self.n = body.dofs

    def prepare(self, es: Any, U: np.ndarray, C: np.ndarray | None, exact: bool,
                relinearise: bool = True) -> None:
        """Linearise at ``es`` with the constraint rows C."""
        n, m = self.n, self.c.count
        self.R = es.rotation
        C = C if m else np.zeros((0, n))
        self.kkt_inverse = inverse(np.block([[self.inertia + es.tangent(), C.T],
                                             [C, np.zeros((m, m))]]))

    def solve(self, r_l: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Δq, Δλ) for the residuals r_l = Tᵀ r (in the frame R of ``prepare``) and g."""
        r = self.frame.to_global(r_l, self.R)
        sol = -self.kkt_inverse.dot(np.concatenate([r, g]))
        return sol[:self.n], sol[self.n:]
