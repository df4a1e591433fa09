"""Rayleigh damping in the co-rotated frame, and the constant matrices it enters
(docs/design.md §6).

The dissipation function is ½ ėᵀ D₀ ė with D₀ = α Mr + β Kr and ė = Π d/dt vec(Q R) the
deformation rate seen in the body frame, so rigid motion is not damped; the force is
f_d = (∂e/∂q)ᵀ D₀ ė (``corotated.frame_force``) and its power ėᵀ D₀ ė. A Newton correction
Δq changes q̇ by γ'Δq, so the damping adds γ' D₀ to the iteration matrix:
S₀ = β' Mr + γ' D₀ + Kr, and the change-of-frame term applies A = γ' D₀ + Kr.
NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.corotated import (ElasticState, frame_force,
                                             translation_free_force, without_translation)
from gcms_fenicsx.dynamics.rotation import rotation_rate, skew


@dataclass(frozen=True)
class RayleighDamping:
    """D₀ = α Mr + β Kr on the co-rotated deformation rates (α in 1/s, β in s)."""

    alpha: float = 0.0
    beta: float = 0.0

    @property
    def active(self) -> bool:
        return (self.alpha, self.beta) != (0.0, 0.0)

    def force(self, body: Body, v: np.ndarray, es: ElasticState) -> tuple[np.ndarray, float]:
        """(f_d, ėᵀ D₀ ė) at the velocity v and the elastic state ``es`` (module docstring)."""
        Vd = v.reshape(-1, 3)
        omega = rotation_rate(es.rotation, es.rate_inv, Vd.T @ body.affine)
        rate = without_translation(body, Vd @ es.rotation + es.local @ skew(omega)).ravel()
        p = self.alpha * (body.mass @ rate) + self.beta * (body.stiffness @ rate)
        P = translation_free_force(body, p.reshape(-1, 3))
        _, force = frame_force(body, es.rotation, es.rate_inv, es.local, P)
        return force, float(rate @ p)

    def iteration_matrix(self, body: Body, beta_p: float, gamma_p: float) -> Any:
        """S₀ = β' Mr + γ' D₀ + Kr = (β' + γ'α) Mr + (1 + γ'β) Kr."""
        return ((beta_p + gamma_p * self.alpha) * body.mass
                + (1.0 + gamma_p * self.beta) * body.stiffness)

    def frame_operator(self, body: Body, gamma_p: float) -> Callable[[np.ndarray], np.ndarray]:
        """X ↦ A X with A = γ' D₀ + Kr = γ'α Mr + (1 + γ'β) Kr, the operator the rank-9
        change-of-frame term applies J_e to (``corotated.frame_update``)."""
        stiffness, mass = 1.0 + gamma_p * self.beta, gamma_p * self.alpha

        def apply(X: np.ndarray) -> np.ndarray:
            out = stiffness * (body.stiffness @ X)
            return out + mass * (body.mass @ X) if self.alpha else out

        return apply
