"""The standalone integrator's settled cantilever against linear statics and Timoshenko.

Not in ``tests/dynamics`` with the other integrator tests: it needs the thirty-mode test
beam (282 coordinates), too large to commit (``tests/data/make_reduced_models.py``), and
fewer modes are too stiff for the 5 % it asserts against Timoshenko, so it reduces the beam
with ``gcms reduce`` (the finite-element stack) here.
"""
from __future__ import annotations

import numpy as np
import pytest

from beams import (E_STEEL, HEIGHT_Z, LENGTH, NU_STEEL, WIDTH_Y, beam_study,
                   linear_static_displacement)
from conftest import gcms_reduce
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.config.scene import parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_body
from gcms_fenicsx.files.reduced_model import read_reduced


@pytest.fixture(scope="module")
def beam30(tmp_path_factory):
    """(model, body): the test beam with thirty elastic modes (282 coordinates)."""
    folder = tmp_path_factory.mktemp("beam30")
    model = read_reduced(gcms_reduce(beam_study(30), folder / "study.toml", folder)
                         / "reduced.h5")
    return model, body_from_reduced(model)


@pytest.mark.slow
def test_ramped_tip_load_settles_to_the_static_cantilever_deflection(beam30):
    """A 100 N end load (−z, ramped over 20 ms) on a cantilever (fixed joint at x = 0), with
    β = 3e-3 damping, settles to:

    - the deflection the reduced stiffness predicts (linear solve with the joint rows) to
      1e-4 (the co-rotated model differs by O((δ/L)²) ~ 4e-6);
    - Timoshenko's cantilever, δ = F L³/(3 E I_y) + F L/(κ G A), κ = 10(1+ν)/(12+11ν)
      (Cowper 1966), within a few percent: the reduced model of 30 free–free modes is a
      Rayleigh–Ritz approximation, hence stiffer (δ ≤ δ_FE), and the joint holds the end
      face only in the mean, so 0.95 < δ/δ_Timoshenko < 1.02;
    - a joint force equal and opposite to the load (1e-6)."""
    _, body = beam30
    F = 100.0
    sc = parse_scene({"end_time": 0.08, "time_step": 1e-4, "damping": {"beta": 3e-3},
                      "joints": [{"type": "fixed", "group": "end_x0", "name": "clamp"}],
                      "loads": [{"group": "end_xL", "force": [0.0, 0.0, -F], "time": "ramp",
                                 "ramp_time": 0.02, "name": "tip"}],
                      "outputs": {"groups": ["end_xL"], "every": 10}})
    traj, summary = simulate_body(body, sc)
    assert summary["complete"], summary["message"]
    tip = traj.groups["end_xL"]["position"]
    settled = tip[-1] - tip[0]
    load = np.kron(body.groups["end_xL"].position, [0.0, 0.0, -F])
    predicted = linear_static_displacement(body, sc, load, "end_xL")
    assert settled[2] == pytest.approx(predicted[2], rel=1e-4)
    np.testing.assert_allclose(traj.joint_force("clamp")[-1], [0.0, 0.0, F], atol=1e-6 * F)

    G = E_STEEL / (2 * (1 + NU_STEEL))
    area, I_y = WIDTH_Y * HEIGHT_Z, WIDTH_Y * HEIGHT_Z ** 3 / 12
    kappa = 10 * (1 + NU_STEEL) / (12 + 11 * NU_STEEL)
    timoshenko = F * LENGTH ** 3 / (3 * E_STEEL * I_y) + F * LENGTH / (kappa * G * area)
    assert 0.95 < -settled[2] / timoshenko < 1.02, -settled[2] / timoshenko
