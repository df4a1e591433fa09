"""Geometrically exact Saint Venant–Kirchhoff elasticity in GCMS coordinates (docs/design.md §7.2).

With x(X) = Σ_f F_f(X) Q_f the deformation gradient is Qᵀ D(X), D = ∇F (nf × 3), and the
right Cauchy–Green tensor C = Dᵀ P D depends on q only through P = Q Qᵀ. Every component
C_ij = D_iᵀ P D_j is linear in the packed vector p = svec(P) (the nf(nf+1)/2 entries
P_ab, a ≤ b, the off-diagonal ones scaled by √2 so that svec(X)·svec(Y) = X : Y), and the
energy density W = λ/8 (tr C − 3)² + μ/4 |C − I|² is quadratic in C. So the strain energy
of the reduced body is

    V(q) = ½ pᵀ A p + bᵀ p + c,        p = svec(Q Qᵀ),                          (1)

with constant A (s × s), b (s), c, s = nf(nf+1)/2, computed once from the quadrature points
(``fe.svk_coefficients``). V is invariant under Q → Q R for every rotation R (P does not
change): objective without a co-rotated frame. With S = smat(A p + b) (the symmetric
nf × nf matrix with S : dP = (A p + b) · svec(dP)),

    ∂V/∂Q = 2 S Q,                                                               (2)
    ∂²V/∂q² = Lᵀ A L + 2 S ⊗ I3,   L = ∂p/∂q, column (f, l) = svec(e_f Q_lᵀ + Q_l e_fᵀ).  (3)

NumPy only. The integrator steps this law through its ``elastic`` callable with the
rotated Jacobian T S₀ Tᵀ (``integrator``), R = polar(A(q)) being the frame of the body's
affine map; (3) is the exact tangent, checked against finite differences in the tests.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.numerics.rotation import polar
from gcms_fenicsx.files.svk_data import SVKCoefficients, packed_size
from gcms_fenicsx.numerics.packing import Packing, packing

#: The undeformed state is stress-free and has no energy: ‖A p0 + b‖ must be round-off next
#: to ‖A‖_F ‖p0‖ and V(p0) next to its terms (measured 3e-20 and 1e-16 on the test beam).
REFERENCE_TOLERANCE = 1e-10


class CoefficientsError(ValueError):
    """SVK coefficients that do not belong to the body's fields."""


@dataclass(frozen=True)
class SVKLaw:
    """(1) written about the undeformed state, where it is evaluated without cancellation.

    The energy depends on the deformation only, so the mean translation is taken out first:
    Q̃ = Π Q (Π = I − k1 g1ᵀ / m, ``Body.projections``), whose field rows place the body's
    points relative to its centre of mass (F k1 = 1 has no gradient, so V(Q̃) = V(Q)).
    Otherwise a translation would change the entries of P that belong to fields which
    combine the constant one with gradients, by O(‖t‖ ‖Q‖), only for A to cancel them. The
    undeformed body (P0 = Q̃0 Q̃0ᵀ, C = I) is stress-free and has no energy, so A p0 + b = 0 and
    ½ p0ᵀ A p0 + bᵀ p0 + c = 0, and with δ = svec(Q̃ Q̃ᵀ − P0)

        V = ½ δᵀ A δ,    S = smat(A δ),    ∂V/∂Q = Πᵀ (2 S Q̃):                     (4)

    the same energy, computed from the small δ instead of the difference of terms of the size
    of c (10⁷ J for the test beam, where V is 1e-2 J). δ vanishes for every rigid motion to
    the round-off of forming Q̃ Q̃ᵀ, and Πᵀ leaves no net force (linear momentum is conserved
    to round-off). b and c enter only through the check that they agree with A (:meth:`of`;
    that they belong to the model's fields at all is the file's check, ``files.svk_data``)."""

    quadratic: np.ndarray
    reference: np.ndarray      # P0 = Q̃0 Q̃0ᵀ (nf × nf)
    centring: np.ndarray       # Π (nf × nf)

    @classmethod
    def of(cls, coefficients: SVKCoefficients, body: Body) -> SVKLaw:
        """The law of ``coefficients`` for ``body``; :class:`CoefficientsError` if they are of
        another number of fields or A p0 + b is not round-off (``REFERENCE_TOLERANCE``)."""
        A, b = coefficients.quadratic, coefficients.linear
        nf = body.field_count
        if len(b) != packed_size(nf):
            raise CoefficientsError(f"the SVK coefficients have {len(b)} linear terms, the "
                                    f"body's {nf} fields need nf (nf + 1) / 2 = "
                                    f"{packed_size(nf)}")
        Pi = np.asarray(body.projections.deformation)
        Q0 = Pi.dot(body.q0.reshape(-1, 3))
        P0 = Q0.dot(Q0.T)
        p0 = packing(nf).svec(P0)
        with np.errstate(all="ignore"):      # non-finite products fail the checks below
            Ap0 = A.dot(p0)
            force = np.linalg.norm(Ap0 + b) / (np.linalg.norm(A) * np.linalg.norm(p0))
            energy = abs(p0.dot(0.5 * Ap0 + b) + coefficients.constant) / (
                abs(p0.dot(0.5 * Ap0)) + abs(p0.dot(b)) + abs(coefficients.constant))
        for what, value in (("‖A p0 + b‖ / (‖A‖ ‖p0‖)", force),
                            ("|V(p0)| / (|½ p0ᵀ A p0| + |bᵀ p0| + |c|)", energy)):
            if not value <= REFERENCE_TOLERANCE:
                raise CoefficientsError(
                    f"the SVK coefficients do not leave the undeformed body stress-free and "
                    f"without energy: {what} = {value:.2e} (at most "
                    f"{REFERENCE_TOLERANCE:g}); they are not this body's")
        return cls(quadratic=A, reference=P0, centring=Pi)

    @property
    def packing(self) -> Packing:
        return packing(len(self.reference))

    def state(self, q: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """(S, V, ∂V/∂q) of (4) at q."""
        Qc = self.centring.dot(q.reshape(-1, 3))
        delta = self.packing.svec(Qc.dot(Qc.T) - self.reference)
        y = self.quadratic.dot(delta)
        S = self.packing.smat(y)
        return S, 0.5 * float(delta.dot(y)), self.centring.T.dot(2.0 * S.dot(Qc)).ravel()

    def energy(self, q: np.ndarray) -> float:
        """V(q)."""
        return self.state(q)[1]

    def force(self, q: np.ndarray) -> np.ndarray:
        """∂V/∂q."""
        return self.state(q)[2]

    def tangent(self, q: np.ndarray, stress: np.ndarray | None = None) -> np.ndarray:
        """∂²V/∂q² = Lᵀ A L + 2 S ⊗ I3 of (3) at Q̃; dense n × n. (The chain rule's Π₃ᵀ … Π₃,
        Π₃ = Π ⊗ I3, changes nothing: both terms annihilate translations, D k1 = 0 and
        S k1 = 0, measured 3e-17 relative.)

        L = ∂p/∂q is sparse — column (f, l) holds row and column f of dP — so A L and
        Lᵀ (A L) are nf products with the nf columns of A that belong to field f
        (``Packing.index``, ``Packing.jacobian_weights``): 3 s nf² operations instead of the
        3 s² nf of a dense L (25× fewer at nf = 47). ``stress``: S at q when the caller has it
        (``SVKState``), else computed."""
        S = self.state(q)[0] if stress is None else stress
        Qc = self.centring.dot(q.reshape(-1, 3))
        pack = self.packing
        nf, index, W = len(Qc), pack.index, pack.jacobian_weights(Qc)
        LA = np.empty((3 * nf, len(self.quadratic)))          # Lᵀ A, from rows of A (= Aᵀ)
        for f in range(nf):
            LA[3 * f:3 * f + 3] = W[f].T.dot(self.quadratic[index[f]])
        K = np.kron(2.0 * S, np.eye(3))
        for f in range(nf):
            K[:, 3 * f:3 * f + 3] += LA[:, index[f]].dot(W[f])
        return K


class SVKState(NamedTuple):
    """One evaluation of (4), as the integrator and the recorder take it: the force ∂V/∂q
    (n,), the energy V, the frame R = polar(A(q)) the Newton matrix is turned by, and the
    exact tangent on request (``kkt.TangentKKT``)."""

    force: np.ndarray
    energy: float
    rotation: np.ndarray
    law: SVKLaw
    q: np.ndarray
    stress: np.ndarray        # S = smat(A δ)

    def tangent(self) -> np.ndarray:
        """∂²V/∂q² at this state (3), with its S."""
        return self.law.tangent(self.q, self.stress)

    @property
    def local_gradient(self) -> np.ndarray:
        """The force in the body frame, Tᵀ ∂V/∂q (nf × 3)."""
        return self.force.reshape(-1, 3).dot(self.rotation)


def svk_state(body: Body, law: SVKLaw, q: np.ndarray) -> SVKState:
    """V(q) and ∂V/∂q of (4) and (2), with the body's co-rotated frame for the Newton matrix."""
    S, V, force = law.state(q)
    return SVKState(force=force, energy=V,
                    rotation=polar(q.reshape(-1, 3).T.dot(body.affine)).rotation, law=law, q=q,
                    stress=S)
