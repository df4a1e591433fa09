"""The generalized-α method's constants (Chung & Hulbert, J. Appl. Mech. 60, 1993), from the
spectral radius at infinite frequency, and how a Newton correction moves q̈ and q̇
(docs/design.md §6). NumPy free."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class AlphaParameters:
    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @classmethod
    def from_rho_inf(cls, rho_inf: float) -> "AlphaParameters":
        """Chung & Hulbert's optimal parameters for spectral radius ρ∞ ∈ [0, 1]."""
        am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        af = rho_inf / (rho_inf + 1.0)
        gamma = 0.5 + af - am
        return cls(alpha_m=am, alpha_f=af, gamma=gamma, beta=0.25 * (gamma + 0.5) ** 2)


def newton_coefficients(p: AlphaParameters, h: float) -> tuple[float, float]:
    """(β', γ') = ((1 − α_m)/(β h² (1 − α_f)), γ/(β h)): how a Newton correction Δq changes q̈
    and q̇ (module docstring)."""
    return (1.0 - p.alpha_m) / (p.beta * h * h * (1.0 - p.alpha_f)), p.gamma / (p.beta * h)
