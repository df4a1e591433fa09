"""The generalized-α method's constants (Chung & Hulbert, J. Appl. Mech. 60, 1993), from the
spectral radius at infinite frequency, and how a Newton correction moves q̈ and q̇
(docs/design.md §6)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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


def step_matrices(p: AlphaParameters, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(P, u): a step as products with the stacked state Z = [q; q̇; q̈; a] (4 × n).

    P (4 × 4) gives the predicted Z_{n+1} from Z_n with q̈_{n+1} = q̈_n: a_{n+1} =
    (α_f q̈_n − α_m a_n + (1 − α_f) q̈_{n+1}) / (1 − α_m), q̇_{n+1} = q̇_n + h((1 − γ) a_n +
    γ a_{n+1}), q_{n+1} = q_n + h q̇_n + h²((½ − β) a_n + β a_{n+1}); a Newton correction Δq
    adds u Δq, u = [1; γ'; β'; β'(1 − α_f)/(1 − α_m)] (``newton_coefficients``), so a_{n+1}
    stays consistent with q̈_{n+1} through the iteration.
    """
    beta_p, gamma_p = newton_coefficients(p, h)
    ca, cb = 1.0 / (1.0 - p.alpha_m), -p.alpha_m / (1.0 - p.alpha_m)   # a_{n+1} from q̈_n, a_n
    predictor = np.array([
        [1.0, h, h * h * p.beta * ca, h * h * ((0.5 - p.beta) + p.beta * cb)],
        [0.0, 1.0, h * p.gamma * ca, h * ((1.0 - p.gamma) + p.gamma * cb)],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, ca, cb]])
    update = np.array([[1.0], [gamma_p], [beta_p], [beta_p * (1.0 - p.alpha_f) * ca]])
    return predictor, update
