"""Rayleigh damping in the co-rotated frame, and the constant matrices it enters
(docs/design.md §6).

The dissipation function is ½ ėᵀ D₀ ė with D₀ = α Mr + β Kr and ė = Π d/dt vec(Q R) the
deformation rate seen in the body frame, so rigid motion is not damped; the force is
f_d = (∂e/∂q)ᵀ D₀ ė (``corotated.frame_force``) and its power ėᵀ D₀ ė (:class:`DampingForce`,
with (Πᵀ ⊗ I3) D₀ formed once per run). A Newton correction
Δq changes q̇ by γ'Δq, so the damping adds γ' D₀ to the iteration matrix:
S₀ = β' Mr + γ' D₀ + Kr, and the change-of-frame term applies A = γ' D₀ + Kr.
NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body, Coordinates, projected
from gcms_fenicsx.dynamics.bodies.corotated import ElasticState, frame_force
from gcms_fenicsx.numerics.rotation import AXIAL_ROWS, SKEW_ROWS


@dataclass(frozen=True)
class RayleighDamping:
    """D₀ = α Mr + β Kr on the co-rotated deformation rates (α in 1/s, β in s)."""

    alpha: float = 0.0
    beta: float = 0.0

    @property
    def active(self) -> bool:
        return (self.alpha, self.beta) != (0.0, 0.0)

    def on(self, body: Coordinates) -> Any:
        """The damping force on ``body`` (a rotor body makes its own, ``rotor.RotorDamping``)."""
        D0 = self.alpha * body.mass + self.beta * body.stiffness
        if not isinstance(body, Body):
            return body.damping_force(D0)
        return DampingForce(body, projected(body.projections.force, D0))

    def iteration_matrix(self, body: Body, beta_p: float, gamma_p: float) -> Any:
        """S₀ = β' Mr + γ' D₀ + Kr = (β' + γ'α) Mr + (1 + γ'β) Kr."""
        return ((beta_p + gamma_p * self.alpha) * body.mass
                + (1.0 + gamma_p * self.beta) * body.stiffness)

    def frame_operator(self, body: Body, gamma_p: float) -> Callable[[np.ndarray], np.ndarray]:
        """X ↦ A X with A = γ' D₀ + Kr = γ'α Mr + (1 + γ'β) Kr, the operator the rank-9
        change-of-frame term applies J_e to (``corotated.local_frame_update``)."""
        stiffness, mass = 1.0 + gamma_p * self.beta, gamma_p * self.alpha

        def apply(X: np.ndarray) -> np.ndarray:
            out = stiffness * (body.stiffness @ X)
            return out + mass * (body.mass @ X) if self.alpha else out

        return apply


@dataclass(frozen=True)
class DampingForce:
    """f_d on one body (module docstring), with (Πᵀ ⊗ I3) D₀ formed once (``body.projected``)."""

    body: Body
    operator: Any   # (Πᵀ ⊗ I3)(α Mr + β Kr), for ``dot`` with vectors

    def local_force(self, v: np.ndarray, es: ElasticState) -> tuple[np.ndarray, float]:
        """(Tᵀ f_d as (nf, 3), ėᵀ D₀ ė) at the velocity v and the elastic state ``es``.

        ė = Π vec(Q̇ R + Q_loc [ω]×) with ω = S⁻¹ w(Rᵀ Q̇ᵀ H) (``rotation.rotation_rate``);
        P = mat((Πᵀ ⊗ I3) D₀ ė) and f_d follows from P as the elastic force does from
        Πᵀ Kr e (``corotated.frame_force``); ėᵀ D₀ ė = ėᵀ P since Π ė = ė.
        """
        body, frame, local = self.body, es.frame, es.local
        Vd = v.reshape(-1, 3)
        R = frame.rotation
        omega = frame.rate_solve(R.T.dot(Vd.T.dot(body.affine)).ravel().dot(AXIAL_ROWS))
        rate = body.projections.deformation.dot(
            Vd.dot(R) + local.dot(omega.dot(SKEW_ROWS).reshape(3, 3))).ravel()
        p = self.operator.dot(rate)
        _, force = frame_force(body, frame, local, p.reshape(-1, 3))
        return force, float(rate.dot(p))
