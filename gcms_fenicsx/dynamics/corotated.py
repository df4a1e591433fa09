"""Co-rotated linear elasticity in GCMS coordinates: energy, forces and their exact tangent.

docs/design.md §6: with the co-rotated frame R = polar(A(q)), A(q) = Qᵀ H, the local coordinates are
Q_loc = Q R (each field's 3-vector rotated back) and the elastic energy is

    V(q) = ½ eᵀ Kr e,    e = Π (vec(Q R) − q0),

where Π removes the mean translation (e − k1 ⊗ ē, ē = (Q R − Q0)ᵀ g1 / m): Kr annihilates
translations only to its round-off, so Π makes V exactly blind to them, and the local
forces Πᵀ Kr e have exactly no net translational part (linear momentum is conserved to
round-off, whatever the round-off in Kr). V vanishes for
every rigid motion (a rigid rotation is undone by R). With P = mat(Kr e) and the rotation rate of the polar decomposition
(``rotation.rotation_rate``: dR = R [ω]×, ω = S⁻¹ w(Rᵀ dA), S = tr U · I − U),

    ∂V/∂Q = (P − H [b]×) Rᵀ,    b = S⁻¹ w(Q_locᵀ P),

where the H-term is the work of the local forces on the change of frame. Its derivative,
the exact tangent, is (I ⊗ R) Kr (I ⊗ Rᵀ) plus a rank-9 term from the change of frame
(:func:`frame_update`, :func:`elastic_tangent`); the integrator factorises only the first
part and adds the second by the Woodbury identity (``integrator``).
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.rotation import Polar, axial, polar, skew

E_CROSS = skew(np.eye(3))  # [e_k]× for k = x, y, z, stacked (3, 3, 3)


class ElasticState(NamedTuple):
    """Everything one evaluation of the co-rotated energy computed at q."""

    frame: Polar              # A = R U
    rate_inv: np.ndarray      # S⁻¹ of the rotation rate
    local: np.ndarray         # Q_loc = Q R (nf, 3)
    local_force: np.ndarray   # P = Πᵀ mat(Kr e) (nf, 3)
    frame_term: np.ndarray    # b
    force: np.ndarray         # ∂V/∂q (n,)
    energy: float

    @property
    def rotation(self) -> np.ndarray:
        return self.frame.rotation


def elastic_state(body: Body, q: np.ndarray) -> ElasticState:
    """V(q) and ∂V/∂q (module docstring)."""
    Q = q.reshape(-1, 3)
    frame = polar(Q.T @ body.affine)
    R = frame.rotation
    S_inv = frame.rate_operator_inverse
    local = Q @ R
    e = without_translation(body, local - body.q0.reshape(-1, 3)).ravel()
    p = body.stiffness @ e
    P = translation_free_force(body, p.reshape(-1, 3))
    b, force = frame_force(body, R, S_inv, local, P)
    return ElasticState(frame, S_inv, local, P, b, force, 0.5 * float(e @ p))


def frame_force(body: Body, R: np.ndarray, S_inv: np.ndarray, local: np.ndarray,
                P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(b, f): the global generalized force f = vec((P − H [b]×) Rᵀ), b = S⁻¹ w(Q_locᵀ P), of
    local forces P (nf × 3, already Πᵀ-projected) conjugate to e: f = (∂e/∂q)ᵀ vec(P)."""
    b = S_inv @ axial(local.T @ P)
    return b, ((P - body.affine @ skew(b)) @ R.T).ravel()


def without_translation(body: Body, D: np.ndarray) -> np.ndarray:
    """Π: D − k1 ⊗ (g1ᵀ D / m) for displacements D of shape (..., nf, 3); Π is linear."""
    return D - body.unit[:, None] * (body.field_mass @ D / body.total_mass_kg)[..., None, :]


def translation_free_force(body: Body, P: np.ndarray) -> np.ndarray:
    """Πᵀ: P − g1 ⊗ (k1ᵀ P / m) for local forces P of shape (..., nf, 3)."""
    return P - body.field_mass[:, None] * (body.unit @ P / body.total_mass_kg)[..., None, :]


def frame_update(body: Body, s: ElasticState,
                 apply_A: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(X, Y) with J_eᵀ A J_e + G = T A Tᵀ + X Y, rank 9, for a symmetric operator A that
    annihilates translations (A = Kr gives the exact tangent ∂²V/∂q²).

    J_e = ∂e/∂q = Π Tᵀ + Ĉ W_ω (T = I ⊗ R): a coordinate change dq turns the frame by
    ω = W_ω dq = S⁻¹ w(Rᵀ dQᵀ H), which moves e by Ĉ ω, Ĉ = Π [vec(Q_loc [e_k]×)]_k. With
    B = Πᵀ A Ĉ:  J_eᵀ A J_e = T A Tᵀ + T B W_ω + W_ωᵀ Bᵀ Tᵀ + W_ωᵀ (Ĉᵀ A Ĉ) W_ω.
    G dq = d(J_eᵀ) p at fixed p (the geometric stiffness of the local forces P):
    −(P − H [b]×) [ω]× Rᵀ − H [db]× Rᵀ with db = W_b dq,

        db = S⁻¹ (P_f × r_l − w([ω]× Y) − (r_l · h_f) b + r_l (h_f · b) − ω × (U b))

    for dq = e_(f,l) (Y = Q_locᵀ P, r_l row l of R, h_f row f of H). So
    X = [T B + U₃ | W_ωᵀ | U₂], Y = [W_ω ; (T B)ᵀ + (Ĉᵀ A Ĉ) W_ω ; W_b] with the columns
    U₂[:, k] = −vec(H [e_k]× Rᵀ), U₃[:, k] = −vec((P − H [b]×) [e_k]× Rᵀ).
    """
    nf = body.field_count
    H, R, S_inv, local, P, b = (body.affine, s.rotation, s.rate_inv, s.local, s.local_force,
                                s.frame_term)
    U = s.frame.stretch
    h_x_r = np.cross(H[:, None, :], R[None, :, :])                  # h_f × r_l  (nf, 3, 3)
    W_omega = (h_x_r.reshape(-1, 3) @ S_inv.T).T                   # (3, n)
    omega = W_omega.T.reshape(nf, 3, 3)
    rot_local = local @ E_CROSS                                    # Q_loc [e_k]×  (3, nf, 3)
    C_hat = without_translation(body, rot_local).reshape(3, -1).T  # (n, 3)
    AC = np.asarray(apply_A(C_hat))
    B = translation_free_force(body, AC.T.reshape(3, nf, 3))       # Πᵀ A Ĉ  (3, nf, 3)
    TB = (B @ R.T).reshape(3, -1).T                                 # (n, 3)
    CAC = C_hat.T @ AC
    Y_lp = local.T @ P
    M_Y = axial(E_CROSS @ Y_lp).T                                  # w([ω]× Y) = M_Y ω
    hr = H @ R.T                                                    # h_f · r_l  (nf, 3)
    db = (np.cross(P[:, None, :], R[None, :, :]) - omega @ M_Y.T
          - hr[:, :, None] * b + R[None, :, :] * (H @ b)[:, None, None]
          - np.cross(omega, U @ b))
    W_b = (db.reshape(-1, 3) @ S_inv.T).T                           # (3, n)
    frame = P - H @ skew(b)
    U2 = -(H @ E_CROSS @ R.T).reshape(3, -1).T
    U3 = -(frame @ E_CROSS @ R.T).reshape(3, -1).T
    X = np.hstack([TB + U3, W_omega.T, U2])
    Y = np.vstack([W_omega, TB.T + CAC @ W_omega, W_b])
    return X, Y


def elastic_tangent(body: Body, q: np.ndarray, state: ElasticState | None = None) -> np.ndarray:
    """The exact tangent ∂²V/∂q² (n × n, dense): T Kr Tᵀ + X Y (:func:`frame_update`).

    Symmetric up to round-off (it is a Hessian); checked against finite differences in
    the tests.
    """
    s = elastic_state(body, q) if state is None else state
    T = np.kron(np.eye(body.field_count), s.rotation)
    X, Y = frame_update(body, s, lambda V: body.stiffness @ V)
    return T @ np.asarray(body.stiffness @ T.T) + X @ Y
