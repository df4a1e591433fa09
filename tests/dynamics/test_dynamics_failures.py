"""Failures of the integrator name their real cause, with their numbers and what to change:
Newton divergence (not "inverted"), a time step too large for the round-off of Kr (not
"dependent fields"), and a summary whose undefined numbers are null, not NaN or Infinity.

The body is the six-mode test beam of ``beams`` (30 × 20 mm, 0.5 m), read from its committed
reduced.h5.
"""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from gcms_fenicsx.dynamics.alpha import AlphaParameters
from gcms_fenicsx.dynamics.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.simulate import elastic_modes, simulate_body

EPS = np.finfo(float).eps
NUMBER = r"[-+0-9.e]+"


@pytest.fixture(scope="module")
def body(beam6_body):
    return beam6_body


def test_newton_divergence_is_reported_as_newton_divergence(body):
    """A cantilever whose tip load is ramped to 100 kN in 10 ms (h = 1 ms): Newton's iterates
    run away in the step to t = 7 ms until one of them turns the body inside out. That is
    reported as Newton divergence (today: "the body is inverted or collapsed", as if the state
    were) with the time, the iteration, the increments and the tolerance, and what to change;
    the run is kept up to the last converged step. An iterate that turns the body inside out
    has moved by about the body's size: the largest increment (mass-weighted RMS) exceeds it."""
    scene = parse_scene({"end_time": 0.02, "time_step": 1e-3,
                         "joints": [{"type": "fixed", "group": "end_x0"}],
                         "loads": [{"group": "end_xL", "force": [0.0, 0.0, -1e5],
                                    "time": "ramp", "ramp_time": 0.01}]})
    traj, summary = simulate_body(body, scene)
    message = summary["message"]
    assert not summary["complete"]
    match = re.fullmatch(rf"Newton diverged at t = ({NUMBER}) s: iteration (\d+) reached a state "
                         rf"whose affine map has det = {NUMBER} \(singular values .*\), after "
                         rf"(?:the last 6 of \d+ )?increments ((?:{NUMBER}, )*{NUMBER}) m "
                         rf"\(tolerance ({NUMBER}) m\); reduce \[scene\] time_step \(now 0.001 "
                         rf"s\) or the loads", message)
    assert match, message
    assert "inverted" not in message
    t_failed, iteration, increments, tolerance = match.groups()
    assert float(t_failed) == pytest.approx(summary["time_reached_s"] + scene.time_step_s)
    assert traj.time[-1] == summary["time_reached_s"]
    increments = [float(x) for x in increments.split(", ")]
    assert int(iteration) >= 2 and len(increments) == min(6, int(iteration) - 1)
    assert float(tolerance) == pytest.approx(1e-10 * body.size_m, rel=0.05)
    assert max(increments) > body.size_m


def test_time_step_too_large_for_the_round_off_of_kr_names_the_time_step(body):
    """time_step = 1 s on the beam (highest reduced frequency ~460 kHz): S0 = β'Mr + Kr is
    singular on rigid motion because β' (≈ 4 /s²) is no longer far above the round-off of Kr's
    rigid eigenvalues, ε·λ_max(Kr, Mr) (≈ 2e-3 /s²); Mr itself is fine. The error is
    SceneError on [scene] time_step (today: IntegrationError asking whether dependent fields
    are left), it states β' and ε·λ_max (recomputed here) and cond(Mr), and it gives a time
    step that works: with it, the run completes."""
    h = 1.0
    with pytest.raises(SceneError) as raised:
        simulate_body(body, parse_scene({"end_time": 1.0, "time_step": h}))
    message = str(raised.value)
    p = AlphaParameters.from_rho_inf(0.8)
    beta_p = (1.0 - p.alpha_m) / (p.beta * h * h * (1.0 - p.alpha_f))
    noise = EPS * elastic_modes(body)[0][-1]
    assert message.startswith("[scene] time_step = 1: the iteration matrix S0 = β'Mr + Kr is "
                              "numerically singular"), message
    assert f"β' = {beta_p:.2e} 1/s²" in message and f"ε·λ_max(Kr, Mr) = {noise:.1e}" in message
    assert f"cond(Mr) = {np.linalg.cond(body.mass):.1e} is fine" in message
    assert "dependent fields" not in message
    works = float(re.search(rf"time_step = ({NUMBER}) s works$", message).group(1))
    assert works < h
    _, summary = simulate_body(body, parse_scene({"end_time": 1.0, "time_step": works}))
    assert summary["complete"], summary["message"]


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning",
                            "ignore:invalid value encountered:RuntimeWarning")
def test_summary_numbers_are_finite_or_null(body):
    """A body thrown at 1e200 m/s: its kinetic energy overflows to inf and the run stops in the
    first step. Every number of the summary is still finite or None — strict JSON
    (``allow_nan=False``) takes it — and the ones that are undefined are None."""
    _, summary = simulate_body(body, parse_scene({"end_time": 0.01, "time_step": 1e-3,
                                                  "initial": {"velocity": [1e200, 0.0, 0.0]}}))
    assert not summary["complete"]
    json.dumps(summary, allow_nan=False)
    assert summary["initial_kinetic_energy_j"] is None
    assert summary["initial_kinetic_energy_removed_by_joints_j"] is None
