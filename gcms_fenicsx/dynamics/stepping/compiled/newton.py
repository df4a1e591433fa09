"""The compiled step's Newton system (``kkt.BorderedKKT``): the change of frame
(``corotated.local_frame_update``, ``rotor.rotor_frame_update``), its relinearisation, and the
bordered solve with the constraint rows applied through their units. Numba."""
from __future__ import annotations

import numpy as np
from numba import njit

from gcms_fenicsx.dynamics.stepping.compiled.algebra import (INLINE, JIT, axial, gram_product,
                                                             lu_factor, lu_solve, mat3,
                                                             mul_into, mv3, product, remove,
                                                             skew, tmul, xe)
from gcms_fenicsx.dynamics.stepping.compiled.laws import back
from gcms_fenicsx.dynamics.stepping.kernel_data import ROTOR

@njit(**JIT)
def apply_A(X, K, M, gram, rotor, gamma_p, alpha, beta, symmetric):
    """damping.RayleighDamping.frame_operator: A X = γ'α Mr X + (1 + γ'β) K X, K = Kr or an
    operator with the same products (:func:`field_frame_update`), by one triangle if
    ``symmetric``."""
    out = (1.0 + gamma_p * beta) * gram_product(K, X, symmetric)
    if alpha != 0.0:
        if rotor:
            out += (gamma_p * alpha) * gram_product(M, X)
        else:
            n, k = X.shape
            MX = gram_product(gram, np.ascontiguousarray(X).reshape(gram.shape[0], 3 * k))
            out += (gamma_p * alpha) * MX.reshape(n, k)
    return out


@njit(**JIT)
def field_frame_update(U, S_inv, local, P, b, gradient, H, k1, g1m, KP, gram, gamma_p,
                       alpha, beta, symmetric):
    """corotated.local_frame_update: the first three columns of X_loc, B + U₃, and Y_loc of the
    rank-9 change-of-frame term. X_loc's other six columns, Wᵀ = Hₓ S⁻¹ᵀ and U₂, are constant
    up to S⁻¹, so S₀⁻¹ times them is formed once (``StepData.frame_solves``; :func:`_relinearise`).
    Kr's products are made with KP = (Πᵀ ⊗ I3) Kr, the law's matrix (kept in cache between
    steps): B = Πᵀ A Ĉ is the same (Πᵀ is a projector) and so is Ĉᵀ A Ĉ, since Π Ĉ = Ĉ (Ĉ's
    fields are cross products of Π Q_loc's, whose g1-weighted sum is zero)."""
    nf = H.shape[0]
    n = 3 * nf
    W_T = np.empty((n, 3))                       # row (f, a): S⁻¹ (h_f × e_a)
    C_hat = np.empty((n, 3))                     # [(f, j), k] = ((Π Q_loc)_f × e_k)_j
    U3 = np.empty((n, 3))                        # [(f, j), k] = −(gradient_f × e_k)_j
    PL = remove(local, k1, g1m)
    for f in range(nf):
        for a in range(3):
            h0, h1, h2 = xe(H[f], a, 0), xe(H[f], a, 1), xe(H[f], a, 2)
            for j in range(3):
                W_T[3 * f + a, j] = S_inv[j, 0] * h0 + S_inv[j, 1] * h1 + S_inv[j, 2] * h2
        for k in range(3):
            for j in range(3):
                C_hat[3 * f + j, k] = xe(PL[f], k, j)
                U3[3 * f + j, k] = -xe(gradient[f], k, j)
    AC = apply_A(C_hat, KP, KP, gram, False, gamma_p, alpha, beta, symmetric)
    B9 = remove(AC.reshape(nf, 9), g1m, k1)     # Πᵀ A Ĉ, fieldwise
    Yl = tmul(local, P)
    X3 = skew(mv3(U, b))                       # [U b]×, plus M_Yᵀ: [k, c] = w([e_k]× Y)_c
    E = np.eye(3)
    for k in range(3):
        X3[k] += axial(mat3(skew(E[k]), Yl))
    M = np.zeros((3, 3))                         # Ĉᵀ A Ĉ
    for i in range(n):
        for k in range(3):
            for j in range(3):
                M[k, j] += C_hat[i, k] * AC[i, j]
    X = np.empty((n, 3))                         # Πᵀ A Ĉ + U₃
    Y = np.empty((9, n))
    for f in range(nf):
        hb = H[f, 0] * b[0] + H[f, 1] * b[1] + H[f, 2] * b[2]
        for k in range(3):
            i = 3 * f + k
            om = W_T[i]
            db0, db1, db2 = _frame_rate_row(P[f], k, om, X3, H[f, k], b, hb)
            for j in range(3):
                B = B9[f, 3 * k + j]
                X[i, j] = B + U3[i, j]
                Y[3 + j, i] = B + M[j, 0] * om[0] + M[j, 1] * om[1] + M[j, 2] * om[2]
                Y[j, i] = om[j]
                Y[6 + j, i] = S_inv[j, 0] * db0 + S_inv[j, 1] * db1 + S_inv[j, 2] * db2
    return X, Y


@njit(**INLINE)
def _frame_rate_row(Pf, k, om, X3, hfk, b, hb):
    """Column (f, k) of db in :func:`field_frame_update`: (P_f × e_k) − X3ᵀ ω − h_fk b
    + (h_f · b) e_k, ω = W_T's row (f, k)."""
    out0 = xe(Pf, k, 0) - (om[0] * X3[0, 0] + om[1] * X3[1, 0] + om[2] * X3[2, 0]) - hfk * b[0]
    out1 = xe(Pf, k, 1) - (om[0] * X3[0, 1] + om[1] * X3[1, 1] + om[2] * X3[2, 1]) - hfk * b[1]
    out2 = xe(Pf, k, 2) - (om[0] * X3[0, 2] + om[1] * X3[1, 2] + om[2] * X3[2, 2]) - hfk * b[2]
    if k == 0:
        out0 += hb
    elif k == 1:
        out1 += hb
    else:
        out2 += hb
    return out0, out1, out2


@njit(**JIT)
def rotor_frame_update(f, c, slope, beta, rho, turn, weights, Ac):
    """rotor.rotor_frame_update: (X_loc, Y_loc) of the rank-2 change of frame, A c given."""
    a = Ac - turn @ f - (beta / rho) * weights[0]
    kappa = c @ Ac + f @ (turn @ c)
    n = f.shape[0]
    X = np.empty((n, 2))
    X[:, 0], X[:, 1] = a, slope
    Y = np.empty((2, n))
    Y[0], Y[1] = -slope, kappa * slope - a
    return X, Y


@njit(**JIT)
def relinearise(d, X, Y, S_inv):
    """BorderedKKT._relinearise: (S₀⁻¹ X_loc)ᵀ and Y_loc into the exact system's last rows; X
    is X_loc (rotor) or its first three columns (GCMS coordinates, with S⁻¹ for the next
    three). Then the capacitance blocks they change (:func:`frame_capacitance`)."""
    m = d.m
    BT = d.border_exact[m:]
    XT = np.ascontiguousarray(X.T)
    for k in range(XT.shape[0]):
        product(d.s0_inverse, XT[k], BT[k], d.s0_symmetric)
    if d.law != ROTOR:
        SH, SU = d.frame_solves[:3], d.frame_solves[3:]
        for j in range(3):
            BT[3 + j] = S_inv[j, 0] * SH[0] + S_inv[j, 1] * SH[1] + S_inv[j, 2] * SH[2]
            BT[6 + j] = SU[j]
    d.rows_exact[m:] = Y
    frame_capacitance(d)


@njit(**JIT)
def frame_capacitance(d):
    """The change-of-frame rows G_x, S₀⁻¹-solved B_x (the NumPy step's kept rows) copied
    beside the constraint units, and their blocks of W = [c(e); G_x] [S₀⁻¹ c(e)ᵀ, B_x]
    (``StepData.unit_capacitance``): products of length n, once per relinearisation."""
    m, u = d.m, d.rows_all.shape[0] - d.rank
    d.rows_all[u:] = d.rows_exact[m:]
    d.solves_all[u:] = d.border_exact[m:]
    W = d.unit_capacitance
    W[u:, :] = d.rows_all[u:] @ d.solves_all.T
    if u:
        W[:u, u:] = d.rows_all[:u] @ d.solves_all[u:].T


@njit(**JIT)
def prepare(exact, U, world, pad, W, index, rank, work):
    """BorderedKKT.prepare (the rank-9 rows already relinearised where asked), with the
    constraint rows never formed: in the frame, row i is G_i = Σ_l a_il c_i(e_l) and its
    solve B_iᵀ = Σ_l a_il S₀⁻¹ c_i(e_l)ᵀ (a_i = Rᵀ u_i, either kind of coordinates), so the
    capacitance matrix G B + [0 0; 0 I] follows from W (:func:`frame_capacitance`) in
    O(m²): (a, its LU factors with pivots), in the stretch's ``work`` (``step.BORDERED``: a,
    then room for the capacitance matrix, G W and the pivots), kept until the next prepare."""
    m = index.shape[0]
    u = W.shape[0] - rank
    k, columns = pad.shape[0], W.shape[1]
    a = mul_into(U, world, work[0])
    cap = work[1][:k * k].reshape(k, k)
    cap[:, :] = pad
    aW = work[2][:m * columns].reshape(m, columns)   # a_i · W[3k_i + l, :]: the rows of G W
    for i in range(m):
        ki = 3 * index[i]
        for c in range(W.shape[1]):
            aW[i, c] = a[i, 0] * W[ki, c] + a[i, 1] * W[ki + 1, c] + a[i, 2] * W[ki + 2, c]
    for i in range(m):
        for j in range(m):
            kj = 3 * index[j]
            cap[i, j] -= aW[i, kj] * a[j, 0] + aW[i, kj + 1] * a[j, 1] + aW[i, kj + 2] * a[j, 2]
    if exact:
        for i in range(m):
            ki = 3 * index[i]
            for r in range(rank):
                cap[i, m + r] -= aW[i, u + r]
                cap[m + r, i] -= (a[i, 0] * W[u + r, ki] + a[i, 1] * W[u + r, ki + 1]
                                  + a[i, 2] * W[u + r, ki + 2])
        for r in range(rank):
            for s in range(rank):
                cap[m + r, m + s] -= W[u + r, u + s]
    piv = lu_factor(cap, work[3][:k])
    return a, cap, piv


@njit(**JIT)
def solve(bordered, a, lu, piv, r, g, R, phase, rotor, pairs, s0_inverse, symmetric, rows_all,
          solves_all, index, rank, work):
    """BorderedKKT.solve: (Δq, Δλ) for the residuals r (frame R) and g, the bordered rows
    applied through the units (:func:`prepare`): two products with 3 nv (+ rank) rows. Δq is
    written into ``work`` (the stretch's work arrays 0, 1, 2, 4, 5, 9 and 20:
    ``step._scratch``), which also holds the products."""
    z = work[0]
    product(s0_inverse, r, z, symmetric)
    if bordered:
        m = a.shape[0]
        u = rows_all.shape[0] - rank
        k = lu.shape[0]
        rows = u + k - m
        Gz = work[3][:rows]
        np.dot(rows_all[:rows], z, Gz)
        b = work[6][:k]
        for i in range(m):
            ki = 3 * index[i]
            b[i] = a[i, 0] * Gz[ki] + a[i, 1] * Gz[ki + 1] + a[i, 2] * Gz[ki + 2] - g[i]
        for r_ in range(k - m):
            b[m + r_] = Gz[u + r_]
        sol = lu_solve(lu, piv, b)           # in place: Δλ is a view of the work array
        w = work[4][:rows]
        w[:] = 0.0
        for i in range(m):
            ki = 3 * index[i]
            for l in range(3):
                w[ki + l] += sol[i] * a[i, l]
        for r_ in range(k - m):
            w[u + r_] = sol[m + r_]
        t = work[1]
        np.dot(w, solves_all[:rows], t)
        z += t
        dlam = sol[:m]
    else:
        dlam = work[5]
    return back(rotor, pairs, z, R, phase, work[2]), dlam
