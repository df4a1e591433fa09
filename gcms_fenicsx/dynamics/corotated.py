"""Co-rotated linear elasticity in GCMS coordinates: energy, forces and their exact tangent.

DESIGN §5: with the co-rotated frame R = polar(A(q)), A(q) = Qᵀ H, the local coordinates are
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
the exact tangent, is :func:`elastic_tangent`; the iteration matrix of the integrator
keeps only its first part, (I ⊗ R) Kr (I ⊗ Rᵀ) (``integrator``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.rotation import Polar, axial, polar, rotation_rate, skew


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


def elastic_tangent(body: Body, q: np.ndarray, state: ElasticState | None = None) -> np.ndarray:
    """The exact tangent ∂²V/∂q² (n × n, dense), by differentiating ∂V/∂Q along every dQ.

    With dA = dQᵀ H, ω = S⁻¹ w(Rᵀ dA), dR = R [ω]×, dU = Rᵀ dA − [ω]× U,
    dQ_loc = dQ R + Q dR, dP = Πᵀ mat(Kr Π vec(dQ_loc)), dY = dQ_locᵀ P + Q_locᵀ dP and
    db = S⁻¹ (w(dY) − (tr dU · I − dU) b):

        d(∂V/∂Q) = (dP − H [db]×) Rᵀ − (P − H [b]×) [ω]× Rᵀ.

    Symmetric up to round-off (it is a Hessian); checked against finite differences in
    the tests.
    """
    s = elastic_state(body, q) if state is None else state
    n = body.dofs
    nf = n // 3
    Q, H, R, U, S_inv = q.reshape(nf, 3), body.affine, s.rotation, s.frame.stretch, s.rate_inv
    dQ = np.eye(n).reshape(n, nf, 3)                   # one direction per coordinate
    dA = np.einsum("kfi,fj->kij", dQ, H)
    omega = rotation_rate(R, S_inv, dA)                # (n, 3)
    W = skew(omega)
    dR = R @ W
    dU = R.T @ dA - W @ U
    dlocal = dQ @ R + np.einsum("fi,kij->kfj", Q, dR)
    de = without_translation(body, dlocal).reshape(n, n)
    dP = translation_free_force(body, np.asarray(body.stiffness @ de.T).T.reshape(n, nf, 3))
    dY = np.swapaxes(dlocal, 1, 2) @ s.local_force + s.local.T @ dP
    trace = np.trace(dU, axis1=1, axis2=2)
    dS_b = trace[:, None] * s.frame_term - dU @ s.frame_term
    db = (axial(dY) - dS_b) @ S_inv.T
    frame = s.local_force - H @ skew(s.frame_term)
    df = (dP - H @ skew(db)) @ R.T - frame @ W @ R.T
    return df.reshape(n, n).T
