"""The static shapes (``gcms_fenicsx.dynamics.static_shapes``) of the committed six-mode test
beam, with NumPy and h5py only: the held beam's static response to the scene's loads lies in
their span, in the full basis on them and in the rotor basis."""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.config.basis import BasisConfig, scene_patterns
from gcms_fenicsx.dynamics.body import body_from_reduced
from gcms_fenicsx.dynamics.run_basis import in_basis
from gcms_fenicsx.dynamics.scene import parse_scene
from gcms_fenicsx.dynamics.static_shapes import held_scene, shape_model, static_shapes
from gcms_fenicsx.dynamics.statics import held_static

PIN = {"name": "pin", "type": "revolute", "group": "end_x0", "axis": [0.0, 0.0, 1.0]}
#: a 5 Hz tip force across the pin's axis (at its peak at t = 0) and gravity along the axis
SCENE = {"end_time": 0.01, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81], "joints": [PIN],
         "loads": [{"group": "end_xL", "force": [0.0, 3.0, 0.0], "time": "harmonic",
                    "frequency_hz": 5.0, "phase_deg": 90.0}]}


def test_the_held_beams_static_response_lies_in_its_static_shapes(beam6_model, beam6_body):
    """The beam pinned about z, held about it for the shapes: the scene's band is 10 Hz, below
    the held beam's first mode (82.8 Hz), so the shapes are the responses to the tip force's
    two directions ⊥ z, gravity along z and the turning about z: 4 shapes, whose 12 components
    span 9 fields (in-plane shapes have no out-of-plane one), 4 + 9 of the model's 22. The held
    beam's static response to the scene's loads at t = 0 — a combination of the patterns — is
    the same on the full basis on the shapes as on the model, to 1e-9 (round-off of two dense
    KKT solves; measured tip 1.3e-13, reactions 2.0e-14), and that to a load outside them
    (along z at the tip, which gravity's pattern bends the same way but not alike) is not
    (measured 5.7e-2; asserted above 1e-3)."""
    scene = parse_scene(SCENE)
    patterns = scene_patterns(BasisConfig(shapes="static"), scene)
    assert patterns.band_hz == 10.0
    assert [ld.kind for ld in patterns.loads] == ["force"] * 2 + ["gravity", "tangential"]
    held_hz, shapes = static_shapes(beam6_body, scene, patterns)
    assert len(held_hz) == 0 and shapes.shape[1] == 4
    shaped = body_from_reduced(shape_model(beam6_model, shapes))
    assert shaped.dofs == 3 * 13 < beam6_body.dofs          # 9 of the 12 components: see above
    held = held_scene(scene)

    def tip_error(load=None, load_shaped=None):
        whole = held_static(beam6_body, held, load)
        restricted = held_static(shaped, held, load_shaped)
        tip = whole.group_displacement(beam6_body, "end_xL")
        return (np.abs(restricted.group_displacement(shaped, "end_xL") - tip).max()
                / np.linalg.norm(tip),
                np.abs(restricted.reactions - whole.reactions).max()
                / np.abs(whole.reactions).max())

    error, reactions = tip_error()
    assert error < 1e-9 and reactions < 1e-9, (error, reactions)
    along = [np.kron(b.groups["end_xL"].position, [0.0, 0.0, 1.0]) for b in (beam6_body, shaped)]
    assert tip_error(*along)[0] > 1e-3
    rotor = in_basis(beam6_model, beam6_body, scene, "rotor", static=patterns)
    assert rotor.dofs <= 3 * 4 + 10
