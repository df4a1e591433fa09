"""System studies (``config.system``, ``app.system_run``; docs/study-file.md "System studies"):
several bodies and their joints in one study file, run by ``gcms run``.

Checked against references nobody here tuned: the rigid slider crank's closed form
(``references.slider_crank_assembly.rigid_closed_form``) and, for a flexible conrod, the same
mechanism built with the Python API (``slider_crank``: its crank pin a prescribed circle
where the study has a rigid crank driven in a revolute joint).
"""
from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest

from gcms_fenicsx.config.system import parse_system
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.references.slider_crank import L1, L2, M3, OMEGA

REPO = Path(__file__).resolve().parents[1]
CONROD_MASS, CONROD_J = 2 * M3, 1.14e-3           # the rigid conrod: mass, J_c,zz (kg m²)

RIGID = f"""
[system]
end_time = 0.05
time_step = 5e-5
record_every = 4

[bodies.crank.rigid]
mass = 0.36
center = [0.075, 0, 0]
inertia = [1e-5, 7e-4, 7e-4]
points = {{pivot = [0, 0, 0], pin = [{L1}, 0, 0]}}

[bodies.conrod]
position = [{L1}, 0, 0]
velocity = [0, {OMEGA * L1 / 2}, 0]
angular_velocity = [0, 0, {-OMEGA * L1 / L2}]

[bodies.conrod.rigid]
mass = {CONROD_MASS}
center = [{L2 / 2}, 0, 0]
inertia = [1.6e-6, {CONROD_J}, {CONROD_J}]
points = {{a = [0, 0, 0], b = [{L2}, 0, 0]}}

[bodies.slider]
point_mass = {M3}
position = [{L1 + L2}, 0, 0]

[[joints]]
name = "main"
type = "revolute"
body = "crank"
point = "pivot"
axis = [0, 0, 1]
drive = {{angular_velocity = {OMEGA}}}

[[joints]]
name = "big_end"
type = "revolute"
body = "crank"
point = "pin"
to_body = "conrod"
to_point = "a"
axis = [0, 0, 1]

[[joints]]
name = "small_end"
type = "spherical"
body = "conrod"
point = "b"
to_body = "slider"

[[joints]]
name = "guide"
type = "prismatic"
body = "slider"
axis = [1, 0, 0]
"""


def test_the_rigid_slider_crank_study_is_the_closed_form(tmp_path):
    """``gcms run`` on a system study of rigid bodies and a point mass (no finite elements):
    the slider follows the rigid slider crank's closed form to round-off (measured 1e-16 m)
    and the force the slider pin applies to the conrod (the closed form's F_B) to 1e-4 of its
    peak from 2 ms (measured 1.9e-5), after the index-3 generalized-α start's transient
    (2.1e-3 of the peak at the first steps, 7e-4 at 1 ms); system.h5 and summary.json
    hold what docs/files.md says, the rigidity rows are not joints."""
    study = tmp_path / "rigid.toml"
    study.write_text(RIGID)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "run", str(study),
                          "--out", str(out)], capture_output=True, text=True, timeout=300,
                         cwd=REPO)
    assert run.returncode == 0, run.stderr
    assert "joint small_end (spherical): peak force" in run.stdout
    from gcms_fenicsx.references.slider_crank_assembly import rigid_closed_form

    with h5py.File(out / "system.h5") as f:
        t, slider = f["time_s"][()], f["bodies/slider/q"][:, 0]
        force = f["joints/small_end/force_n"][()]
        assert sorted(f["joints"]) == ["big_end", "guide", "main", "small_end"]
        assert f["multipliers"].shape == (len(t), len(f["rows/joint"]))
    ref = rigid_closed_form(t, CONROD_MASS, L2 / 2, CONROD_J + CONROD_MASS * (L2 / 2) ** 2)
    assert np.abs(slider - ref["slider_m"]).max() <= 1e-12
    peak = np.abs(ref["pin_force_n"]).max()
    error = np.abs(force[:, :2] - ref["pin_force_n"]).max(axis=1)
    assert error[t >= 2e-3].max() <= 1e-4 * peak
    assert error.max() <= 3e-3 * peak
    assert np.abs(force[:, 2]).max() <= 1e-9 * peak
    summary = json.loads((out / "summary.json").read_text())
    assert summary["kind"] == "system" and summary["coordinates"] == 27
    assert summary["energy_drift_rel"] < 1e-3
    assert summary["joints"]["small_end"]["peak_force_n"] == pytest.approx(
        float(np.linalg.norm(force, axis=1).max()))
    assert not (out / "bodies").exists()


def test_a_system_run_that_stops_early_keeps_its_rows_marked_incomplete(tmp_path):
    """A step that fails (the rigid slider crank at h = 1 ms with two Newton iterations a step:
    its second step does not converge) ends the run as a one-body simulation's: exit status 1,
    one line saying so, system.h5 with the rows up to the last step that converged (the
    start and t = 1 ms), summary.json ``complete`` false with Newton's message, the picture
    drawn."""
    study = tmp_path / "stops.toml"
    study.write_text(RIGID.replace("time_step = 5e-5", "time_step = 1e-3\nmax_iterations = 2"))
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "run", str(study),
                          "--out", str(out)], capture_output=True, text=True, timeout=300,
                         cwd=REPO)
    assert run.returncode == 1, run.stderr
    assert "the simulation stopped early" in run.stderr and "INCOMPLETE" in run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert not summary["complete"] and "Newton did not converge" in summary["message"]
    assert summary["plots"] == ["system_joints.png"]
    with h5py.File(out / "system.h5") as f:
        np.testing.assert_allclose(f["time_s"][()], [0.0, 1e-3], atol=1e-15)
        assert f["bodies/slider/q"].shape == (2, 3)


def test_an_interrupt_while_drawing_keeps_the_published_system_results(tmp_path, monkeypatch,
                                                                       capsys):
    """SIGINT while system_joints.png is drawn (system.h5 and summary.json published): exit
    130 and one line saying the results are in --out, the unfinished picture not there."""
    import signal

    from gcms_fenicsx import cli
    from gcms_fenicsx.app import system_plots
    from gcms_fenicsx.runtime.interrupts import Interrupted

    def interrupted(*args):
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(system_plots, "plot_joints", interrupted)
    study, out = tmp_path / "rigid.toml", tmp_path / "out"
    study.write_text(RIGID)
    status = cli.main(["run", str(study), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 130, err
    assert ("while drawing the pictures; the results are in" in err.splitlines()[-1]
            and "system.h5, summary.json" in err.splitlines()[-1]), err
    assert sorted(p.name for p in out.iterdir()) == ["summary.json", "system.h5"]


def test_joints_refused_after_the_bodies_stages_leave_out_as_it_was(tmp_path):
    """A flexible body's joint refused when the assembly is built (the conrod's slider-pin
    group placed 0.3 m from the slider): one line, exit 2, and --out not created — the
    conrod's stages, computed by then, are not published either."""
    raw = tomllib.loads((REPO / "workflows" / "slider_crank.toml").read_text())
    raw["bodies"]["conrod"]["mesh"]["size"] = 0.004
    del raw["bodies"]["slider"]["align"]
    raw["bodies"]["slider"]["position"] = [0.75, 0.0, 0.0]
    study, out = tmp_path / "apart.toml", tmp_path / "out"
    text = (REPO / "workflows" / "slider_crank.toml").read_text()
    study.write_text(text.replace('[bodies.conrod.mesh]\nsize = 0.003',
                                  '[bodies.conrod.mesh]\nsize = 0.004').replace(
        'align = { to_body = "conrod", to_point = "end_xL" }   # at the conrod\'s slider pin',
        'position = [0.75, 0.0, 0.0]'))
    assert tomllib.loads(study.read_text()) == raw
    run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "run", str(study),
                          "--out", str(out)], capture_output=True, text=True, timeout=600,
                         cwd=REPO)
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines()[-1].startswith("gcms run: error:"), run.stderr
    assert "slider_pin" in run.stderr and "apart" in run.stderr, run.stderr
    assert not out.exists()


@pytest.mark.parametrize("change, joint", [
    ({"joints": [{"name": "guide2", "type": "prismatic", "body": "slider",
                  "axis": [0.0, 1.0, 0.0]}]}, "guide2"),
    ({"slider_mass": 1e-15}, "guide")])
def test_a_row_dropped_at_a_dead_centre_that_stops_holding_ends_the_run(tmp_path, change,
                                                                        joint):
    """The rigid slider crank starts at its dead centre. A second guide across the first
    (the slider locked: no mechanism can turn) has its row dropped there as implied by the
    crank's, and a slider of 1e-15 kg has its guide's row dropped as implied by nothing that
    weighs: neither holds once the crank turns, and the run stops saying so (before: exit
    0, the slider through the second guide or off its own by 0.3–0.45 m), its rows up to
    there kept."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.dynamics.run.study_run import SimulationIncomplete

    raw = tomllib.loads(RIGID)
    raw["joints"] += change.get("joints", [])
    raw["bodies"]["slider"]["point_mass"] = change.get("slider_mass", M3)
    with pytest.raises(SimulationIncomplete, match=f"joint {joint!r}: its row along .* "
                       "dropped at the start .* no longer holds at t = "):
        run_system(parse_system(raw, "dead centre", tmp_path), tmp_path / "out")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert not summary["complete"] and summary["end_time_s"] < 5e-3


#: What the hinged beam's one-body scene and its system body each say for a case: (the
#: scene's extra lines, the study's extra lines, the system body's extra keys).
ONE_BODY_CASES = {
    "svk": ('elasticity = "svk"\n', "", {"elasticity": "svk"}),
    "rotor": ("", '\n[basis]\nkind = "rotor"\n', {}),
    "damped": ("damping = { alpha = 5.0, beta = 1e-4 }\n", "",
               {"damping": {"alpha": 5.0, "beta": 1e-4}}),
    "damped rotor": ("damping = { alpha = 5.0, beta = 1e-4 }\n", '\n[basis]\nkind = "rotor"\n',
                     {"damping": {"alpha": 5.0, "beta": 1e-4}}),
}


@pytest.mark.parametrize("case", ONE_BODY_CASES)
def test_a_body_steps_as_its_one_body_scene(tmp_path, case):
    """The test beam as a pendulum hinged about y at its end face (the system's revolute joint
    to the ground) under gravity, 60 ms at h = 1 ms, against the same beam and joint as a
    one-body study, for a body with ``elasticity = "svk"`` (its reduced model carries the SVK
    coefficients: the implied scene asks for them), in the rotor basis (``[basis] kind =
    "rotor"``: 43 coordinates where the full basis has 111), with Rayleigh ``damping``
    (``[scene.damping]`` there), and damped in the rotor basis: the free end's path agrees to
    1e-12 of the length (the same equations and rows, each Newton to its tolerance; measured
    1e-16 to 4e-16), the energy balanced to 1e-4; the damping's dissipation is the one body's
    to 1e-2 of itself (the one body takes the power at its last Newton iterate, an update
    before the state, whose velocity differs by γ' Δq: measured 8e-4 and 1.3e-3)."""
    from beams import LENGTH, beam_study
    from gcms_fenicsx.app.commands import run, run_system
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.files.reduced_model import read_reduced

    scene_lines, study_lines, body_keys = ONE_BODY_CASES[case]
    joint = 'type = "revolute"\naxis = [0.0, 1.0, 0.0]\n'
    one = tmp_path / "one.toml"
    one.write_text(beam_study(6) + study_lines + f"""
[scene]
end_time = 0.06
time_step = 1e-3
gravity = [0.0, 0.0, -9.81]
outputs = {{ groups = ["end_xL"], every = 1 }}
{scene_lines}
[[scene.joints]]
group = "end_x0"
{joint}""")
    run(one, tmp_path / "one")
    tables = tomllib.loads(beam_study(6) + study_lines)
    raw = {"system": {"end_time": 0.06, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81]},
           "bodies": {"beam": dict(tables, **body_keys)},
           "joints": [{"name": "hinge", "body": "beam", "point": "end_x0",
                       **tomllib.loads(joint)}]}
    run_system(parse_system(raw, case, tmp_path), tmp_path / "system")
    model = read_reduced(tmp_path / "system" / "bodies" / "beam" / "reduced.h5")
    assert (model.svk is not None) == (case == "svk")
    body = body_from_reduced(model)
    tip = body.groups["end_xL"].position
    with h5py.File(tmp_path / "system" / "system.h5") as f:
        path = np.array([tip @ q.reshape(-1, 3) for q in f["bodies/beam/q"][()]])
        dissipated = f["energy/damping_dissipation"][-1]
    with h5py.File(tmp_path / "one" / "results.h5") as f:
        reference = f["groups/end_xL/position"][()]
        one_dissipated = f["energy/damping_dissipation"][-1]
    summary = json.loads((tmp_path / "system" / "summary.json").read_text())
    assert np.abs(path - reference).max() <= 1e-12 * LENGTH
    assert summary["energy_drift_rel"] <= 1e-4
    assert (summary["bodies"]["beam"].get("basis") == "rotor") == ("rotor" in case)
    if "rotor" in case:
        assert summary["coordinates"] < body.dofs / 2
    if "damped" in case:
        assert dissipated > 0 and abs(dissipated - one_dissipated) <= 1e-2 * one_dissipated
    else:
        assert dissipated == 0.0


FRAME = """
[bodies.frame]
rigid = {mass = 5.0, center = [0.2, 0, 0], inertia = [0.1, 0.1, 0.1], points = {mount = [0, 0, 0], rail = [0.3, 0, 0]}}
"""


@pytest.mark.parametrize("slider", ["point mass", "rigid body"])
def test_a_slider_on_a_frames_rail_is_the_closed_form(tmp_path, slider):
    """The rigid slider crank with its guide a joint between two bodies: a rigid frame held to
    the ground by a fixed joint carries the rail, the slider on it in a prismatic joint
    (``relative_rows.on_member_line``; for a rigid slider also ``align_axes`` and
    ``hold_turn``: no relative rotation). The frame does not move, so the slider follows the
    closed form as with its guide to the ground (1e-12 m; measured 1e-16 m), the frame holds
    still (1e-12 m) and the rigid slider does not turn (its A stays I to 1e-12); the rail's
    force on the frame (its first body) is the ground guide's force on the slider, reversed,
    to 1e-8 of its peak (measured 1.6e-9: the Newton iterations differ)."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.references.slider_crank_assembly import rigid_closed_form

    raw = tomllib.loads(RIGID.replace("[bodies.slider]", FRAME + "\n[bodies.slider]"))
    if slider == "rigid body":
        del raw["bodies"]["slider"]["point_mass"]
        raw["bodies"]["slider"]["rigid"] = {"mass": M3, "center": [0.0, 0.0, 0.0],
                                            "inertia": [1e-5, 1e-5, 1e-5],
                                            "points": {"pin": [0.0, 0.0, 0.0]}}
        raw["joints"][2]["to_point"] = "pin"
    raw["joints"][3] = {"name": "guide", "type": "prismatic", "body": "frame", "point": "rail",
                        "to_body": "slider", "axis": [1.0, 0.0, 0.0],
                        **({"to_point": "pin"} if slider == "rigid body" else {})}
    raw["joints"].append({"name": "mount", "type": "fixed", "body": "frame", "point": "mount"})
    cfg = parse_system(raw, "frame", tmp_path)
    run_system(cfg, tmp_path / "out")
    with h5py.File(tmp_path / "out" / "system.h5") as f:
        t, slider_q, frame = f["time_s"][()], f["bodies/slider/q"][()], f["bodies/frame/q"][()]
        rail = f["joints/guide/force_n"][()]
    run_system(parse_system(tomllib.loads(RIGID), "ground", tmp_path), tmp_path / "ground")
    with h5py.File(tmp_path / "ground" / "system.h5") as f:
        guide = f["joints/guide/force_n"][()]
    assert np.abs(guide).max() > 1.0               # the guide carries the conrod's thrust
    np.testing.assert_allclose(rail, -guide, rtol=0, atol=1e-8 * np.abs(guide).max())
    ref = rigid_closed_form(t, CONROD_MASS, L2 / 2, CONROD_J + CONROD_MASS * (L2 / 2) ** 2)
    assert np.abs(slider_q[:, 0] - ref["slider_m"]).max() <= 1e-12
    assert np.abs(frame - frame[0]).max() <= 1e-12
    if slider == "rigid body":                   # x0, then A's rows: no turn
        assert np.abs(slider_q[:, 3:] - np.eye(3).ravel()).max() <= 1e-12


def _rigid(**changes) -> dict:
    raw = tomllib.loads(RIGID)
    for path, value in changes.items():
        *keys, last = path.split(".")
        table = raw
        for key in keys:
            table = table[int(key)] if isinstance(table, list) else table[key]
        if value is None:
            del table[last]
        else:
            table[last] = value
    return raw


#: An [engine] on the rigid slider crank: its slider the piston, its main joint the drive.
ENGINE_OF_RIGID = {"pistons": ["slider"], "bore": 0.05, "towards_crank": [-1.0, 0.0, 0.0],
                   "crank_drive": "main"}


def test_numbers_decades_apart_end_in_one_line_and_leave_out_as_it_was(tmp_path):
    """A point mass of 1e300 kg beside bodies of grams makes the assembly's matrices singular
    in floating point: a ComputationFailed naming what to look for (exit status 1, one line),
    not a LinAlgError's traceback, and --out not created."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.runtime.errors import ComputationFailed

    raw = _rigid(**{"bodies.slider.point_mass": 1e300})
    with pytest.raises(ComputationFailed, match="the assembly could not be solved .* a mass"):
        run_system(parse_system(raw, "heavy", tmp_path), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_huge_and_tiny_directions_are_directions():
    """An axis or towards_crank is normalised without over- or underflow."""
    raw = _rigid(**{"joints.0.axis": [0.0, 0.0, 1e-300],
                    "engine": dict(ENGINE_OF_RIGID, towards_crank=[-1e300, 1e300, 0.0])})
    cfg = parse_system(raw, "test")
    assert cfg.joints[0].axis == (0.0, 0.0, 1.0)
    np.testing.assert_allclose(cfg.engine.towards_crank, [-0.5 ** 0.5, 0.5 ** 0.5, 0.0],
                               rtol=1e-15)


@pytest.mark.parametrize("changes, where, says", [
    ({"scene": {}}, "[scene]", "unknown table in a system study"),
    ({"system.time_step": 1.0}, "[system] time_step", "must be in [end_time / 1e+08, end_time]"),
    ({"system.time_step": 1e-300}, "[system] time_step", "must be in [end_time / 1e+08"),
    ({"joints.0.body": ["crank"]}, "[joints[0]] body", "must be one of the bodies"),
    ({"bodies.slider.position": None,
      "bodies.slider.align": {"point": "q", "to_body": "conrod", "to_point": "b"}},
     "[bodies.slider.align] point", "'slider' is a point mass: it is its own point"),
    ({"joints.1.to_body": ["conrod"]}, "[joints[1]] to_body", "or another body"),
    ({"engine": dict(ENGINE_OF_RIGID, crank_drive=["main"])}, "[engine] crank_drive",
     "must be a joint with a drive"),
    ({"engine": dict(ENGINE_OF_RIGID, bore=1e200)}, "[engine] bore", "must be > 0 and <= 10"),
    ({"bodies.slider.rigid": {"mass": 1.0}}, "[bodies.slider] point_mass", "a body is one of"),
    ({"bodies.crank.rigid": None}, "[bodies.crank]", "a body needs study = PATH"),
    ({"bodies.conrod.rigid.points": {}}, "[bodies.conrod.rigid] points", "name at least one"),
    ({"bodies.conrod.rigid.inertia": [1, 2]}, "[bodies.conrod.rigid] inertia", "3 × 3"),
    ({"joints.0.body": "piston"}, "[joints[0]] body", "must be one of the bodies"),
    ({"joints.1.to_point": "c"}, "to_point", "is not a point of 'conrod'; its points are a, b"),
    ({"joints.2.type": "revolute"}, "type", "a point mass has no rotation"),
    ({"joints.3.type": "fixed"}, "type", "a point mass has no rotation"),
    ({"joints.3.to_body": "conrod", "joints.3.to_point": "b"}, "type",
     "a point mass has no rotation"),
    ({"joints.1.drive": {"angular_velocity": 1.0}}, "drive", "a drive turns a revolute joint "
                                                               "to the ground"),
    ({"joints.2.to_point": "b"}, "to_point", "is a point mass: it is its own point"),
    ({"joints.1.name": "main"}, "[[joints]] name", "joint names must be unique"),
    ({"joints.0.axis": [0, 0, 0]}, "axis", "must be a non-zero vector"),
    ({"bodies.crank.align": {"to_body": "slider"}}, "[bodies.crank.align] to_body",
     "must be a body listed above this one: (none)"),
    ({"bodies.slider.align": {"to_body": "conrod", "to_point": "b"}},
     "[bodies.slider] align", "give position or align, not both"),
    ({"bodies.conrod.study": "missing.toml", "bodies.conrod.rigid": None},
     "[bodies.conrod] study", "cannot be read"),
])
def test_a_system_study_refuses_what_it_cannot_run(changes, where, says, tmp_path):
    """Each refusal names the table and key, the value and what is allowed."""
    with pytest.raises(ConfigError) as caught:
        parse_system(_rigid(**changes), "test", tmp_path)
    assert where in str(caught.value) and says in str(caught.value), str(caught.value)


def test_a_body_of_a_system_study_refuses_the_static_shapes():
    """The crank train's crankshaft asking for the static shapes: refused naming the body,
    the key and what is allowed (before, the run stepped the full basis of its modes and said
    nothing)."""
    raw = tomllib.loads((REPO / "workflows" / "crank_train.toml").read_text())
    raw["bodies"]["crankshaft"]["basis"]["shapes"] = "static"
    with pytest.raises(ConfigError) as caught:
        parse_system(raw, "train", REPO / "workflows")
    said = str(caught.value)
    assert "body 'crankshaft'" in said and "[basis] shapes = 'static'" in said, said
    assert '"modes"' in said and "deforms along its modes" in said, said


def _beam_on(kind: str, joints: list, rotation: dict | None = None) -> dict:
    """The test beam (``[basis] kind``) with a rigid arm driven about x at the ground."""
    from beams import beam_study

    beam = dict(tomllib.loads(beam_study(6)), basis={"kind": kind})
    if rotation:
        beam["rotation"] = rotation
    arm = {"mass": 1.0, "center": [0.0, 0.0, 0.0], "inertia": [0.1, 0.1, 0.1],
           "points": {"hub": [0.0, 0.0, 0.0], "tip": [0.0, 0.0, 0.0]}}
    return {"system": {"end_time": 0.01, "time_step": 1e-3},
            "bodies": {"arm": {"rigid": arm}, "beam": beam},
            "joints": [{"name": "drive", "type": "revolute", "body": "arm", "point": "hub",
                        "axis": [1.0, 0.0, 0.0], "drive": {"angular_velocity": 10.0}}] + joints}


#: The beam hinged about z to the driven arm only (it turns about x and z), or to the ground.
ON_THE_ARM = [{"name": "pin", "type": "revolute", "body": "beam", "point": "end_x0",
               "to_body": "arm", "to_point": "tip", "axis": [0.0, 0.0, 1.0]}]
TO_THE_GROUND = [{"name": "pin", "type": "revolute", "body": "beam", "point": "end_x0",
                  "axis": [0.0, 0.0, 1.0]}]


@pytest.mark.parametrize("joints, rotation, says, reason", [
    (ON_THE_ARM, None, "needs joints to the ground that leave the body turning",
     "no joint holds it to the ground"),
    (TO_THE_GROUND, {"axis": [0.0, 1.0, 0.0], "angle": 90.0},
     "its rotation turns it about another axis than its rotor axis",
     "turns it about another axis"),
])
def test_the_rotor_basis_is_chosen_by_a_bodys_joints_to_the_ground(tmp_path, joints, rotation,
                                                                   says, reason):
    """``[basis] kind = "rotor"`` on a body its joints to the ground do not hold to one axis
    (hinged only to a body that turns about another: before, the implied scene read every
    joint as one to the ground, chose the rotor basis, and Newton failed at 42 ms), or placed
    turned about another axis than its rotor axis (before: refused only after its model was
    built, naming the wrong key): refused when the study is read, naming the body, the key and
    why; ``"auto"`` steps it in the full basis, saying why. Hinged to the ground about its own
    axis, both choose the rotor basis."""
    from gcms_fenicsx.config.system import FlexibleSpec

    with pytest.raises(ConfigError) as caught:
        parse_system(_beam_on("rotor", joints, rotation), "t", tmp_path)
    said = str(caught.value)
    assert "body 'beam'" in said and "[basis] kind = 'rotor'" in said and says in said, said
    beam = next(b for b in parse_system(_beam_on("auto", joints, rotation), "t", tmp_path).bodies
                if isinstance(b, FlexibleSpec))
    assert beam.basis.kind == "full" and beam.rotor_scene is None
    assert reason in beam.basis.reason, beam.basis.reason
    for kind in ("rotor", "auto"):
        beam = next(b for b in parse_system(_beam_on(kind, TO_THE_GROUND), "t", tmp_path).bodies
                    if isinstance(b, FlexibleSpec))
        assert beam.basis.kind == "rotor" and beam.basis.axis == (0.0, 0.0, 1.0)
        assert [j.name for j in beam.rotor_scene.joints] == ["end_x0"]


def test_joints_that_do_not_meet_are_refused_naming_them(tmp_path):
    """A joint whose points start apart (the conrod placed 1 cm off its crank pin) is refused
    before any step, naming the joint and the gap (``assemble``)."""
    from gcms_fenicsx.app.system_run import simulate_system

    cfg = parse_system(_rigid(**{"bodies.conrod.position": [L1 + 0.01, 0, 0]}), "t", tmp_path)
    with pytest.raises(ConfigError, match="joint 'big_end': its points are"):
        simulate_system(cfg, {}, tmp_path, lambda line: None)


def test_the_flexible_slider_crank_study_is_the_python_assembly(tmp_path):
    """``workflows/slider_crank.toml`` (a 4 mm conrod mesh, 30 ms): the conrod's own stages run
    in --out/bodies/conrod with the attachment modes of the groups the system's joints hold
    (the study's scene is the one they imply), and its midpoint deflection is the Python
    assembly's (``references.slider_crank_assembly.slider_crank``, the crank pin a prescribed
    circle) on the same reduced model to 1e-4 of the peak (two formulations of one mechanism,
    equal but for Newton's tolerance: measured 2e-6 over the 0.1 s run). A second run reuses
    the conrod's stages."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.system.march import march
    from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state
    from gcms_fenicsx.files.reduced_model import read_reduced
    from gcms_fenicsx.references import slider_crank_assembly as sca

    raw = tomllib.loads((REPO / "workflows" / "slider_crank.toml").read_text())
    raw["bodies"]["conrod"]["mesh"]["size"] = 0.004
    raw["system"]["end_time"] = 0.03
    cfg = parse_system(raw, "slider_crank.toml", REPO / "workflows")
    out = tmp_path / "out"
    text = run_system(cfg, out)
    assert "joint slider_pin (spherical)" in text
    body = body_from_reduced(read_reduced(out / "bodies" / "conrod" / "reduced.h5"))
    probe = sca.midpoint_deflection(body)
    with h5py.File(out / "system.h5") as f:
        t, q = f["time_s"][()], f["bodies/conrod/q"][()]
    study = np.array([probe(SimpleNamespace(q=x)) for x in q])
    assembly = sca.slider_crank(body)
    stepper = AssemblyStepper(assembly, StepSettings(cfg.time_step_s))
    api = march(stepper, initial_state(stepper, sca.rigid_start_velocity(assembly)), 0.03,
                every=cfg.record_every, probes={"d": probe})
    np.testing.assert_array_equal(t, api.time_s)
    peak = np.abs(api.probes["d"]).max()
    assert peak > 5e-4                        # the conrod bends (2 mm peak over the full run)
    assert np.abs(study - api.probes["d"]).max() <= 1e-4 * peak
    summary = json.loads((out / "summary.json").read_text())
    assert summary["bodies"]["conrod"]["coordinates"] == body.dofs
    run_system(cfg, out)
    again = json.loads((out / "summary.json").read_text())
    assert again["stages"]["conrod"]["reduction"]["status"] == "reused", again["stages"]



def test_a_system_study_runs_with_a_flexible_body_full_order(tmp_path):
    """``system_run.full_order_body`` and ``build_system(..., full_order)``: the slider crank
    study (conrod mesh 4 mm, 10 ms) with its conrod on every node of its mesh (reference (a),
    F = I, a sparse LU) against the same study reduced: the midpoint deflection agrees to
    1e-3 of its peak (GCMS with the pins' attachment modes follows (a) to 1e-4 of the peak
    over the 0.1 s run on the 3 mm mesh, docs/slider_crank.md; measured 1.1e-4 here), and
    both balance their energy to 1e-4."""
    from mpi4py import MPI

    from gcms_fenicsx.app.commands import system_models
    from gcms_fenicsx.app.system_run import build_system, full_order_body, start_velocity
    from gcms_fenicsx.dynamics.system.march import march
    from gcms_fenicsx.dynamics.system.stepper import initial_state
    from gcms_fenicsx.references import slider_crank_assembly as sca

    raw = tomllib.loads((REPO / "workflows" / "slider_crank.toml").read_text())
    raw["bodies"]["conrod"]["mesh"]["size"] = 0.004
    cfg = parse_system(raw, "slider_crank.toml", REPO / "workflows")
    with system_models(cfg, tmp_path, False, MPI.COMM_WORLD, lambda line: None) as built:
        models = built[0]
    full = full_order_body(cfg.body("conrod"), tmp_path / "full", lambda line: None)
    runs = {}
    for label, replaced in (("gcms", None), ("full", {"conrod": full})):
        made, assembly, stepper = build_system(cfg, models, replaced)
        rod = next(m for m in made if m.name == "conrod")
        where = assembly.offsets["conrod"]
        probe = sca.midpoint_deflection(rod.body)
        runs[label] = march(stepper, initial_state(stepper, start_velocity(cfg, made)), 0.01,
                            every=5, probes={"d": lambda s: probe(SimpleNamespace(q=s.q[where]))})
        assert runs[label].energy_drift_rel <= 1e-4, (label, runs[label].energy_drift_rel)
    assert full.dofs == full.nodes_m.size                 # every node its own field
    peak = np.abs(runs["full"].probes["d"]).max()
    assert peak > 5e-4
    assert np.abs(runs["gcms"].probes["d"] - runs["full"].probes["d"]).max() <= 1e-3 * peak

ENGINE = """
[system]
end_time = {end}
time_step = 2e-5
record_every = 10

[bodies.crank.rigid]
mass = 2.0
center = [0, 0, 0.01]
inertia = [2e-3, 1.5e-3, 1.5e-3]
points = {{main = [0, 0, 0], pin = [0, 0, {r}]}}

[bodies.conrod]
rotation = {{axis = [0, 1, 0], angle = -90.0}}
align = {{point = "big_end", to_body = "crank", to_point = "pin"}}

[bodies.conrod.rigid]
mass = 0.5
center = [0.04, 0, 0]
inertia = [1e-4, 1.5e-3, 1.5e-3]
points = {{big_end = [0, 0, 0], small_end = [{L}, 0, 0]}}

[bodies.piston]
point_mass = 0.4
align = {{to_body = "conrod", to_point = "small_end"}}

[[joints]]
name = "main_bearing"
type = "revolute"
body = "crank"
point = "main"
axis = [1, 0, 0]
drive = {{angular_velocity = {omega}}}

[[joints]]
name = "big_end"
type = "revolute"
body = "crank"
point = "pin"
to_body = "conrod"
to_point = "big_end"
axis = [1, 0, 0]

[[joints]]
name = "small_end"
type = "spherical"
body = "conrod"
point = "small_end"
to_body = "piston"

[[joints]]
name = "bore"
type = "prismatic"
body = "piston"
axis = [0, 0, 1]

[engine]
pistons = ["piston"]
bore = {bore}
towards_crank = [0, 0, -1]
crank_drive = "main_bearing"
"""


def test_a_single_cylinder_engine_study_takes_the_gas_work_of_its_cycle(tmp_path):
    """``[engine]`` with the built-in full-load curve on a rigid single-cylinder engine driven
    at 3000 rpm, over one four-stroke cycle (720°, 40 ms): the gas's work on the piston
    (``energy/load_work``) is ∮ (p(φ) − 1 bar) A dx_p over the mechanism's exact kinematics
    (``gas_pressure.indicated_work_j``, itself checked against ∮ p dV) to 1e-4 (the run's
    trapezoidal power integral at h = 20 µs; measured 4.7e-6 of 500.8 J, an IMEP of 11.03
    bar), the piston follows x_p = r cos θ + √(L² − r² sin² θ) to 1e-9 m, and the drive
    takes the work out: the joints' work is its negative but for the kinetic energy's change
    (measured 7e-5 J), and so is the drive torque's ∫ τ ω dt over the recorded rows (the
    trapezoidal rule on every 10th step: measured 3.7e-4 of the work, asserted 1e-3). The
    recorded crank angle is ω t, the gas force the curve's at it."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.dynamics.system.gas_pressure import (indicated_work_j, petrol_full_load,
                                                            piston_force_n)

    r, L, bore, omega = 0.043, 0.145, 0.082, 100 * np.pi
    end = 4 * np.pi / omega
    raw = tomllib.loads(ENGINE.format(end=end, r=r, L=L, omega=omega, bore=bore))
    cfg = parse_system(raw, "engine", tmp_path)
    run_system(cfg, tmp_path / "out")
    with h5py.File(tmp_path / "out" / "system.h5") as f:
        t, work = f["time_s"][()], f["energy/load_work"][()]
        rows, kinetic = f["energy/row_work"][()], f["energy/kinetic"][()]
        piston = f["bodies/piston/q"][()]
        torque = f["joints/main_bearing/drive_torque_nm"][()]
        angle, gas = f["engine/crank_angle_deg"][()], f["engine/gas_force_n"][()]
    assert t[-1] == pytest.approx(end, rel=1e-9)
    expected = indicated_work_j(petrol_full_load(), bore, r, L)
    assert expected > 0                          # the cycle's indicated work
    assert work[-1] == pytest.approx(expected, rel=1e-4)
    theta = np.linspace(0.0, 4 * np.pi, 72_001)
    x = r * np.cos(theta) + np.sqrt(L ** 2 - (r * np.sin(theta)) ** 2)
    np.testing.assert_allclose(piston[:, 2] - piston[0, 2] + r + L,
                               np.interp(omega * t, theta, x), atol=1e-9)
    assert abs(rows[-1] + work[-1] - (kinetic[-1] - kinetic[0])) <= 1e-6 * expected
    np.testing.assert_allclose(angle, np.degrees(omega * t), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(gas[:, 0], piston_force_n(petrol_full_load(), bore, angle),
                               rtol=1e-12, atol=1e-9)
    drive_work = float(np.sum(0.5 * (torque[1:] + torque[:-1]) * omega * np.diff(t)))
    assert drive_work == pytest.approx(rows[-1], rel=1e-3)


def test_identical_bodies_share_one_reduced_model_and_move_alike(tmp_path):
    """Two pendulums of one inline beam study, each pinned at its end face to the ground about
    y and placed 1 m apart: the second body takes the first's reduced model (its stages are
    not run: ``stages`` says whose model it is) and, started alike, swings exactly as the
    first but for the offset (the members are stepped in one state: 1e-12 m)."""
    from gcms_fenicsx.app.commands import run_system

    beam = {"geometry": {"kind": "beam", "section": "square", "side": 0.02, "length": 0.4},
            "mesh": {"size": 0.01}, "modes": {"count": 4}, "basis": {"attachment": "scene"}}
    raw = {"system": {"end_time": 0.02, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81]},
           "bodies": {"left": beam, "right": {**beam, "position": [0.0, 1.0, 0.0]}},
           "joints": [{"name": f"pin_{side}", "type": "revolute", "body": side,
                       "point": "end_x0", "axis": [0.0, 1.0, 0.0]}
                      for side in ("left", "right")]}
    cfg = parse_system(raw, "pendulums", tmp_path)
    assert cfg.body("left").model_key == cfg.body("right").model_key
    out = tmp_path / "out"
    run_system(cfg, out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stages"]["right"] == {"model_of": "left"}
    assert not (out / "bodies" / "right").exists()
    with h5py.File(out / "system.h5") as f:
        left, right = f["bodies/left/q"][()], f["bodies/right/q"][()]
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.files.reduced_model import read_reduced

    unit = body_from_reduced(read_reduced(out / "bodies" / "left" / "reduced.h5")).unit
    shift = np.outer(unit, [0.0, 1.0, 0.0]).ravel()
    assert np.abs(left[-1] - left[0]).max() > 1e-6           # they swing
    np.testing.assert_allclose(right - shift, left, rtol=0, atol=1e-12)


def test_a_flexible_body_as_rigid_is_its_rigid_twin(tmp_path):
    """``as_rigid = true`` steps the conrod of ``workflows/slider_crank.toml`` as the rigid body
    of its mass properties (``rigid.rigid_twin``): the slider and the slider-pin force follow
    the closed form of a rigid conrod with the 3D conrod's mass, centre and inertia
    (``rigid_reference``): the slider to 1e-12 m, the force to 1e-4 of its peak from 2 ms (the
    rigid study above: 1.9e-5)."""
    from gcms_fenicsx.app.commands import run_system
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.files.reduced_model import read_reduced
    from gcms_fenicsx.references.slider_crank_assembly import rigid_reference

    raw = tomllib.loads((REPO / "workflows" / "slider_crank.toml").read_text())
    raw["bodies"]["conrod"] |= {"as_rigid": True, "mesh": {"size": 0.004}}
    raw["system"] |= {"end_time": 0.03, "time_step": 5e-5}
    out = tmp_path / "out"
    run_system(parse_system(raw, "slider_crank.toml", REPO / "workflows"), out)
    body = body_from_reduced(read_reduced(out / "bodies" / "conrod" / "reduced.h5"))
    with h5py.File(out / "system.h5") as f:
        t, slider = f["time_s"][()], f["bodies/slider/q"][:, 0]
        force = f["joints/slider_pin/force_n"][()]
        assert f["bodies/conrod/q"].shape[1] == 12           # a rigid body's coordinates
    ref = rigid_reference(body, t)
    assert np.abs(slider - ref["slider_m"]).max() <= 1e-12
    error = np.abs(force[:, :2] - ref["pin_force_n"]).max(axis=1)
    assert error[t >= 2e-3].max() <= 1e-4 * np.abs(ref["pin_force_n"]).max()
    assert json.loads((out / "summary.json").read_text())["bodies"]["conrod"]["kind"] == "rigid"
