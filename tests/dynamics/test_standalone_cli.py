"""``python -m gcms_fenicsx.dynamics`` end to end on the committed six-mode test beam: the
integrator without the finite-element stack, bad input (one line, exit status 2, nothing
lost) and a results file of a newer schema. The same through ``gcms simulate``, which needs
the stack, is ``tests/test_simulate_cli.py``."""
from __future__ import annotations

import json
import re
import subprocess
import sys

import h5py
import numpy as np
import pytest

from gcms_fenicsx.files.results import (RESULTS_SCHEMA_VERSION, ResultsError, Trajectory,
                                           read_results, write_results)
from gcms_fenicsx.files.reduced_model import read_reduced
from simulate_runs import (BAD_SCENES, FE_STACK, REPO, SCENE, assert_one_line_error, contents,
                           non_finite_copy, output_folder, standalone, study)


@pytest.fixture
def reduced(beam6_file):
    """reduced.h5 of the six-mode test beam (committed; tests only read or copy it)."""
    return beam6_file


# -- 6. the standalone integrator ------------------------------------------------------------

BOOTSTRAP = '''
import sys
BLOCKED = set(sys.argv[1].split(","))
preloaded = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
assert not preloaded, f"already imported before the blocker: {preloaded}"


class NoFiniteElements:
    """Refuse every module of the finite-element stack, as on a machine without it."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{name} is not installed here")
        return None


sys.meta_path.insert(0, NoFiniteElements())
try:
    import mpi4py  # noqa: F401
except ImportError:
    pass
else:
    raise AssertionError("the blocker does not work")

import runpy
sys.argv = ["python -m gcms_fenicsx.dynamics", *sys.argv[2:]]
try:
    runpy.run_module("gcms_fenicsx.dynamics", run_name="__main__", alter_sys=True)
finally:
    loaded = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
    print("LOADED=" + ",".join(loaded), file=sys.stderr)
'''


def test_standalone_integrator_runs_without_the_finite_element_stack(reduced, tmp_path):
    """Item 6: with dolfinx, ufl, basix, ffcx, petsc4py, slepc4py, mpi4py, gmsh and scipy made
    unimportable (a meta-path finder installed before anything imports them),
    ``python -m gcms_fenicsx.dynamics REDUCED.h5 STUDY.toml --out DIR`` simulates the
    cantilever and writes a complete, readable results.h5 and summary.json carrying the
    reduced model's input hash; none of those modules was imported."""
    script = tmp_path / "bootstrap.py"
    script.write_text(BOOTSTRAP)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, str(script), ",".join(FE_STACK), str(reduced),
                          str(study(tmp_path)), "--out", str(out)],
                         cwd=REPO, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "LOADED=\n" in run.stderr
    assert "note:" not in run.stderr        # the model is the study's (its input hash)
    traj = read_results(out / "results.h5")
    assert traj.complete and traj.message == ""
    assert traj.time[-1] == pytest.approx(0.01)
    assert traj.groups["end_xL"]["position"].shape == (11, 3)
    assert traj.model_hash == read_reduced(reduced).input_hash
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] and summary["steps"] == 10
    assert sorted(p.name for p in out.iterdir()) == ["results.h5", "summary.json"]


def test_a_model_made_without_the_attachment_modes_the_study_asks_for_is_noted(reduced,
                                                                             tmp_path):
    """The committed beam holds no attachment modes; a study whose [basis] attachment is the
    default "auto" (with the clamp's scene) asks for them: the run goes on with the model as
    it is and says so in one note naming the key and its value."""
    config = study(tmp_path, SCENE.replace('attachment = "none"', 'attachment = "auto"'))
    run = standalone(str(reduced), str(config), "--out", str(tmp_path / "out"))
    assert run.returncode == 0, run.stderr
    [note] = [line for line in run.stderr.splitlines() if "note:" in line]
    assert "was made from other" in note and "holds no attachment modes" in note
    assert "[basis] attachment = 'auto'" in note and "simulated as it is" in note


# -- 7. bad input --------------------------------------------------------------------------

@pytest.mark.parametrize("case", BAD_SCENES)
def test_bad_scene_is_one_clear_line_and_changes_nothing(reduced, tmp_path, case):
    """Bad [scene] input — time_step = 0, rho_inf outside 0..1, a zero joint axis, no [scene]
    at all — ends with exit status 2 and one line naming the key, for the standalone
    integrator (``gcms simulate``: tests/test_simulate_cli.py), before anything is computed;
    the output folder (the user's file, the cached model) is left as it was."""
    scene, key = BAD_SCENES[case]
    config = study(tmp_path, scene)
    out = output_folder(tmp_path, reduced)
    before = contents(out)
    run = standalone(str(reduced), str(config), "--out", str(out))
    assert_one_line_error(run, key)
    assert contents(out) == before


def test_non_finite_reduced_model_is_refused(reduced, tmp_path):
    """A reduced.h5 written with a NaN in Kr (checksums that fit it, so the content check must
    catch it): the standalone integrator refuses it with exit status 2 and one line naming the
    file, the dataset and what is wrong; the output folder is unchanged. (``gcms simulate``
    rebuilds such a cache: tests/test_simulate_cli.py.)"""
    damaged = non_finite_copy(reduced, tmp_path / "damaged.h5")
    out = output_folder(tmp_path)
    before = contents(out)
    run = standalone(str(damaged), str(study(tmp_path)), "--out", str(out))
    assert_one_line_error(run, str(damaged), "/stiffness", "non-finite")
    assert contents(out) == before


def test_results_file_of_a_newer_schema_is_refused(tmp_path):
    """read_results reads back what write_results wrote, and refuses a file of a newer
    schema with a ResultsError naming the file and both schema versions."""
    traj = Trajectory(time=np.linspace(0.0, 1.0, 5), newton_iterations=np.arange(5),
                      groups={"tip": {"position": np.ones((5, 3)), "velocity": np.zeros((5, 3))}},
                      energy={"kinetic": np.arange(5.0)}, momentum={"linear": np.zeros((5, 3))},
                      multipliers=np.zeros((5, 1)),
                      rows=[{"joint": "j", "kind": "force", "axis": [1, 0, 0], "unit": "N"}],
                      complete=False, message="stopped", model_hash="abc")
    path = tmp_path / "results.h5"
    write_results(path, traj)
    back = read_results(path)
    np.testing.assert_array_equal(back.groups["tip"]["position"], traj.groups["tip"]["position"])
    assert (back.complete, back.message, back.rows) == (False, "stopped", traj.rows)
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = RESULTS_SCHEMA_VERSION + 1
    with pytest.raises(ResultsError, match=f"{re.escape(str(path))}.*newer.*schema "
                                           f"{RESULTS_SCHEMA_VERSION + 1}.*up to "
                                           f"{RESULTS_SCHEMA_VERSION}"):
        read_results(path)


# -- 7. simulations that stop early --------------------------------------------------------

def test_initial_mode_amplitude_that_inverts_the_body_is_a_clear_error(reduced, tmp_path):
    """initial = { mode = 3, amplitude = 10 } (10 m on a 0.5 m beam) turns the body's affine
    map inside out already at t = 0. That is bad input and ends like any other (exit status 2,
    one line naming [scene.initial]), not in the InvertedBodyError traceback it once was."""
    scene = SCENE.replace("time_step = 1e-3",
                          "time_step = 1e-3\ninitial = { mode = 3, amplitude = 10.0 }")
    out = output_folder(tmp_path)
    before = contents(out)
    run = standalone(str(reduced), str(study(tmp_path, scene)), "--out", str(out))
    assert_one_line_error(run, "[scene.initial]")
    assert contents(out) == before
