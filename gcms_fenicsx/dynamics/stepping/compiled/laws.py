"""The compiled step's frames and elastic laws: T on GCMS and rotor coordinates
(``body.FieldFrame``, ``rotor.RotorFrame``), and the co-rotated law in both bases and the
Saint Venant–Kirchhoff law, with Rayleigh damping (``corotated``, ``rotor``, ``svk``,
``damping``). Numba."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gcms_fenicsx.dynamics.stepping.compiled.algebra import (JIT, axial, entries, gram_product,
                                                             mat3, mul, mv3, polar, product,
                                                             remove, skew, tmul, tmul_into)

COLLAPSED = 1e-12   # rotor.COLLAPSED


@njit(**JIT)
def residual(rotor, pairs, y, gradient, R_state, phase_state, same, R, phase, out):
    """FieldFrame.residual / RotorFrame.residual: Tᵀ y + (T_Rᵀ T_state) gradient, into
    ``out``."""
    if rotor:
        c, s = phase[0], -phase[1]
        if phase_state[0] == phase[0] and phase_state[1] == phase[1]:
            gc, gs = 1.0, 0.0
            turned = False
        else:
            zr = complex(phase[0], phase[1]) / complex(phase_state[0], phase_state[1])
            gc, gs = zr.real, -zr.imag
            turned = True
        _turned_into(y, pairs, c, s, out)
        if turned:
            for j in range(y.shape[0]):
                out[j] += gradient[j] if j >= 2 * pairs else 0.0
            for j in range(pairs):
                x, z = gradient[2 * j], gradient[2 * j + 1]
                out[2 * j] += x * gc - z * gs
                out[2 * j + 1] += x * gs + z * gc
        else:
            for j in range(y.shape[0]):
                out[j] += gradient[j]
        return out
    M = R if same else mat3(R_state, R, True)
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = entries(R)
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = entries(M)
    for f in range(y.shape[0] // 3):
        y0, y1, y2 = y[3 * f], y[3 * f + 1], y[3 * f + 2]
        g0, g1, g2 = gradient[3 * f], gradient[3 * f + 1], gradient[3 * f + 2]
        x0 = y0 * r00 + y1 * r10 + y2 * r20
        x1 = y0 * r01 + y1 * r11 + y2 * r21
        x2 = y0 * r02 + y1 * r12 + y2 * r22
        if same:
            x0 += g0
            x1 += g1
            x2 += g2
        else:
            x0 += g0 * m00 + g1 * m10 + g2 * m20
            x1 += g0 * m01 + g1 * m11 + g2 * m21
            x2 += g0 * m02 + g1 * m12 + g2 * m22
        out[3 * f], out[3 * f + 1], out[3 * f + 2] = x0, x1, x2
    return out


@njit(**JIT)
def back(rotor, pairs, z, R, phase, out):
    """−T z, into ``out``."""
    if rotor:
        _turned_into(z, pairs, phase[0], phase[1], out)
        for j in range(z.shape[0]):
            out[j] = -out[j]
        return out
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = entries(R)
    for f in range(z.shape[0] // 3):        # −(R z_f) for every field
        z0, z1, z2 = z[3 * f], z[3 * f + 1], z[3 * f + 2]
        out[3 * f] = -(r00 * z0 + r01 * z1 + r02 * z2)
        out[3 * f + 1] = -(r10 * z0 + r11 * z1 + r12 * z2)
        out[3 * f + 2] = -(r20 * z0 + r21 * z1 + r22 * z2)
    return out


@njit(**JIT)
def corotated_state(q, v, H, k1, g1m, q0p, KP, mass_projected, damping, alpha, beta, work,
                    small, symmetric):
    """corotated.elastic_state with damping.DampingForce.local_force, fused (module
    docstring): (ok, R, U, S⁻¹, Tᵀ(∂V/∂q + f_d) (n,), Q_loc, e, ė, z = (Πᵀ ⊗ I3) Kr (e + β ė)).
    The energy, the dissipation and the elastic part alone follow from these
    (:func:`corotated_energies`, :func:`corotated_parts`). One pass over the fields per
    quantity: Q_loc = Q R, e = Π Q_loc − Π Q0, ė = Π (Q̇ R + Q_loc [ω]×) with
    ω = S⁻¹ w(Rᵀ Q̇ᵀ H), and the force P − H [b]× row by row (h_fᵀ [b]× = h_f × b). Q_loc, e, ė, e + β ė, z and the force are
    written into the stretch's ``work`` arrays (n each), the 3 × 3 ones into ``small``
    (``step.SMALL``: R, U and S⁻¹ are views of it); KP through one triangle if ``symmetric``
    (``algebra.product``)."""
    nf = H.shape[0]
    Q, Vd = q.reshape(nf, 3), v.reshape(nf, 3)
    A, VH = small[5], small[6]
    tmul_into(Q, H, A)                           # Qᵀ H
    if damping:
        tmul_into(Vd, H, VH)                     # Q̇ᵀ H, for the rate only
    R, U, S_inv, ok = polar(A, small[:5])
    Om = skew(mv3(S_inv, axial(mat3(R, VH, True)))) if damping else small[7]   # damping only
    local, rate = work[0].reshape(nf, 3), work[2].reshape(nf, 3)
    rate[:, :] = 0.0
    # the loops keep R, the means and b in scalars (``algebra.entries``)
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = entries(R)
    c0 = c1 = c2 = d0 = d1 = d2 = 0.0
    for f in range(nf):                          # Q_loc = Q R, Q̇ R + Q_loc [ω]×, their means
        x0, x1, x2 = Q[f, 0], Q[f, 1], Q[f, 2]
        l0 = x0 * r00 + x1 * r10 + x2 * r20
        l1 = x0 * r01 + x1 * r11 + x2 * r21
        l2 = x0 * r02 + x1 * r12 + x2 * r22
        local[f, 0], local[f, 1], local[f, 2] = l0, l1, l2
        g = g1m[f]
        c0 += g * l0
        c1 += g * l1
        c2 += g * l2
        if damping:
            for j in range(3):
                y = (Vd[f, 0] * R[0, j] + Vd[f, 1] * R[1, j] + Vd[f, 2] * R[2, j]
                     + l0 * Om[0, j] + l1 * Om[1, j] + l2 * Om[2, j])
                rate[f, j] = y
            d0 += g * rate[f, 0]
            d1 += g * rate[f, 1]
            d2 += g * rate[f, 2]
    e, w = work[1].reshape(nf, 3), work[3]
    for f in range(nf):                          # Π applied; e + β ė
        kf = k1[f]
        x0 = local[f, 0] - kf * c0 - q0p[f, 0]
        x1 = local[f, 1] - kf * c1 - q0p[f, 1]
        x2 = local[f, 2] - kf * c2 - q0p[f, 2]
        e[f, 0], e[f, 1], e[f, 2] = x0, x1, x2
        if damping:
            y0 = rate[f, 0] - kf * d0
            y1 = rate[f, 1] - kf * d1
            y2 = rate[f, 2] - kf * d2
            rate[f, 0], rate[f, 1], rate[f, 2] = y0, y1, y2
            x0 += beta * y0
            x1 += beta * y1
            x2 += beta * y2
        w[3 * f], w[3 * f + 1], w[3 * f + 2] = x0, x1, x2
    z = work[4]
    product(KP, w, z, symmetric)
    total = z.reshape(nf, 3)
    if damping and alpha != 0.0:
        total = total + alpha * gram_product(mass_projected, rate)
    b = _frame_couple(S_inv, tmul_into(local, total, small[8]), small[9, 2])
    gradient = work[5]
    b0, b1, b2 = b[0], b[1], b[2]
    for f in range(nf):          # P_f − h_fᵀ [b]× = P_f − h_f × b
        h0, h1, h2 = H[f, 0], H[f, 1], H[f, 2]
        gradient[3 * f] = total[f, 0] - (h1 * b2 - h2 * b1)
        gradient[3 * f + 1] = total[f, 1] - (h2 * b0 - h0 * b2)
        gradient[3 * f + 2] = total[f, 2] - (h0 * b1 - h1 * b0)
    return ok, R, U, S_inv, gradient, local, e, rate, z


@njit(**JIT)
def _frame_couple(S_inv, T, out):
    """b = S⁻¹ w(T), T = Q_locᵀ P (corotated.frame_force), into ``out`` (3,)."""
    w0, w1, w2 = T[2, 1] - T[1, 2], T[0, 2] - T[2, 0], T[1, 0] - T[0, 1]
    for i in range(3):
        out[i] = S_inv[i, 0] * w0 + S_inv[i, 1] * w1 + S_inv[i, 2] * w2
    return out


@njit(**JIT)
def corotated_energies(e, rate, z, KP, mass_projected, damping, alpha, beta, kr, symmetric):
    """V = ½ eᵀ Kr e and ėᵀ D₀ ė from :func:`corotated_state`'s e, ė and z: with damping one
    product more, (Πᵀ ⊗ I3) Kr ė into ``kr`` (no other array made)."""
    e1, z1 = e.ravel(), z
    if not damping:
        return 0.5 * (e1 @ z1), 0.0
    r1 = rate.ravel()
    energy, dissipation = 0.0, 0.0
    if beta != 0.0:
        product(KP, r1, kr, symmetric)
        for j in range(e1.shape[0]):
            energy += e1[j] * (z1[j] - beta * kr[j])
            dissipation += r1[j] * kr[j]
        dissipation *= beta
    else:
        energy = e1 @ z1
    if alpha != 0.0:
        dissipation += alpha * (r1 @ gram_product(mass_projected, rate).ravel())
    return 0.5 * energy, dissipation


@njit(**JIT)
def corotated_parts(e, rate, z, KP, mass_projected, damping, alpha, beta):
    """From :func:`_corotated`: (V = ½ eᵀ Kr e, ėᵀ D₀ ė, P = mat((Πᵀ ⊗ I3) Kr e)); with
    damping one product more, (Πᵀ ⊗ I3) Kr ė."""
    nf = e.shape[0]
    if not damping:
        return 0.5 * (e.ravel() @ z), 0.0, z.reshape(nf, 3)
    pd = alpha * gram_product(mass_projected, rate) if alpha != 0.0 else np.zeros((nf, 3))
    p = z
    if beta != 0.0:
        kr = KP @ rate.ravel()
        p = z - beta * kr
        pd += beta * kr.reshape(nf, 3)
    return 0.5 * (e.ravel() @ p), rate.ravel() @ pd.ravel(), p.reshape(nf, 3)


@njit(**JIT)
def elastic_frame(local, P, H, S_inv):
    """(b, P − H [b]×) of the elastic forces P alone (corotated.frame_force)."""
    b = _frame_couple(S_inv, tmul(local, P), np.empty(3))
    return b, P - mul(H, skew(b))


@njit(**JIT)
def rotor_state(p, v, plane_map, p0, K, translation, weights, pairs, damping, D, work,
                symmetric, plane, phase):
    """rotor.rotor_state, with rotor.RotorDamping.local_force: (ok, phase, Tᵀ(∂V/∂p + f_d),
    V, ėᵀ D₀ ė, f, c, s, β, ρ); p_l, e, f, c, s, the force and the damping's ẋ, ė, D₀ ė are
    written into the stretch's ``work`` arrays (n each), the plane's four sums and the phase
    into ``plane`` (4,) and ``phase`` (2,)."""
    N = np.dot(plane_map, p, plane)
    X, Y = N[0] + N[3], N[2] - N[1]
    rho = math.hypot(X, Y)
    n = p.shape[0]
    if not N[0] * N[3] - N[1] * N[2] > COLLAPSED * rho * rho:
        z = np.zeros(n)
        phase[0], phase[1] = 1.0, 0.0
        return False, phase, z, 0.0, 0.0, z, z, z, 0.0, 1.0
    phase[0], phase[1] = X / rho, Y / rho
    local, e, f, c, slope, gradient = work[0], work[1], work[2], work[3], work[4], work[5]
    _turned_into(p, pairs, phase[0], -phase[1], local)
    for j in range(n):
        e[j] = local[j] - p0[j]
        slope[j] = weights[1, j] / rho
    product(K, e, f, symmetric)
    for j in range(n):                   # c = P Ĵ p_l: each pair times i, the rest and t 0
        c[j] = 0.0
    for j in range(pairs):
        c[2 * j], c[2 * j + 1] = -local[2 * j + 1], local[2 * j]
    for t in translation:
        c[t] = 0.0
    beta = f @ c
    for j in range(n):
        gradient[j] = f[j] - beta * slope[j]
    dissipation = 0.0
    if damping:
        x, rate, y = work[6], work[7], work[8]
        _turned_into(v, pairs, phase[0], -phase[1], x)
        sx = slope @ x
        for j in range(n):
            rate[j] = x[j] - c[j] * sx
        np.dot(D, rate, y)
        cy = c @ y
        for j in range(n):
            gradient[j] += y[j] - slope[j] * cy
        dissipation = rate @ y
    return True, phase, gradient, 0.5 * (e @ f), dissipation, f, c, slope, beta, rho


@njit(**JIT)
def _turned_into(y, pairs, c, s, out):
    """``out`` = y with its first ``pairs`` pairs multiplied by c + i s."""
    for j in range(y.shape[0]):
        out[j] = y[j]
    for j in range(pairs):
        x, z = y[2 * j], y[2 * j + 1]
        out[2 * j] = x * c - z * s
        out[2 * j + 1] = x * s + z * c


@njit(**JIT)
def svk_state(q, H, k1, g1m, reference, A, rows, cols, scale, small, symmetric):
    """svk.SVKLaw.state and svk.svk_state: (ok, R, Tᵀ ∂V/∂q, V); A through one triangle if
    ``symmetric``; R a view of ``small`` (``step.SMALL``)."""
    nf = H.shape[0]
    Q = q.reshape(nf, 3)
    Qc = remove(Q, k1, g1m)
    Pm = Qc @ Qc.T - reference
    count = rows.shape[0]
    delta = np.empty(count)
    for k in range(count):
        delta[k] = 0.5 * (Pm[rows[k], cols[k]] + Pm[cols[k], rows[k]]) * scale[k]
    y = product(A, delta, np.empty(count), symmetric)
    S = np.zeros((nf, nf))
    for k in range(count):
        value = y[k] / scale[k]
        S[rows[k], cols[k]] = value
        S[cols[k], rows[k]] = value
    force = remove(2.0 * (S @ Qc), g1m, k1)
    R, _, _, ok = polar(tmul_into(Q, H, small[5]), small[:5])
    return ok, R, mul(force, R).ravel(), 0.5 * (delta @ y)
