"""Reference frequencies of free-free prismatic beams from classical beam theories.

Used by the tests and the stability workflow as references nobody here tuned:
- Euler–Bernoulli bending: ω_n = (β_n L)² √(EI / ρA L⁴), cos βL cosh βL = 1
  (Blevins, *Formulas for Natural Frequency and Mode Shape*, 1979, Table 8-1).
- Timoshenko bending (shear deformation and rotary inertia, Timoshenko 1921): the
  free-free equations ρA ẅ = κGA (w'' − θ'), ρI θ̈ = EI θ'' + κGA (w' − θ), solved here
  to ~1e-7 relative by a fine 1D finite-element discretisation (linear w and θ, one-point
  shear integration) with Richardson extrapolation in the element size.
- Shear coefficients κ of Cowper (J. Appl. Mech. 33, 1966): rectangle 10(1+ν)/(12+11ν),
  circle 6(1+ν)/(7+6ν).
- Axial (bar) modes ω_n = nπ/L √(E/ρ); St-Venant torsion ω_n = nπ/L √(GJ/(ρ I_p))
  with the torsion constant J of a rectangle from the series of Timoshenko & Goodier,
  *Theory of Elasticity*, 3rd ed., §109, and J = I_p = πr⁴/2 for a circle.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

EB_ROOTS = np.array([4.730040744862704, 7.853204624095838, 10.995607838001671,
                     14.137165491257464])


def euler_bernoulli_hz(n: int, E: float, I: float, rho: float, A: float, L: float) -> float:
    """n-th (1-based) free-free Euler–Bernoulli bending frequency in Hz."""
    return EB_ROOTS[n - 1] ** 2 * np.sqrt(E * I / (rho * A * L ** 4)) / (2 * np.pi)


def cowper_kappa(section: str, nu: float) -> float:
    return {"rectangle": 10 * (1 + nu) / (12 + 11 * nu),
            "circle": 6 * (1 + nu) / (7 + 6 * nu)}[section]


def _timoshenko_fe(n_el: int, E, G, kappa, rho, A, I, L, modes: int) -> np.ndarray:
    h = L / n_el
    nd = 2 * (n_el + 1)
    # dofs per node: (w, θ); shear strain γ = w' − θ at the midpoint (one-point rule)
    B_s = np.array([-1 / h, -0.5, 1 / h, -0.5])
    B_b = np.array([0.0, -1 / h, 0.0, 1 / h])
    ke = kappa * G * A * h * np.outer(B_s, B_s) + E * I * h * np.outer(B_b, B_b)
    lin = h / 6 * np.array([[2.0, 1.0], [1.0, 2.0]])
    me = np.zeros((4, 4))
    me[np.ix_([0, 2], [0, 2])] = rho * A * lin
    me[np.ix_([1, 3], [1, 3])] = rho * I * lin
    idx = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]
    rows = np.repeat(idx, 4, axis=1).ravel()
    cols = np.tile(idx, (1, 4)).ravel()
    K = scipy.sparse.coo_matrix((np.tile(ke.ravel(), n_el), (rows, cols)), shape=(nd, nd))
    M = scipy.sparse.coo_matrix((np.tile(me.ravel(), n_el), (rows, cols)), shape=(nd, nd))
    sigma = -1e-3 * E * I / (rho * A * L ** 4)
    vals = scipy.sparse.linalg.eigsh(K.tocsc(), k=modes + 2, M=M.tocsc(), sigma=sigma,
                                     which="LM", return_eigenvectors=False)
    return np.sort(vals)[2:2 + modes]  # drop the two rigid modes of planar bending


def timoshenko_hz(n: int, E: float, nu: float, kappa: float, rho: float, A: float, I: float,
                  L: float) -> float:
    """n-th free-free Timoshenko bending frequency in Hz (Richardson-extrapolated FE, O(h²))."""
    G = E / (2 * (1 + nu))
    coarse = _timoshenko_fe(2000, E, G, kappa, rho, A, I, L, n)[n - 1]
    fine = _timoshenko_fe(4000, E, G, kappa, rho, A, I, L, n)[n - 1]
    lam = (4 * fine - coarse) / 3
    return np.sqrt(lam) / (2 * np.pi)


def bar_hz(n: int, E: float, rho: float, L: float) -> float:
    return n / (2 * L) * np.sqrt(E / rho)


def torsion_hz(n: int, G: float, J: float, rho: float, Ip: float, L: float) -> float:
    return n / (2 * L) * np.sqrt(G * J / (rho * Ip))


def rectangle_torsion_constant(b: float, h: float, terms: int = 50) -> float:
    """J = (b h³/3)[1 − (192/π⁵)(h/b) Σ_{n odd} tanh(nπb/2h)/n⁵], b ≥ h."""
    b, h = max(b, h), min(b, h)
    n = np.arange(1, 2 * terms, 2)
    return b * h ** 3 / 3 * (1 - 192 / np.pi ** 5 * h / b * np.sum(np.tanh(n * np.pi * b / (2 * h)) / n ** 5))
