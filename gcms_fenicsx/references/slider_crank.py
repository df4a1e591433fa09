"""The flexible slider crank of the Test Set for IVP Solvers, as a NumPy/SciPy reference.

Problem "Slider crank" of the IVP Test Set (B. Simeon, 1998; problem file ``crank.f``,
subroutine RESMBS with ITYP = 3, linear stiffness, no damping), after B. Simeon, "Modelling a
flexible slider crank mechanism by a mixed system of DAEs and PDEs", Math. Modelling of
Systems 2 (1996) 1–18, and Jahnke, Popp & Dirr (1993).

Model. A rigid crank (angle φ1 = Ω t, prescribed by the constraint φ1 − Ω t = 0) drives an
elastic conrod whose end slides with a point mass M3 on the x axis (coordinate x3). The conrod
lives in a floating frame at the crank pin whose x axis passes through the slider pin, turned
by φ2; in it a point at ξ = x/L2 is displaced by

    v(ξ) = q1 sin(πξ) + q2 sin(2πξ)                (lateral, two pinned–pinned modes),
    u(ξ) = q3 4ξ(1 − ξ) + q4 ξ(2ξ − 1)             (axial, one quadratic element:
                                                    q3 midside, q4 the slider-pin end),

so q1 is the midpoint deflection, positive towards the frame's +y: to the left of the chord
from the crank pin to the slider pin. With p = (φ1, φ2, x3, q1..q4) the equations are

    M(p) p̈ = f(p, ṗ) − G(p)ᵀ λ,     g(p, t) = 0,                                   (1)
    g1 = L1 sin φ1 + (L2 + q4) sin φ2,
    g2 = x3 − L1 cos φ1 − (L2 + q4) cos φ2,
    g3 = φ1 − Ω t,                                                                   (2)

with the full floating-frame coupling of the test set in M (its AM) and f (its F: centrifugal,
Coriolis and coupling terms, − K q); gravity and damping are zero. Equation (1) differentiated
twice, G p̈ = γ (the test set's index-1 system), gives p̈ and λ from one linear solve.

Integration. φ1 is prescribed and (2) is solved in closed form for φ2, x3 (and, by its time
derivative, for φ̇2, ẋ3), so the state is (q, q̇) only: an ODE in 8 unknowns with no drift,
integrated by scipy's DOP853 (its step is bounded by the 3.6 kHz axial mode: ~3e3 steps,
5-10 s for 0.1 s); λ at the output times from the same linear solve.

Data taken as published, so as to reproduce the reference digits: π = 3.1415927 in the
finite-element matrices; J2 = 0.0045339259 kg m² (= M2 (L2²/3 + h²/12)); the axial mass block
ρ b h L2 [[8, 1], [1, 2]], fifteen times the consistent ρ b h L2 [[8, 1], [1, 2]]/15. With the
consistent block, q1(t) from the second initial state moves by up to 1.2e-5 m (0.6 % of its
2 mm peak; its largest |q1| becomes the −1.988 mm at 35.8 ms instead of +1.986 mm at 47.9 ms):
the size of difference a model with the true axial inertia will see.

Multipliers as in the test set, with the sign of (1): the slider (with its guide) acts on the
conrod's end with the force (λ2, −λ1) (x, y) in N, so the conrod pushes the slider with −λ2
along x and its guide with λ1 along y, and the drive applies the torque −λ3 (N m) to the crank.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.integrate import solve_ivp

# --- data: the PARAMETER block of crank.f (SI) --------------------------------------------
L1, L2 = 0.15, 0.30                       # crank, conrod (pin to pin) lengths, m
M1, M2, M3 = 0.36, 0.151104, 0.075552     # crank (only in gravity: none), conrod, slider, kg
J1, J2 = 0.002727, 0.0045339259           # crank about its pivot, conrod about the crank pin
E, NU, RHO = 2.0e11, 0.3, 7870.0          # conrod material (ν is not used by the beam model)
B = H = 0.008                             # conrod section, m
OMEGA = 150.0                             # crank speed, rad/s
PI_TESTSET = 3.1415927                    # the problem file's value of π

# --- the two initial states (INIT, INIT2 of the drivers): q, q̇, the rigid values, p̈ and λ ---
INITIAL = {
    "first": {  # "close to smooth motion"
        "q": [0.0, 0.0, 1.03339863e-5, 1.69327969e-5],
        "q_rate": [0.444896105, 4.63434311e-3, -1.78591076e-6, -2.68938672e-6],
        "phi2": 0.0, "x3": 0.450016933, "phi2_rate": -74.9957670, "x3_rate": -2.68938672e-6,
        "accelerations": [0.0, -1.344541576008661e-03, -5.062194923138079e+03,
                          -6.833142732779555e-05, 1.449382650173157e-08,
                          -4.268463211410861e+00, 2.098334687947376e-01],
        "multipliers": [-6.397251492537153e-08, 3.824589508329281e+02, -4.376060460948886e-09],
    },
    "second": {  # on the rigid motion trajectory: undeformed, moving rigidly
        "q": [0.0, 0.0, 0.0, 0.0], "q_rate": [0.0, 0.0, 0.0, 0.0],
        "phi2": 0.0, "x3": 0.45, "phi2_rate": -75.0, "x3_rate": 0.0,
        "accelerations": [0.0, 0.0, -3.789473684210526e+03, 0.0, 0.0,
                          1.924342105263158e+02, 1.273026315789474e+03],
        "multipliers": [0.0, 2.863023157894737e+02, 0.0],
    },
}

#: The published reference solution at t = 0.1 s from the first initial state (SOLN).
REFERENCE_T01 = {
    "phi2": -3.311734987910881e-01, "x3": 1.697373326718410e-01,
    "q": [1.893192460247178e-04, 2.375751865617931e-05, -5.323907988763734e-06,
          -8.363283141616840e-06],
    "phi2_rate": 6.025346682645789e+01, "x3_rate": -8.753116989887888e+00,
    "q_rate": [-3.005536801092212e-02, -5.500488291932075e-03, 4.978243404809343e-04,
               1.104933470696396e-03],
    "multipliers": [-6.232893262533717e+01, -1.637910131687472e+02, 2.529853213732781e+01],
}


def _conrod_matrices() -> dict[str, np.ndarray]:
    """Mass MQ, stiffness KQ, gyroscopic BQ (antisymmetric) and the coupling vectors c1, c2,
    c12, c21 of the conrod (RESMBS, first call), ρ included in all but KQ."""
    pi, vol = PI_TESTSET, B * H * L2
    rv, ea_l, slender = RHO * vol, E * B * H / L2, (H / L2) ** 2
    b13, b14, b24 = 16 / pi ** 3, 8 / pi ** 3 - 1 / pi, 0.5 / pi
    return {
        "MQ": rv * np.array([[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 8, 1], [0, 0, 1, 2.0]]),
        "KQ": ea_l * np.array([[pi ** 4 / 24 * slender, 0, 0, 0],
                               [0, pi ** 4 * 2 / 3 * slender, 0, 0],
                               [0, 0, 16 / 3, -8 / 3], [0, 0, -8 / 3, 7 / 3]]),
        "BQ": rv * np.array([[0, 0, -b13, b14], [0, 0, 0, b24],
                             [b13, 0, 0, 0], [-b14, -b24, 0, 0]]),
        "c1": rv * np.array([0, 0, 2 / 3, 1 / 6]),           # ∫ ρA N_u dx
        "c2": rv * np.array([2 / pi, 0, 0, 0]),              # ∫ ρA N_v dx
        "c12": rv * L2 * np.array([0, 0, 1 / 3, 1 / 6]),     # ∫ ρA x N_u dx
        "c21": rv * L2 * np.array([1 / pi, -0.5 / pi, 0, 0]),  # ∫ ρA x N_v dx
    }


CONROD = _conrod_matrices()


def conrod_variant(bending_hz: tuple[float, float] | None = None,
                   consistent_axial_mass: bool = False) -> dict[str, np.ndarray]:
    """The conrod's matrices with its two bending frequencies (pinned–pinned, Hz) set to
    ``bending_hz`` by scaling KQ's bending diagonal, and/or the axial mass block replaced by the
    consistent one (a fifteenth of the test set's): what a conrod whose beam theory differs
    from Euler–Bernoulli's (shear, rotary inertia: a 3D body) is compared with."""
    c = {k: v.copy() for k, v in CONROD.items()}
    if bending_hz is not None:
        for k, f in enumerate(bending_hz):
            c["KQ"][k, k] = c["MQ"][k, k] * (2 * np.pi * f) ** 2
    if consistent_axial_mass:
        c["MQ"][2:, 2:] /= 15.0
    return c


def bending_frequencies_hz(conrod: dict[str, np.ndarray] = CONROD) -> tuple[float, float]:
    """The two bending modes' frequencies √(k_ii / m_ii) / 2π (Hz): Euler–Bernoulli's
    pinned–pinned ones for the test set's data (203.19 and 812.76 Hz)."""
    k, m = np.diag(conrod["KQ"]), np.diag(conrod["MQ"])
    f = np.sqrt(k[:2] / m[:2]) / (2 * np.pi)
    return float(f[0]), float(f[1])


def mass_and_forces(p: np.ndarray, v: np.ndarray, c: dict[str, np.ndarray] = CONROD
                    ) -> tuple[np.ndarray, np.ndarray]:
    """M(p) and f(p, ṗ) of (1), p = (φ1, φ2, x3, q1..q4): the test set's AM and F (for the
    conrod's matrices ``c``)."""
    q, qd, w1, w2 = p[3:], v[3:], v[0], v[1]
    s12, k12 = np.sin(p[0] - p[1]), np.cos(p[0] - p[1])
    c1q, c2q, c12q = c["c1"] @ q, c["c2"] @ q, c["c12"] @ q
    c1qd, c2qd, c12qd = c["c1"] @ qd, c["c2"] @ qd, c["c12"] @ qd
    mq = c["MQ"] @ q
    m = np.zeros((7, 7))
    m[0, 0] = J1 + M2 * L1 ** 2
    m[0, 1] = 0.5 * L1 * L2 * M2 * k12 + L1 * (s12 * c2q + k12 * c1q)
    m[1, 1] = J2 + q @ mq + 2 * c12q
    m[2, 2] = M3
    m[0, 3:] = L1 * (-s12 * c["c1"] + k12 * c["c2"])
    m[1, 3:] = c["c21"] + c["BQ"].T @ q
    m[3:, 3:] = c["MQ"]
    m = np.triu(m) + np.triu(m, 1).T
    f = np.empty(7)
    f[0] = (-0.5 * L1 * L2 * M2 * w2 ** 2 * s12 + L1 * w2 ** 2 * (-s12 * c1q + k12 * c2q)
            - 2 * L1 * w2 * (k12 * c1qd + s12 * c2qd))
    # the test set's − q̇ᵀ BQ q̇ in f2 vanishes: BQ is antisymmetric
    f[1] = (0.5 * L1 * L2 * M2 * w1 ** 2 * s12 + L1 * w1 ** 2 * (s12 * c1q - k12 * c2q)
            - 2 * w2 * c12qd - 2 * w2 * (qd @ mq))
    f[2] = 0.0
    f[3:] = (w2 ** 2 * (mq + c["c12"]) + L1 * w1 ** 2 * (k12 * c["c1"] + s12 * c["c2"])
             + 2 * w2 * c["BQ"] @ qd - c["KQ"] @ q)
    return m, f


def constraints(p: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """G(p) = ∂g/∂p of (2) and γ(p, ṗ) with G p̈ = γ (the test set's GP and ALC)."""
    s1, k1, s2, k2 = np.sin(p[0]), np.cos(p[0]), np.sin(p[1]), np.cos(p[1])
    arm, w1, w2, q4d = L2 + p[6], v[0], v[1], v[6]
    g = np.zeros((3, 7))
    g[0, [0, 1, 6]] = L1 * k1, arm * k2, s2
    g[1, [0, 1, 2, 6]] = L1 * s1, arm * s2, 1.0, -k2
    g[2, 0] = 1.0
    gamma = np.array([L1 * s1 * w1 ** 2 + arm * s2 * w2 ** 2 - 2 * w2 * k2 * q4d,
                      -L1 * k1 * w1 ** 2 - arm * k2 * w2 ** 2 - 2 * w2 * s2 * q4d, 0.0])
    return g, gamma


def accelerations(p: np.ndarray, v: np.ndarray, c: dict[str, np.ndarray] = CONROD
                  ) -> tuple[np.ndarray, np.ndarray]:
    """p̈ and λ of the index-1 system [[M, Gᵀ], [G, 0]] (p̈, λ) = (f, γ) from (1)–(2)."""
    m, f = mass_and_forces(p, v, c)
    g, gamma = constraints(p, v)
    kkt = np.zeros((10, 10))
    kkt[:7, :7], kkt[:7, 7:], kkt[7:, :7] = m, g.T, g
    sol = np.linalg.solve(kkt, np.concatenate([f, gamma]))
    return sol[:7], sol[7:]


def coordinates(t: float, q: np.ndarray, q_rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """p and ṗ satisfying (2) and its time derivative for given t, q, q̇ (|φ2| < π/2)."""
    phi1, arm = OMEGA * t, L2 + q[3]
    phi2 = np.arcsin(-L1 * np.sin(phi1) / arm)
    s1, k1, s2, k2 = np.sin(phi1), np.cos(phi1), np.sin(phi2), np.cos(phi2)
    x3 = L1 * k1 + arm * k2
    phi2_rate = -(L1 * k1 * OMEGA + s2 * q_rate[3]) / (arm * k2)
    x3_rate = -L1 * s1 * OMEGA - arm * s2 * phi2_rate + k2 * q_rate[3]
    return (np.concatenate([[phi1, phi2, x3], q]),
            np.concatenate([[OMEGA, phi2_rate, x3_rate], q_rate]))


def derivative(t: float, y: np.ndarray, c: dict[str, np.ndarray] = CONROD) -> np.ndarray:
    """d/dt (q, q̇) of the slider crank, φ2, x3 eliminated by (2)."""
    p, v = coordinates(t, y[:4], y[4:])
    a, _ = accelerations(p, v, c)
    return np.concatenate([y[4:], a[3:]])


@dataclass(frozen=True)
class Solution:
    """Slider-crank history at n times (s): φ2 (rad), x3 (m), q (m, n × 4), their rates,
    and the multipliers (λ1, λ2 in N, λ3 in N m; n × 3)."""

    time: np.ndarray
    phi2: np.ndarray
    x3: np.ndarray
    q: np.ndarray
    phi2_rate: np.ndarray
    x3_rate: np.ndarray
    q_rate: np.ndarray
    multipliers: np.ndarray


def solve(initial: Literal["first", "second"] = "first", end_time: float = 0.1,
          times: np.ndarray | None = None, rtol: float = 1e-12,
          atol: float | np.ndarray = 1e-14, conrod: dict[str, np.ndarray] = CONROD) -> Solution:
    """Integrate from the test set's ``initial`` state ("first" or "second") to ``end_time``
    by DOP853; output at ``times`` (default: the accepted steps). ``atol`` applies to q in m
    and is scaled by 1e3 s⁻¹ for q̇ (rates ~ 10³ × displacements) unless given per component.
    ``conrod``: the conrod's matrices (the test set's, or a :func:`conrod_variant`)."""
    state = INITIAL[initial]
    y0 = np.concatenate([state["q"], state["q_rate"]])
    if np.ndim(atol) == 0:
        atol = np.concatenate([np.full(4, atol), np.full(4, 1e3 * atol)])
    ivp = solve_ivp(derivative, (0.0, end_time), y0, method="DOP853", t_eval=times,
                    rtol=rtol, atol=atol, args=(conrod,))
    if not ivp.success:
        raise RuntimeError(f"slider crank: {ivp.message}")
    rows = []
    for t, y in zip(ivp.t, ivp.y.T):
        p, v = coordinates(t, y[:4], y[4:])
        rows.append(np.concatenate([p, v, accelerations(p, v, conrod)[1]]))
    out = np.array(rows)
    return Solution(time=ivp.t, phi2=out[:, 1], x3=out[:, 2], q=out[:, 3:7],
                    phi2_rate=out[:, 8], x3_rate=out[:, 9], q_rate=out[:, 10:14],
                    multipliers=out[:, 14:17])


def midpoint_deflection(solution: Solution) -> np.ndarray:
    """Lateral deflection of the conrod's midpoint, v(½) = q1, in m: positive to the left of
    the chord from the crank pin to the slider pin (the floating frame's +y)."""
    return solution.q[:, 0]


def rigid_slider_position(t: np.ndarray) -> np.ndarray:
    """x3 of the rigid slider crank, L1 cos φ1 + √(L2² − L1² sin² φ1), φ1 = Ω t, in m."""
    phi1 = OMEGA * np.asarray(t)
    return L1 * np.cos(phi1) + np.sqrt(L2 ** 2 - (L1 * np.sin(phi1)) ** 2)
