"""A scene that starts in the held body's static equilibrium (``[scene.initial] equilibrium =
true``, ``dynamics.constraints.statics.static_equilibrium``) and loads that rise in (a harmonic
load's ``ramp_time``): what makes the default crankshaft's outputs converge in the step.

On the committed six-mode test beam (``beams``): the equilibrium start is where a damped run
from the undeformed beam comes to rest, and an undamped run from it stays there.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from beams import BEAM6_SVK, GRAVITY
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.config.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate, simulate_body
from gcms_fenicsx.files.reduced_model import read_reduced

CLAMP = {"type": "fixed", "group": "end_x0", "name": "clamp"}
DOWN = [0.0, 0.0, -GRAVITY]


def cantilever(**table):
    return parse_scene(dict({"end_time": 0.02, "time_step": 1e-4, "gravity": DOWN,
                             "joints": [CLAMP], "outputs": {"groups": ["end_xL"]}}, **table))


def tip(traj) -> np.ndarray:
    return traj.groups["end_xL"]["position"]


def test_the_equilibrium_start_is_where_a_damped_run_comes_to_rest(beam6_body):
    """The cantilever under gravity: the tip of the equilibrium start is where a damped run
    from the undeformed beam comes to rest (β = 3e-3 s, every mode decays at ≥ 250 /s, so
    after 60 ms the swing is e⁻¹⁵ ≈ 3e-7 of the sag: bound 1e-6 of the sag; measured 2e-8),
    and undamped the run from it stays there within ten Newton tolerances (1e-10 of the body's
    size per step; measured 2.3e-12 m against a 56 µm sag), while the run from the undeformed
    beam swings through twice the sag."""
    body = beam6_body
    settled, summary = simulate_body(body, cantilever(end_time=0.06, damping={"beta": 3e-3}))
    assert summary["complete"], summary["message"]
    rest, summary = simulate_body(body, cantilever(initial={"equilibrium": True}))
    assert summary["complete"], summary["message"]
    undeformed = tip(settled)[0]
    sag = tip(settled)[-1] - undeformed
    assert abs(sag[2]) > 1e-7                                  # a sag to compare with
    np.testing.assert_allclose(tip(rest)[0] - undeformed, sag, atol=1e-6 * np.linalg.norm(sag))
    tolerance_m = cantilever().solver.tolerance * body.size_m
    assert np.abs(tip(rest) - tip(rest)[0]).max() <= 10 * tolerance_m
    dropped, _ = simulate_body(body, cantilever())
    assert np.abs(tip(dropped) - tip(dropped)[0])[:, 2].max() >= 1.5 * abs(sag[2])


def test_the_rotor_basis_starts_at_rest_too(beam6_model, beam6_body):
    """The beam in a revolute joint about its axis x whose drive holds it at rest (angular
    velocity 0: a brake, so every rigid motion is held) under gravity: in either basis it
    starts sagged and stays at rest (within ten Newton tolerances, 1e-10 of the body's size
    each; measured 2.2e-12 m full, 2.2e-16 m rotor, against a 56 µm sag)."""
    sc = parse_scene({"end_time": 0.005, "time_step": 1e-4, "gravity": DOWN,
                      "initial": {"equilibrium": True},
                      "joints": [{"type": "revolute", "group": "end_x0", "axis": [1, 0, 0],
                                  "name": "shaft",
                                  "drive": {"angular_velocity": 0.0}}],
                      "outputs": {"groups": ["end_xL"]}})
    tolerance_m = sc.solver.tolerance * beam6_body.size_m
    for basis in ("full", "rotor"):
        traj, summary = simulate(beam6_model, sc, basis=basis)
        assert summary["complete"], summary["message"]
        sag = tip(traj)[0, 2]                  # the undeformed tip is on the axis (z = 0)
        moved = np.abs(tip(traj) - tip(traj)[0]).max()
        assert sag < -1e-5 and moved <= 10 * tolerance_m, (basis, sag, moved)


@pytest.mark.parametrize("joints, refused", [
    ([], "no joints"),
    ([{"type": "revolute", "group": "end_x0", "axis": [0, 1, 0]}], "rigid motions free"),
    ([{"type": "spherical", "group": "end_x0"}], "rigid motions free"),
])
def test_a_body_its_joints_do_not_hold_has_no_equilibrium_start(beam6_body, joints, refused):
    """No joints, an undriven pin, a ball joint: the body can move rigidly, so a static
    equilibrium under gravity does not exist — refused by name, not run."""
    sc = parse_scene({"end_time": 0.01, "time_step": 1e-3, "gravity": DOWN, "joints": joints,
                      "initial": {"equilibrium": True}})
    with pytest.raises(SceneError, match=refused):
        simulate_body(beam6_body, sc)


@pytest.mark.parametrize("extra, named", [
    ({"initial": {"equilibrium": True, "mode": 1, "amplitude": 1e-3}}, "not with mode"),
    ({"initial": {"equilibrium": True, "velocity": [0.0, 0.0, 1.0]}}, "velocity"),
    ({"initial": {"equilibrium": True, "angular_velocity": [1.0, 0.0, 0.0]}}, "velocity"),
    ({"initial": {"equilibrium": True},
      "joints": [dict(CLAMP, type="revolute", axis=[1, 0, 0],
                      drive={"angular_velocity": 10.0})]}, "joint 'clamp': give it a ramp_time"),
    ({"initial": {"equilibrium": "yes"}}, "true or false"),
])
def test_a_start_at_rest_that_is_not_at_rest_is_refused_when_read(extra, named):
    """A mode shape, a given velocity, or a drive turning at t = 0 (no ramp_time: θ̇(0) = Ω)
    contradict a body at rest in its static equilibrium: one ConfigError naming the key, when
    the study is read."""
    with pytest.raises(ConfigError, match="equilibrium") as err:
        parse_scene(dict({"end_time": 1.0, "time_step": 1e-3}, **extra))
    assert named in str(err.value)


def test_the_geometrically_exact_law_starts_at_rest_too():
    """elasticity = "svk" on the cantilever under gravity: Newton on the SVK forces with the
    stiffness at rest, and the run from there stays within ten Newton tolerances."""
    model = read_reduced(BEAM6_SVK)
    sc = cantilever(initial={"equilibrium": True}, elasticity="svk")
    traj, summary = simulate(model, sc)
    assert summary["complete"] and summary["elasticity"] == "svk", summary["message"]
    size = body_from_reduced(model).size_m
    assert tip(traj)[0, 2] < -1e-5
    assert np.abs(tip(traj) - tip(traj)[0]).max() <= 10 * sc.solver.tolerance * size


def test_a_harmonic_load_rises_in_over_its_ramp_time():
    """s(t) = ½ (1 − cos(π t / T)) sin(2π f t + φ) below T, the plain harmonic from T on:
    zero at t = 0 with zero rate (a finite difference of 1e-9 T gives |s'| ≤ 1e-6 f), equal
    to the plain harmonic at and after T; without ramp_time the harmonic starts at once."""
    T, f, phase = 0.04, 25.0, 270.0
    table = {"end_time": 1.0, "time_step": 1e-3,
             "loads": [{"group": "g", "force": [0, 0, 1], "time": "harmonic",
                        "frequency_hz": f, "phase_deg": phase, "ramp_time": T}]}
    ramped = parse_scene(table).loads[0]
    plain = parse_scene(dict(table, loads=[{k: v for k, v in table["loads"][0].items()
                                            if k != "ramp_time"}])).loads[0]
    assert ramped.factor(0.0) == 0.0 and plain.factor(0.0) == pytest.approx(-1.0)
    dt = 1e-9 * T
    assert abs(ramped.factor(dt) / dt) <= 1e-6 * f
    for t in (T, 1.3 * T, 0.77):
        assert ramped.factor(t) == pytest.approx(plain.factor(t), abs=1e-15)
    t = 0.3 * T
    envelope = 0.5 * (1.0 - math.cos(math.pi * 0.3))
    assert ramped.factor(t) == pytest.approx(envelope * plain.factor(t), rel=1e-14)
    with pytest.raises(ConfigError, match="ramp_time"):
        parse_scene(dict(table, loads=[dict(table["loads"][0], ramp_time=-1.0)]))


def test_a_load_too_large_for_a_start_at_rest_is_refused_with_its_newton_steps(beam6_body):
    """1 MN at the cantilever's tip: the linear statics already moves it 3.3 m (6.7 L) and
    Newton's next iterate inverts the body — one message naming the key and the increments,
    not a run from a collapsed state."""
    sc = cantilever(initial={"equilibrium": True},
                    loads=[{"group": "end_xL", "force": [0.0, 0.0, -1e6]}])
    with pytest.raises(SceneError, match=r"equilibrium = true: Newton .* inverts the body "
                                         r".*last increments 3\.33e\+00"):
        simulate_body(beam6_body, sc)
