"""The study's input hash is a cache key users' files carry (reduced.h5 ``input_hash``): the same
study must give the same hash across versions of the code that do not change its meaning."""
from __future__ import annotations

import tomllib

from gcms_fenicsx.config.plan import REDUCED_MODEL_TABLES
from gcms_fenicsx.config.study import default_config_text, load_config, parse_config

#: Hashes recorded with the code of 2026-11-24 (d2b8c1b), before the package was reorganised
#: into config/, fe/, reduction/, files/: reduced.h5 files written then are still reused.
DEFAULT_STUDY_HASH = "0424d8625fda33704263580578ca62fd271157714bdb67da201cf5b66880a731"
SLENDER_BEAM_HASH = "c8b2fc00e98ec1c6c3b32b46b50c972a6bcf7b04e9d1e748ff8102b21f65597f"


def test_the_input_hash_of_a_study_is_stable():
    """The default study without attachment modes means what it meant then; with the default
    ``[basis] attachment = "auto"`` its scene adds them, so its reduced model, and its hash,
    differ (a file cached without them is not reused for it)."""
    raw = tomllib.loads(default_config_text())
    plain = parse_config(dict(raw, basis={"attachment": "none"}))
    assert plain.plan.body.digest(*REDUCED_MODEL_TABLES) == DEFAULT_STUDY_HASH
    assert load_config(None).plan.body.digest(*REDUCED_MODEL_TABLES) != DEFAULT_STUDY_HASH
    beam = parse_config({"geometry": {"kind": "beam", "section": "square", "side": 0.01,
                                      "length": 2.0},
                         "mesh": {"order": 2}, "modes": {"count": 6}})
    assert beam.plan.body.digest(*REDUCED_MODEL_TABLES) == SLENDER_BEAM_HASH


def test_the_hash_follows_the_tables_it_covers():
    """A changed upstream table changes the hash; a [scene] only through the attachment modes
    it asks for (its joints and loads), not its times."""
    raw = tomllib.loads(default_config_text())
    base = parse_config(dict(raw, basis={"attachment": "none"}))
    longer = parse_config(dict(raw, scene=dict(raw["scene"], end_time=0.2)))
    assert (longer.plan.body.digest(*REDUCED_MODEL_TABLES)
            == load_config(None).plan.body.digest(*REDUCED_MODEL_TABLES))
    stiffer = parse_config({"geometry": {"kind": "crankshaft", "throws": 4},
                            "mesh": {"order": 2}, "material": {"E": 211e9},
                            "modes": {"count": 10}})
    assert (stiffer.plan.body.digest(*REDUCED_MODEL_TABLES)
            != base.plan.body.digest(*REDUCED_MODEL_TABLES))
    unscened = parse_config({"geometry": {"kind": "crankshaft", "throws": 4},
                             "mesh": {"order": 2}, "modes": {"count": 10}})
    assert (unscened.plan.body.digest(*REDUCED_MODEL_TABLES)
            == base.plan.body.digest(*REDUCED_MODEL_TABLES))


def test_auto_count_takes_the_band_of_the_scene():
    """count = "auto": twice the highest excitation (harmonic load + drive speed), capped by
    what the step resolves (ten steps per period); refused without a scene."""
    import math

    import pytest

    from gcms_fenicsx.config.table import ConfigError

    raw = tomllib.loads(default_config_text())
    band = parse_config(dict(raw, modes={"count": "auto"})).plan.body.modes.band
    drive_hz = 314.159 / (2 * math.pi)                       # the default scene: 3000 rpm
    assert band.excitation_hz == pytest.approx(25.0 + drive_hz)   # its 25 Hz firing loads
    assert band.max_frequency_hz == pytest.approx(2 * (25.0 + drive_hz))
    assert band.set_by == "drive" and band.resolved_hz == pytest.approx(2000.0)
    coarse = dict(raw["scene"], time_step=2e-3)              # resolves 50 Hz only
    capped = parse_config(dict(raw, modes={"count": "auto"}, scene=coarse)).plan.body.modes.band
    assert capped.set_by == "time step" and capped.max_frequency_hz == pytest.approx(50.0)
    no_scene = {k: v for k, v in raw.items() if k != "scene"}
    with pytest.raises(ConfigError, match=r"\[modes\] count.*needs a \[scene\]"):
        parse_config(dict(no_scene, modes={"count": "auto"}))
    with pytest.raises(ConfigError, match='integer ≥ 1 or "auto"'):
        parse_config(dict(raw, modes={"count": "all"}))


def test_attachment_auto_follows_the_scene():
    """[basis] attachment = "auto" (the default) is "scene" in a study with a scene and "none"
    without one; an explicit "scene" without a scene is refused naming the key."""
    import pytest

    from gcms_fenicsx.config.basis import attachment_loads, parse_basis
    from gcms_fenicsx.config.table import ConfigError

    raw = tomllib.loads(default_config_text())
    default = load_config(None)
    assert default.basis.attachment == "auto"
    scene = parse_config(dict(raw, basis={"attachment": "scene"}))
    assert default.plan.body.modes.attachment == scene.plan.body.modes.attachment
    # the default scene: 3 forces at each bearing, 2 at each crank pin (the gas force along z
    # turns with the shaft in the y-z plane only), 2 moments at each bearing, the drive's
    # moment, the spin's centrifugal load
    kinds = [load.kind for load in default.plan.body.modes.attachment]
    assert (kinds.count("force"), kinds.count("moment"), kinds.count("centrifugal")) == (
        3 * 2 + 2 * 4, 2 * 2 + 1, 1)
    pins = {load.direction for load in default.plan.body.modes.attachment if load.group == "pin_0"}
    assert pins == {(0.0, 0.0, 1.0), (0.0, -1.0, 0.0)}
    assert parse_config(dict(raw, basis={"attachment": "none"})).plan.body.modes.attachment is None
    no_scene = {k: v for k, v in raw.items() if k != "scene"}
    assert parse_config(no_scene).plan.body.modes.attachment is None
    assert attachment_loads(parse_basis(None), None) == ()
    with pytest.raises(ConfigError, match=r"\[basis\] attachment.*needs a \[scene\]"):
        parse_config(dict(no_scene, basis={"attachment": "scene"}))
    with pytest.raises(ConfigError, match="'auto', 'none', 'scene'"):
        parse_config(dict(raw, basis={"attachment": "scenes"}))


def test_a_load_gets_the_directions_the_body_can_see_it_in():
    """A world-fixed force seen from the body (Rᵀ f over the rotations the joints leave):
    its own direction under a clamp (f and −f one load), the plane ⊥ the axis and the axis
    under revolute joints on one axis, x, y and z on a free body or a spherical joint; a load
    at a joint's group adds nothing to the joint's three forces."""
    import math

    from gcms_fenicsx.config.basis import BasisConfig, attachment_loads
    from gcms_fenicsx.config.scene import parse_scene

    def forces(joints, loads):
        scene = parse_scene({"end_time": 0.01, "time_step": 1e-3, "joints": joints,
                             "loads": loads})
        return {(a.group, a.direction) for a in attachment_loads(BasisConfig("scene"), scene)
                if a.kind == "force" and a.group != "end_x0"}

    clamp = [{"type": "fixed", "group": "end_x0"}]
    pin = [{"type": "revolute", "group": "end_x0", "axis": [0.0, 1.0, 0.0]}]
    tip = [{"group": "end_xL", "force": [0.0, 0.0, -3.0]},
           {"group": "end_xL", "force": [0.0, 0.0, 5.0]}]
    assert forces(clamp, tip) == {("end_xL", (0.0, 0.0, 1.0))}
    slanted = [{"group": "end_xL", "force": [1.0, 1.0, 0.0]}]
    plane = {d for _, d in forces(pin, slanted)}
    assert len(plane) == 3 and (0.0, 1.0, 0.0) in plane
    assert all(abs(d[1]) in (0.0, 1.0) for d in plane)          # the axis and ⊥ it
    assert len(forces(pin, tip)) == 2                           # z ⊥ the pin's y: the x-z plane
    assert len(forces([], tip)) == 3
    assert len(forces([{"type": "spherical", "group": "end_x0"}], tip)) == 3
    # a spherical joint ignores an axis given to it: the body still turns every way
    assert len(forces([{"type": "spherical", "group": "end_x0", "axis": [0.0, 0.0, 1.0]}],
                      tip)) == 3
    # loads at one group along parallel directions are one load; no −0.0 in its key
    parallel = [{"group": "end_xL", "force": [1.0, 1.0, 0.0]},
                {"group": "end_xL", "force": [3.0, 3.0, 0.0]}]
    assert len(forces(clamp, parallel)) == 1
    [(_, d)] = forces(clamp, [{"group": "end_xL", "force": [0.0, 0.0, -5.0]}])
    assert [math.copysign(1.0, x) for x in d] == [1.0, 1.0, 1.0]
    at_joint = [{"group": "end_x0", "force": [0.0, 0.0, 1.0]}]
    assert forces(clamp, at_joint) == set()


def test_static_shapes_take_the_scenes_load_patterns():
    """[basis] shapes = "static": on the default crankshaft, the four gas forces in the plane
    ⊥ the shaft (two directions each), gravity likewise, the drive's angular acceleration and
    its spin — 12 patterns — and the scene's band for the held modes; under a clamp, a load's
    own direction and gravity's, nothing turning. Refused naming the key without a scene, for
    joints that leave the body free to turn, with an initial mode and with another elastic
    law; the reduced model (its input hash) does not depend on it."""
    import math

    import pytest

    from gcms_fenicsx.config.basis import BasisConfig, scene_patterns, static_loads
    from gcms_fenicsx.config.table import ConfigError
    from gcms_fenicsx.config.scene import parse_scene

    raw = tomllib.loads(default_config_text())
    cfg = parse_config(dict(raw, basis={"shapes": "static"}))
    loads = static_loads(cfg.basis, cfg.scene)
    kinds = [load.kind for load in loads]
    assert (kinds.count("force"), kinds.count("gravity"), kinds.count("tangential"),
            kinds.count("centrifugal")) == (2 * 4, 2, 1, 1)
    assert {ld.direction for ld in loads if ld.kind == "gravity"} == {(0.0, 0.0, 1.0),
                                                                       (0.0, -1.0, 0.0)}
    assert (cfg.plan.body.digest(*REDUCED_MODEL_TABLES)
            == load_config(None).plan.body.digest(*REDUCED_MODEL_TABLES))
    assert static_loads(load_config(None).basis, cfg.scene) == ()
    # the held modes kept besides: below the scene's band, twice (25 Hz + 50 Hz)
    patterns = scene_patterns(cfg.basis, cfg.scene)
    assert patterns.loads == loads and patterns.band_hz == 2 * (25.0 + 314.159 / (2 * math.pi))
    assert scene_patterns(load_config(None).basis, cfg.scene) is None

    def scene(joints, **more):
        return parse_scene({"end_time": 0.01, "time_step": 1e-3, "joints": joints,
                            "gravity": [0.0, 0.0, -9.81],
                            "loads": [{"group": "end_xL", "force": [0.0, 0.0, -3.0]}], **more})

    clamp = [{"type": "fixed", "group": "end_x0"}]
    held = static_loads(BasisConfig(shapes="static"), scene(clamp))
    assert [(ld.kind, ld.direction) for ld in held] == [("force", (0.0, 0.0, 1.0)),
                                                        ("gravity", (0.0, 0.0, 1.0))]
    static = BasisConfig(shapes="static")
    with pytest.raises(ConfigError, match=r"\[basis\] shapes.*needs a \[scene\]"):
        static_loads(static, None)
    with pytest.raises(ConfigError, match=r"\[basis\] shapes.*free to turn"):
        static_loads(static, scene([{"type": "spherical", "group": "end_x0"}]))
    with pytest.raises(ConfigError, match=r"\[basis\] shapes.*the scene has no joints"):
        static_loads(static, scene([]))
    with pytest.raises(ConfigError, match=r"\[basis\] shapes.*initial\] mode = 1"):
        static_loads(static, scene(clamp, initial={"mode": 1, "amplitude": 1e-4}))
    with pytest.raises(ConfigError, match=r"\[basis\] shapes.*svk"):
        static_loads(static, scene(clamp, elasticity="svk"))
    with pytest.raises(ConfigError, match="'modes', 'static'"):
        parse_config(dict(raw, basis={"shapes": "ritz"}))
