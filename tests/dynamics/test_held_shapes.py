"""The static shapes (``gcms_fenicsx.dynamics.bases.static_shapes``) of the committed six-mode test
beam, with NumPy and h5py only: the held beam's static response to the scene's loads lies in
their span, in the full basis on them and in the rotor basis; how joints that hold it every
way, or leave it nothing to respond to, are taken."""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.config.basis import BasisConfig, scene_patterns
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.dynamics.constraints.joints import build_constraints
from gcms_fenicsx.dynamics.bases.run_basis import in_basis
from gcms_fenicsx.config.scene import parse_scene
from gcms_fenicsx.dynamics.bases.static_shapes import held_rows, shape_model, static_shapes
from gcms_fenicsx.dynamics.constraints.statics import dense_kkt_solve

PIN = {"name": "pin", "type": "revolute", "group": "end_x0", "axis": [0.0, 0.0, 1.0]}
CLAMP = {"name": "clamp", "type": "fixed", "group": "end_x0"}
#: a 5 Hz tip force across the pin's axis (at its peak at t = 0) and gravity along the axis
SCENE = {"end_time": 0.01, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81], "joints": [PIN],
         "loads": [{"group": "end_xL", "force": [0.0, 3.0, 0.0], "time": "harmonic",
                    "frequency_hz": 5.0, "phase_deg": 90.0}]}
STATIC = BasisConfig(shapes="static")


def test_the_held_beams_static_response_lies_in_its_static_shapes(beam6_model, beam6_body):
    """The beam pinned about z, its swing relieved by its inertia: the scene's band is 10 Hz,
    below the held beam's first mode, so the shapes are the responses to the tip force's two
    directions ⊥ z and to gravity along z (the swing's angular acceleration is the relief
    itself): 3 shapes, whose 9 components span fewer fields than the model's 22. The held
    beam's static response to the scene's loads at t = 0 — a combination of the patterns — is
    the same on the full basis on the shapes as on the model, to 1e-9 (round-off of two dense
    KKT solves; measured 4.2e-13), and that to a load outside them (along z at the tip, which
    gravity's pattern bends the same way but not alike) is not (measured 5.7e-2; asserted
    above 1e-3)."""
    scene = parse_scene(SCENE)
    patterns = scene_patterns(STATIC, scene)
    assert patterns.band_hz == 10.0
    assert [ld.kind for ld in patterns.loads] == ["force"] * 2 + ["gravity", "tangential"]
    held_hz, shapes = static_shapes(beam6_body, scene, patterns)
    assert len(held_hz) == 0 and shapes.shape[1] == 3
    shaped = body_from_reduced(shape_model(beam6_model, shapes))
    assert shaped.dofs < beam6_body.dofs

    def tip(body, load):
        rows, free = held_rows(body, scene)
        assert free == 1
        rhs = np.concatenate([load, np.zeros(rows.shape[0])])
        u = dense_kkt_solve(body.stiffness, rows, rhs)[:body.dofs]
        return u.reshape(-1, 3).T @ body.groups["end_xL"].position

    def error(loads):
        whole, part = (tip(b, f) for b, f in zip((beam6_body, shaped), loads))
        return np.abs(part - whole).max() / np.linalg.norm(whole)

    scene_loads = [b.gravity @ np.array(scene.gravity) + np.kron(
        b.groups["end_xL"].position, [0.0, 3.0, 0.0]) for b in (beam6_body, shaped)]
    along = [np.kron(b.groups["end_xL"].position, [0.0, 0.0, 1.0]) for b in (beam6_body, shaped)]
    assert error(scene_loads) < 1e-9
    assert error(along) > 1e-3
    rotor = in_basis(beam6_model, beam6_body, scene, "rotor", static=patterns)
    assert rotor.dofs <= 3 * 3 + 10


def test_a_clamp_holds_the_body_without_a_relief_however_other_joints_are_placed(beam6_body):
    """A fixed joint holds every rigid motion: beside a revolute joint at its own group or at
    the other end, the held rows are the joints' independent rows only (no relief, no extra
    row), and the shapes are made (a clamp and pin at the same group once failed: the shapes
    held the pin with an invented drive that contradicted the clamp)."""
    for pin in (dict(PIN, group="end_x0"), dict(PIN, group="end_xL")):
        scene = parse_scene(dict(SCENE, joints=[CLAMP, pin]))
        rows, free = held_rows(beam6_body, scene)
        assert free == 0
        assert rows.shape[0] == build_constraints(beam6_body, scene.joints, beam6_body.q0).count
        _, shapes = static_shapes(beam6_body, scene, scene_patterns(STATIC, scene))
        assert shapes.shape[1] >= 1


def test_a_scene_that_loads_nothing_gets_no_shapes_and_says_so(beam6_model, beam6_body):
    """A clamped beam without loads or gravity, its band (the 1 Hz load of zero force: 2 Hz)
    below its first mode: no pattern, no shape; the full basis on none is the rigid body (12
    coordinates, all held), and the run says it."""
    scene = parse_scene(dict(SCENE, joints=[CLAMP], gravity=[0.0, 0.0, 0.0],
                             loads=[{"group": "end_xL", "force": [0.0, 0.0, 0.0],
                                     "time": "harmonic", "frequency_hz": 1.0}]))
    patterns = scene_patterns(STATIC, scene)
    assert patterns.loads == ()
    said: list[str] = []
    body = in_basis(beam6_model, beam6_body, scene, "full", progress=said.append,
                    static=patterns)
    assert body.dofs == 12
    assert any("warning: no static shapes" in s for s in said), said
