"""The study's plan (``config.plan``, docs/design.md §1.2): one frozen value however the study
is reached — a file read by the command line, a dict given to the Python API, the default,
the tables a workflow builds (``workflows/common``) —
and what the command's stages produce carries exactly its keys; a choice that does not fit
is refused when the study is read, before any stage runs."""
from __future__ import annotations

import dataclasses
import json
import sys
import tomllib

import pytest

from beams import beam_study
from conftest import REPO, gcms
from gcms_fenicsx.config.plan import REDUCED_MODEL_TABLES, StudyPlan
from gcms_fenicsx.config.study import default_config_text, load_config, parse_config
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.files.modes_file import read_modes
from gcms_fenicsx.files.reduced_model import read_reduced
from simulate_runs import SCENE


def test_the_plan_is_one_frozen_value_however_the_study_is_reached(tmp_path):
    """The default study read from a file (the command line's route), as a dict (the Python
    API), built in, and as the workflows build it: equal plans, and a plan's fields cannot be
    changed (frozen all the way down to the body's keys)."""
    sys.path.insert(0, str(REPO / "workflows"))
    from common.crankshaft import default_study

    path = tmp_path / "default.toml"
    path.write_text(default_config_text())
    from_file = load_config(path).plan
    from_dict = parse_config(tomllib.loads(default_config_text()), str(path)).plan
    built_in = dataclasses.replace(load_config(None).plan, source=str(path))
    workflow = parse_config(default_study(), str(path)).plan
    assert isinstance(from_file, StudyPlan)
    assert from_file == from_dict == built_in == workflow
    with pytest.raises(dataclasses.FrozenInstanceError):
        from_file.body.svk = True                      # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        from_file.body.keys.reduced = ""               # type: ignore[misc]
    assert load_config(path).plan is not from_file     # each reading plans anew ...
    study = load_config(path)
    assert study.plan is study.plan                    # ... and once per study


def test_the_commands_stages_carry_the_plans_keys(beam6_reduced):
    """``gcms reduce`` (the command line) on the six-mode beam: mesh.json's input digest,
    modes.h5's key and reduced.h5's input hash are the plan's keys, as the Python API makes
    them from the same file; the reduced model's key is the digest of its tables."""
    out = beam6_reduced.parent
    plan = load_config(out / "study.toml").plan
    assert json.loads((out / "mesh.json").read_text())["input_digest"] == plan.body.keys.mesh
    assert read_modes(out / "modes.h5").key == plan.body.keys.modes
    model = read_reduced(beam6_reduced)
    assert model.input_hash == plan.body.keys.reduced
    assert plan.body.served_by(model.input_hash)
    assert plan.body.keys.reduced == plan.body.digest(*REDUCED_MODEL_TABLES)   # co-rotated


def test_each_choice_is_made_once_and_carried_where_it_is_needed():
    """The attachment loads reach the solve (the modes request) and the run (the scene's
    plan) as one tuple; "auto" is resolved to the scene's band in the request; the SVK law
    changes the reduced model's key and is served by no co-rotated model."""
    raw = tomllib.loads(beam_study(6) + SCENE.replace('attachment = "none"',
                                                      'attachment = "scene"'))
    plan = parse_config(dict(raw, modes={"count": "auto"})).plan
    assert plan.body.modes.attachment == plan.scene.attachment and len(plan.scene.attachment) == 6
    assert plan.body.modes.band is not None
    assert plan.body.modes.max_frequency_hz == plan.body.modes.band.max_frequency_hz
    svk = parse_config(dict(raw, scene=dict(raw["scene"], elasticity="svk"))).plan
    corotated = parse_config(raw).plan
    assert svk.body.svk and not corotated.body.svk
    assert svk.body.keys.reduced != corotated.body.keys.reduced
    assert not svk.body.served_by(corotated.body.keys.reduced)
    assert corotated.body.served_by(svk.body.keys.reduced)   # it carries what co-rotated needs


@pytest.mark.parametrize("change, key", [
    ({"basis": {"kind": "rotor"}}, "[basis] kind"),                 # a clamp holds the turning
    ({"basis": {"shapes": "static"}, "scene": None}, "[basis] shapes"),
    ({"modes": {"count": "auto"}, "scene": None}, "[modes] count"),
    ({"basis": {"attachment": "scene"}, "scene": None}, "[basis] attachment"),
])
def test_a_choice_that_does_not_fit_is_refused_when_the_study_is_read(change, key):
    """Each of the plan's refusals names its key, and comes from reading the study (no stage
    has run: nothing here meshes or solves)."""
    from gcms_fenicsx.config.scene import SceneError

    raw = tomllib.loads(beam_study(6) + SCENE)
    raw.update({k: v for k, v in change.items() if v is not None})
    for k in (k for k, v in change.items() if v is None):
        raw.pop(k)
    with pytest.raises((ConfigError, SceneError)) as refused:
        parse_config(raw)
    assert key in str(refused.value)


def test_the_command_line_refuses_before_any_stage(tmp_path):
    """The same refusal through ``gcms run``: one line, exit 2, no --out."""
    config = tmp_path / "study.toml"
    config.write_text(beam_study(6) + SCENE + 'kind = "rotor"\n')
    run = gcms("run", str(config), "--out", str(tmp_path / "out"))
    assert run.returncode == 2 and "[basis] kind" in run.stderr, run.stderr
    assert "mesh" not in run.stderr.split("error")[0]
    assert not (tmp_path / "out").exists()
