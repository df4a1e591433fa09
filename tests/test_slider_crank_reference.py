"""The flexible slider crank of the IVP Test Set (``gcms_fenicsx.references.slider_crank``)
against the published data: the consistent initial accelerations and multipliers of both
initial states, the reference solution at t = 0.1 s, and, from the second (rigid) initial
state, the midpoint deflection and the closeness to the rigid slider crank.

Tolerances are derived from measured deviations. The port's own integration error (DOP853 at
its default rtol 1e-12, against rtol 1e-14) is ≤ 1.3e-8 relative in φ2, x3, q, φ̇2, ẋ3, λ and
≤ 2.6e-6 in q̇, far below what remains: the distance to the published digits. At t = 0.1 s
(first initial state) the port reaches, relative: φ2 1.0e-10, x3 1.9e-10, q1..q4 2.0e-7,
2.3e-7, 2.1e-6, 3.6e-6, φ̇2 1.2e-8, ẋ3 7.6e-8, q̇1..q̇4 1.5e-6, 1.1e-5, 8.3e-4, 5.7e-4,
λ 6.9e-6, 6.6e-6, 1.9e-6. These are one and the same thing: a ~3e-11 m component in the
3.6 kHz axial mode (q4 off by 3.0e-11 m and q̇4 by 6.3e-7 m/s, ratio 2.1e4 s⁻¹ against the
mode's 2.26e4 rad/s; x3 follows q4: 3.2e-11 m; the conrod force follows it through EA/L2 =
4.3e7 N/m: 1.1e-3 N), within what the published reference resolved. Each bound below is
the measured deviation times 3 to 5.
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.references import slider_crank as sc

pytestmark = pytest.mark.slow  # each solve takes ~8-13 s on the loaded 2-core machine

#: Relative bounds at t = 0.1 s, from the first initial state (see the module docstring).
BOUNDS_T01 = {"phi2": 5e-10, "x3": 1e-9, "q": [1e-6, 1e-6, 1e-5, 2e-5],
              "phi2_rate": 5e-8, "x3_rate": 3e-7, "q_rate": [5e-6, 5e-5, 3e-3, 2e-3],
              "multipliers": [3e-5, 3e-5, 1e-5]}
TIMES = np.linspace(0.0, 0.1, 2001)  # 50 µs: a 203 Hz peak sampled to 5e-4 relative


@pytest.fixture(scope="module")
def first() -> sc.Solution:
    return sc.solve("first", times=np.array([0.0, 0.1]))


@pytest.fixture(scope="module")
def second() -> sc.Solution:
    """rtol 1e-10: q1 within 1e-11 m of rtol 1e-12, x3 within 3e-11 m; the bands are ≥ 5e-5 m."""
    return sc.solve("second", times=TIMES, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("initial", ["first", "second"])
def test_initial_accelerations_and_multipliers_match_the_published_ones(initial):
    """The index-1 solve at t = 0 reproduces the drivers' consistent p̈ and λ. The second
    state is exact (q = q̇ = 0); the first agrees to 1e-9 relative where the rigid motion
    dominates and to ≤ 2.4e-7 (m/s², N) in the elastic accelerations and the near-zero
    multipliers, which the published values carry from an unrounded initial state. Any
    wrong coupling term shows at ≥ 1e-4 (a sign of the gyroscopic BQ: 3.4 m/s² in q̈4)."""
    state = sc.INITIAL[initial]
    p, v = sc.coordinates(0.0, np.array(state["q"]), np.array(state["q_rate"]))
    a, lam = sc.accelerations(p, v)
    np.testing.assert_allclose(a, state["accelerations"], rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(lam, state["multipliers"], rtol=1e-9, atol=1e-6)


@pytest.mark.parametrize("initial", ["first", "second"])
def test_closed_form_rigid_coordinates_match_the_published_initial_values(initial):
    """φ2, x3 and their rates from the constraints agree with the published 9-digit values to
    half a unit of their last digit."""
    state = sc.INITIAL[initial]
    p, v = sc.coordinates(0.0, np.array(state["q"]), np.array(state["q_rate"]))
    assert abs(p[2] - state["x3"]) <= 5e-10
    assert abs(v[1] - state["phi2_rate"]) <= 5e-8
    assert (p[1], v[2]) == pytest.approx((state["phi2"], state["x3_rate"]), abs=1e-15)


def test_first_initial_state_reproduces_the_published_solution_at_0p1_s(first):
    """φ2, x3, q, their rates and λ at t = 0.1 s within BOUNDS_T01 of the published digits."""
    assert first.time[-1] == 0.1
    got = {"phi2": first.phi2[-1], "x3": first.x3[-1], "q": first.q[-1],
           "phi2_rate": first.phi2_rate[-1], "x3_rate": first.x3_rate[-1],
           "q_rate": first.q_rate[-1], "multipliers": first.multipliers[-1]}
    for key, bound in BOUNDS_T01.items():
        reference = np.asarray(sc.REFERENCE_T01[key])
        relative = np.abs(np.asarray(got[key]) - reference) / np.abs(reference)
        assert np.all(relative <= np.asarray(bound)), (key, relative)


def test_second_initial_state_midpoint_deflection_peaks_near_2_mm_at_48_ms(second):
    """|q1| peaks at +1.986 mm at t = 47.9 ms (to the left of the chord). The band, 2 mm
    ± 2.5 % and ± 1 ms, is the published "close to 2 mm near 0.048 s"; ± 1 ms is under half
    the 4.9 ms pinned–pinned bending period, so a shifted cycle fails. The runner-up, −1.980
    mm at 35.8 ms, is within 0.3 %: a model with different axial inertia may swap the two
    (the consistent axial mass does), which is why the sign and time are asserted too."""
    deflection = sc.midpoint_deflection(second)
    peak = int(np.argmax(np.abs(deflection)))
    assert deflection[peak] == pytest.approx(2.0e-3, rel=0.025)
    assert second.time[peak] == pytest.approx(0.048, abs=1e-3)
    assert deflection[0] == 0.0


def test_second_initial_state_stays_on_the_rigid_slider_crank(second):
    """In the test set's chord frame the bending (q1, q2: 2 mm) never enters the constraints
    (2): x3 and φ2 differ from the rigid slider crank through the axial stretch q4 alone, with
    |dx3/dq4| = 1/cos φ2 and |dφ2/dq4| = |tan φ2|/(L2 + q4), |sin φ2| ≤ L1/(L2 − max|q4|)
    (≈ 1.155 and 1.93 m⁻¹). And max|q4| < 2.5 % of the 2 mm peak deflection (5e-5 m; the
    peak conrod force, 477 N, over EA/L2 = 4.3e7 N/m is 1.1e-5 m static; measured 3.4e-5 m
    with the axial vibration)."""
    q4_max = np.abs(second.q[:, 3]).max()
    assert q4_max < 0.025 * 2.0e-3
    sin_max = sc.L1 / (sc.L2 - q4_max)
    cos_min = np.sqrt(1 - sin_max ** 2)
    rigid_x3 = sc.rigid_slider_position(second.time)
    rigid_phi2 = np.arcsin(-sc.L1 * np.sin(sc.OMEGA * second.time) / sc.L2)
    assert np.abs(second.x3 - rigid_x3).max() <= q4_max / cos_min
    assert np.abs(second.phi2 - rigid_phi2).max() <= q4_max * sin_max / cos_min / (sc.L2 - q4_max)
