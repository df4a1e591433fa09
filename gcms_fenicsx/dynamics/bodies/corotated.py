"""Co-rotated linear elasticity in GCMS coordinates: energy, forces and their exact tangent.

docs/design.md §6: with the co-rotated frame R = polar(A(q)), A(q) = Qᵀ H, the local coordinates are
Q_loc = Q R (each field's 3-vector rotated back) and the elastic energy is

    V(q) = ½ eᵀ Kr e,    e = Π (vec(Q R) − q0),

where Π removes the mean translation (e − k1 ⊗ ē, ē = (Q R − Q0)ᵀ g1 / m): Kr annihilates
translations only to its round-off, so Π makes V blind to them, and the local forces
P = mat(Πᵀ Kr e) have no net translational part (k1ᵀ Πᵀ = 0), to the round-off of forming
(Πᵀ ⊗ I3) Kr once (``Body.projections``) times the deformation, not the translation: linear
momentum is conserved to round-off, whatever the round-off in Kr. V vanishes for every
rigid motion (a rigid rotation is undone by R). With the rotation rate of the polar
decomposition (``rotation.rotation_rate``: dR = R [ω]×, ω = S⁻¹ w(Rᵀ dA), S = tr U · I − U),

    ∂V/∂Q = (P − H [b]×) Rᵀ,    b = S⁻¹ w(Q_locᵀ P),

where the H-term is the work of the local forces on the change of frame. Its derivative,
the exact tangent, is (I ⊗ R) Kr (I ⊗ Rᵀ) plus a rank-9 term from the change of frame
(:func:`local_frame_update`, :func:`elastic_tangent`); the integrator factorises only the first
part and adds the second by the Woodbury identity (``integrator``).
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.numerics.lapack import determinant, svd
from gcms_fenicsx.numerics.rotation import (AXIAL_ROWS, SKEW_ROWS, InvertedBodyError, Polar,
                                            axial, polar, skew)

E_CROSS = skew(np.eye(3))  # [e_k]× for k = x, y, z, stacked (3, 3, 3)
#: A (nf, 3) times this is [A [e_k]×]_k laid out (nf, 3, 3) with k last (columns of Ĉ).
CROSS_COLUMNS = E_CROSS.transpose(1, 2, 0).reshape(3, 9)
#: A (nf, 3) times this is [a_f × e_l]_{f, l} laid out (nf, 3, 3): the row aᵀ [e_l]×.
CROSS_ROWS = E_CROSS.transpose(1, 0, 2).reshape(3, 9)
#: vec(Y) times this is vec(M_Yᵀ), M_Y ω = w([ω]× Y) (``local_frame_update``): column k of M_Y
#: is w([e_k]× Y), linear in Y, so row (i, j) holds it for Y = e_i e_jᵀ.
FRAME_RATE_ROWS = np.array([axial(E_CROSS @ Y.reshape(3, 3)).ravel() for Y in np.eye(9)])
EYE3 = np.eye(3)


class ElasticState(NamedTuple):
    """Everything one evaluation of the co-rotated energy computed at q; S⁻¹, the energy and
    the gradient in global coordinates are formed only when asked for (the integrator works
    with the gradient in the body frame)."""

    frame: Polar              # A = R U
    local: np.ndarray         # Q_loc = Q R (nf, 3)
    local_force: np.ndarray   # P = Πᵀ mat(Kr e) (nf, 3)
    frame_term: np.ndarray    # b
    local_gradient: np.ndarray  # Tᵀ ∂V/∂q = P − H [b]× (nf, 3)
    deformation: np.ndarray   # e (n,)
    stiffness_force: np.ndarray  # Πᵀ Kr e (n,), so eᵀ of it is eᵀ Kr e (Π e = e)

    @property
    def rotation(self) -> np.ndarray:
        return self.frame.rotation

    @property
    def force(self) -> np.ndarray:
        """∂V/∂q = vec((P − H [b]×) Rᵀ) (n,)."""
        return self.local_gradient.dot(self.frame.rotation.T).ravel()

    @property
    def rate_inv(self) -> np.ndarray:
        """S⁻¹ of the rotation rate (``rotation.rotation_rate``)."""
        return self.frame.rate_operator_inverse

    @property
    def energy(self) -> float:
        """V = ½ eᵀ Kr e."""
        return 0.5 * float(self.deformation.dot(self.stiffness_force))


def elastic_state(body: Body, q: np.ndarray) -> ElasticState:
    """V(q) and ∂V/∂q (module docstring): Π and Πᵀ Kr as products with matrices formed once
    (``Body.projections``), and the frame term by :func:`frame_force`. This is the
    integrator's hot path: every residual of every Newton iteration calls it, so it makes as
    few NumPy calls as the formulas allow (docs/integrator_profile.md)."""
    pr = body.projections
    Q = q.reshape(-1, 3)
    frame = polar(Q.T.dot(body.affine))
    local = Q.dot(frame.rotation)
    e = (pr.deformation.dot(local) - pr.q0).ravel()                  # Π (Q R − Q0)
    p = pr.stiffness.dot(e)                                          # Πᵀ Kr e
    P = p.reshape(-1, 3)
    b, gradient = frame_force(body, frame, local, P)
    return ElasticState(frame, local, P, b, gradient, e, p)


class ElasticStates(NamedTuple):
    """The co-rotated energy of k configurations of one body (:func:`elastic_states`): the
    forces ∂V/∂q of all of them (k n,), their energies summed, and their frames (k, 3, 3)."""

    force: np.ndarray
    energy: float
    rotation: np.ndarray


def elastic_states(body: Body, Q: np.ndarray) -> ElasticStates:
    """:func:`elastic_state`'s V and ∂V/∂q for k configurations Q (k, nf, 3) of one dense
    reduced body at once — the members of an assembly that share a model: the same formulas
    (module docstring) with every product over the fields taken for the k of them together
    (k columns, or a stack of k frames), so k configurations make one configuration's NumPy
    calls. InvertedBodyError for the worst of them when an affine map has no rotation."""
    pr = body.projections
    k, nf = Q.shape[:2]
    W, s, Vt = svd(np.matmul(Q.transpose(0, 2, 1), body.affine))     # Qᵀ H = W Σ Vᵀ
    R = np.matmul(W, Vt)
    # det R = ±1: a reflected or degenerate map makes this ≤ 1e-12 (``polar``'s test)
    if not (determinant(R) * s[:, 2] / s[:, 0]).min() > 1e-12:
        bad = int(np.argmin(determinant(R) * s[:, 2] / s[:, 0]))
        raise InvertedBodyError(np.linalg.det(Q[bad].T @ body.affine), s[bad])
    local = np.matmul(Q, R)                                            # Q_loc = Q R
    e = (np.matmul(pr.deformation, local) - pr.q0).reshape(k, 3 * nf)  # Π (Q R − Q0)
    p = e.dot(pr.stiffness.T)                                          # Πᵀ Kr e
    P = p.reshape(k, nf, 3)
    w = np.matmul(local.transpose(0, 2, 1), P).reshape(k, 9).dot(AXIAL_ROWS)
    # b = S⁻¹ w(Q_locᵀ P) = V (Vᵀ w / (tr Σ − Σ))  (``Polar.rate_solve``)
    b = np.einsum("kji,kj->ki", Vt, np.einsum("kij,kj->ki", Vt, w)
                  / (s.sum(axis=1, keepdims=True) - s))
    gradient = P - b.dot(pr.affine_cross).reshape(k, nf, 3)            # P − H [b]×
    force = np.matmul(gradient, R.transpose(0, 2, 1)).reshape(-1)
    return ElasticStates(force, 0.5 * float(np.vdot(e, p)), R)


def frame_force(body: Body, frame: Polar, local: np.ndarray, P: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """(b, P − H [b]×), b = S⁻¹ w(Q_locᵀ P): for local forces P (nf × 3, already
    Πᵀ-projected) conjugate to e, the generalized force (∂e/∂q)ᵀ vec(P) in the body frame,
    T (P − H [b]×) being the global one (module docstring); w(Y) and H [b]× are products with
    constant matrices (``rotation.AXIAL_ROWS``, ``Projections.affine_cross``)."""
    b = frame.rate_solve(local.T.dot(P).ravel().dot(AXIAL_ROWS))
    return b, P - b.dot(body.projections.affine_cross).reshape(-1, 3)


def local_frame_update(body: Body, s: ElasticState, apply_A: Callable[[np.ndarray], np.ndarray]
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(X_loc, Y_loc) with J_eᵀ A J_e + G = T (A + X_loc Y_loc) Tᵀ (T = I ⊗ R): the rank-9
    change-of-frame term in the body frame, where it depends only on the local state
    (Q_loc, P, b, U, S⁻¹).

    J_e = ∂e/∂q = Π Tᵀ + Ĉ W_ω: a coordinate change dq = T dq_l turns the frame by
    ω = W_ω dq = S⁻¹ w(dQ_lᵀ H), which moves e by Ĉ ω, Ĉ = Π [vec(Q_loc [e_k]×)]_k. With
    B = Πᵀ A Ĉ:  Tᵀ J_eᵀ A J_e T = A + B W + Wᵀ Bᵀ + Wᵀ (Ĉᵀ A Ĉ) W (W = W_ω T, rows
    W[:, (f, a)] = S⁻¹ (h_f × e_a)). The geometric stiffness of the local forces P,
    G dq = d(J_eᵀ) p at fixed p, is in the body frame −(P − H [b]×) [ω]× − H [db]× with
    db = W_b dq_l,

        db = S⁻¹ (P_f × e_a − w([ω]× Y) − h_fa b + e_a (h_f · b) − ω × (U b))

    for dq_l = e_(f,a) (Y = Q_locᵀ P, h_f row f of H). So X_loc = [B + U₃ | Wᵀ | U₂],
    Y_loc = [W ; Bᵀ + (Ĉᵀ A Ĉ) W ; W_b] with the columns U₂[:, k] = −vec(H [e_k]×),
    U₃[:, k] = −vec((P − H [b]×) [e_k]×).

    Every cross product over the fields is a product with a constant-size matrix: the row
    aᵀ [c]× is a × c, so [a_f × e_l]_{f,l} = A · [[e_l]×]_l (nf × 9), and ω × c = ωᵀ [c]×.
    """
    nf = body.field_count
    H, S_inv, local, P, b = body.affine, s.rate_inv, s.local, s.local_force, s.frame_term
    R, values, Vt, _ = s.frame
    pr = body.projections
    omega = H.dot(E_CROSS.dot(S_inv.T).transpose(1, 0, 2).reshape(3, 9)).reshape(nf, 3, 3)
    W_T = omega.reshape(-1, 3)                                      # Wᵀ (n, 3)
    C_hat = pr.deformation.dot(local).dot(CROSS_COLUMNS).reshape(-1, 3)  # Π Q_loc [e_k]×
    AC = np.asarray(apply_A(C_hat))
    B = pr.force.dot(AC.reshape(nf, 9)).reshape(-1, 3)              # Πᵀ A Ĉ (n, 3)
    M_Y_T = local.T.dot(P).ravel().dot(FRAME_RATE_ROWS).reshape(3, 3)   # w([ω]× Y) = M_Y ω
    Ub = Vt.T.dot(values * Vt.dot(b))                               # U b, U = V Σ Vᵀ
    db = (P.dot(CROSS_ROWS).reshape(nf, 3, 3) - omega.dot(M_Y_T + Ub.dot(SKEW_ROWS).reshape(3, 3))
          - H[:, :, None] * b + EYE3 * H.dot(b)[:, None, None])
    U3 = -s.local_gradient.dot(CROSS_COLUMNS).reshape(-1, 3)      # −(P − H [b]×) [e_k]×
    X = np.concatenate((B + U3, W_T, -pr.affine_cross.T), axis=1)   # U₂ = −[vec(H [e_k]×)]_k
    Y = np.concatenate((W_T.T, B.T + C_hat.T.dot(AC).dot(W_T.T), S_inv.dot(db.reshape(-1, 3).T)))
    return X, Y


def elastic_tangent(body: Body, q: np.ndarray, state: ElasticState | None = None) -> np.ndarray:
    """The exact tangent ∂²V/∂q² (n × n, dense): T (Kr + X_loc Y_loc) Tᵀ
    (:func:`local_frame_update`).

    Symmetric up to round-off (it is a Hessian); checked against finite differences in
    the tests.
    """
    s = elastic_state(body, q) if state is None else state
    T = body.frame.matrix(s.rotation, body.dofs)
    X, Y = local_frame_update(body, s, lambda V: body.stiffness @ V)
    return T @ (np.asarray(body.stiffness) + X @ Y) @ T.T
