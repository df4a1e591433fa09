"""``gcms simulate`` and ``python -m gcms_fenicsx.dynamics`` end to end: the integrator without
the finite-element stack, the cached reduced model, bad input (one line, exit status 2,
nothing lost) and simulations that stop early (exit status 1, results kept, incomplete)."""
from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import REPO, gcms
from gcms_fenicsx.dynamics.results import (RESULTS_SCHEMA_VERSION, ResultsError, Trajectory,
                                           read_results, write_results)
from gcms_fenicsx.files.reduced_model import read_reduced
from gcms_fenicsx.files.versioned import seal
from test_dynamics import beam_study

#: A cantilever under gravity for 10 ms: cheap, with joints, loads and every output.
SCENE = """
[scene]
end_time = 0.01
time_step = 1e-3
gravity = [0.0, 0.0, -9.81]
outputs = { groups = ["end_xL"] }

[[scene.joints]]
type = "fixed"
group = "end_x0"
name = "clamp"
"""

#: Modules the standalone integrator must do without.
FE_STACK = ("dolfinx", "ufl", "basix", "ffcx", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy")


def standalone(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "gcms_fenicsx.dynamics", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=600)


@pytest.fixture
def reduced(beam6_reduced):
    """reduced.h5 of the six-mode test beam (shared by the session; tests only read or copy it)."""
    return beam6_reduced


def study(tmp_path, scene: str = SCENE, name: str = "study.toml", count: int = 6):
    path = tmp_path / name
    path.write_text(beam_study(count) + scene)
    return path


def output_folder(tmp_path, reduced=None, name: str = "out"):
    """An output folder holding a file of the user's, and the cached reduced model if given
    (same upstream tables as :func:`study`, so ``gcms simulate`` reuses it)."""
    out = tmp_path / name
    out.mkdir()
    (out / "notes.txt").write_text("the user's own file\n")
    if reduced is not None:
        shutil.copy2(reduced, out / "reduced.h5")
    return out


def contents(folder) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def assert_one_line_error(run: subprocess.CompletedProcess, *needles: str) -> None:
    """Exit status 2 and, besides progress lines ("[   0.1 s] ..."), one line: the error."""
    assert run.returncode == 2, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr, run.stderr
    lines = [line for line in run.stderr.splitlines() if not line.startswith("[")]
    assert len(lines) == 1 and "error" in lines[0], run.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


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
    traj = read_results(out / "results.h5")
    assert traj.complete and traj.message == ""
    assert traj.time[-1] == pytest.approx(0.01)
    assert traj.groups["end_xL"]["position"].shape == (11, 3)
    assert traj.model_hash == read_reduced(reduced).input_hash
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] and summary["steps"] == 10
    assert sorted(p.name for p in out.iterdir()) == ["results.h5", "summary.json"]


# -- 8. the cached reduced model ---------------------------------------------------------------

def test_simulate_reuses_the_reduced_model_until_an_upstream_table_changes(tmp_path):
    """Item 8: the first ``gcms simulate`` builds reduced.h5 (eigen-solve) and writes results,
    summary and plots; changing only [scene] reuses reduced.h5 (no eigen-solve, file not
    rewritten); changing [material] E rebuilds it, and the new frequencies are the old ones
    × √(E'/E) (K ∝ E on the same mesh, M unchanged) to the eigen-solver's accuracy."""
    out = tmp_path / "out"
    config = study(tmp_path)
    first = gcms("simulate", str(config), "--out", str(out))
    assert first.returncode == 0, first.stderr
    assert "eigen-solve" in first.stderr and "reusing" not in first.stderr
    assert {"reduced.h5", "results.h5", "summary.json", "trajectory.png",
            "energy.png"} <= {p.name for p in out.iterdir()}
    assert read_results(out / "results.h5").complete
    model = read_reduced(out / "reduced.h5")
    stamp = (out / "reduced.h5").stat().st_mtime_ns

    config.write_text(config.read_text().replace("end_time = 0.01", "end_time = 0.02"))
    second = gcms("simulate", str(config), "--out", str(out))
    assert second.returncode == 0, second.stderr
    assert "reusing" in second.stderr
    assert "eigen-solve" not in second.stderr and "assembled" not in second.stderr
    assert (out / "reduced.h5").stat().st_mtime_ns == stamp
    assert read_results(out / "results.h5").time[-1] == pytest.approx(0.02)

    config.write_text(config.read_text().replace("[modes]", "[material]\nE = 105e9\n\n[modes]"))
    third = gcms("simulate", str(config), "--out", str(out))
    assert third.returncode == 0, third.stderr
    assert "made from other inputs; rebuilding" in third.stderr and "eigen-solve" in third.stderr
    softer = read_reduced(out / "reduced.h5")
    assert softer.input_hash != model.input_hash
    np.testing.assert_allclose(softer.frequencies_hz, model.frequencies_hz * math.sqrt(0.5),
                               rtol=1e-8)


# -- 7. bad input --------------------------------------------------------------------------

def test_unknown_group_fails_before_the_eigen_solve(reduced, tmp_path):
    """A joint on a group the body does not have: ``gcms simulate`` stops with exit status 2
    and one line naming the joint and the group, after meshing but before assembly and the
    eigen-solve when there is no cached model, and at once with one; nothing in the output
    folder changes (the user's file, the cached model) and nothing is added."""
    bad = SCENE.replace('group = "end_x0"', 'group = "end_x9"')
    config = study(tmp_path, bad)
    for cached in (None, reduced):
        out = output_folder(tmp_path, cached, name="out" if cached is None else "cached")
        before = contents(out)
        run = gcms("simulate", str(config), "--out", str(out))
        assert_one_line_error(run, "joints[0]", "'end_x9'", "end_x0, end_xL")
        assert "assembled" not in run.stderr and "eigen-solve" not in run.stderr
        assert contents(out) == before


@pytest.mark.parametrize("tool", ["gcms simulate", "python -m gcms_fenicsx.dynamics"],
                         ids=["gcms", "standalone"])
@pytest.mark.parametrize("scene, key", [
    (SCENE.replace("time_step = 1e-3", "time_step = 0"), "[scene] time_step"),
    (SCENE.replace("time_step = 1e-3", "time_step = 1e-3\nrho_inf = 1.5"), "[scene] rho_inf"),
    (SCENE.replace('name = "clamp"', 'name = "clamp"\naxis = [0, 0, 0]'),
     "[scene.joints[0]] axis"),
    ("", "[scene]"),
], ids=["time_step=0", "rho_inf=1.5", "zero_axis", "no_scene"])
def test_bad_scene_is_one_clear_line_and_changes_nothing(reduced, tmp_path, tool, scene, key):
    """Bad [scene] input — time_step = 0, rho_inf outside 0..1, a zero joint axis, no [scene]
    at all — ends with exit status 2 and one line naming the key, for both the command and
    the standalone integrator, before anything is computed; the output folder (the user's
    file, the cached model) is left as it was."""
    config = study(tmp_path, scene)
    out = output_folder(tmp_path, reduced)
    before = contents(out)
    if tool == "gcms simulate":
        run = gcms("simulate", str(config), "--out", str(out))
    else:
        run = standalone(str(reduced), str(config), "--out", str(out))
    assert_one_line_error(run, key)
    assert contents(out) == before


def test_non_finite_reduced_model_is_refused(reduced, tmp_path):
    """A reduced.h5 written with a NaN in Kr (checksums that fit it, so the content check must
    catch it): the standalone integrator refuses it with exit status 2 and one line naming the
    file, the dataset and what is wrong; the output folder is unchanged. ``gcms simulate``
    treats the same file in its output folder as a stale cache: it says so and rebuilds it."""
    damaged = tmp_path / "damaged.h5"
    shutil.copy2(reduced, damaged)
    with h5py.File(damaged, "r+") as f:
        f["stiffness"][3, 3] = np.nan
        seal(f)
    out = output_folder(tmp_path)
    before = contents(out)
    run = standalone(str(damaged), str(study(tmp_path)), "--out", str(out))
    assert_one_line_error(run, str(damaged), "/stiffness", "non-finite")
    assert contents(out) == before

    cache = output_folder(tmp_path, name="cache")
    shutil.copy2(damaged, cache / "reduced.h5")
    rebuilt = gcms("simulate", str(study(tmp_path)), "--out", str(cache))
    assert rebuilt.returncode == 0, rebuilt.stderr
    assert "cannot be used" in rebuilt.stderr and "/stiffness" in rebuilt.stderr
    assert np.isfinite(read_reduced(cache / "reduced.h5").stiffness).all()


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

def _stopped_early(run, out, before) -> tuple[Trajectory, dict]:
    """Exit status 1 without a traceback; the user's file and the cached model unchanged; a
    readable results.h5 and summary.json marked incomplete, with the same message."""
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr
    assert "INCOMPLETE" in run.stderr and "stopped early" in run.stderr
    after = contents(out)
    assert {k: after[k] for k in before} == before
    traj = read_results(out / "results.h5")
    summary = json.loads((out / "summary.json").read_text())
    assert not traj.complete and not summary["complete"]
    assert traj.message == summary["message"] and traj.message in run.stderr
    assert summary["time_reached_s"] == traj.time[-1] < summary["end_time_s"]
    return traj, summary


def test_newton_failure_keeps_the_results_up_to_there(reduced, tmp_path):
    """Newton allowed one iteration with a tolerance it cannot meet in one: ``gcms simulate``
    ends with exit status 1 and writes results.h5 and summary.json marked incomplete, the
    message naming the time, the iteration count and the residual; files already in the
    folder are still there, unchanged."""
    scene = SCENE.replace("time_step = 1e-3",
                          "time_step = 1e-3\nsolver = { tolerance = 1e-15, max_iterations = 1 }")
    out = output_folder(tmp_path, reduced)
    before = contents(out)
    run = gcms("simulate", str(study(tmp_path, scene)), "--out", str(out))
    traj, _ = _stopped_early(run, out, before)
    assert "Newton did not converge at t = 0.001 s" in traj.message
    assert "1 iterations" in traj.message and "|r| = " in traj.message


def test_state_that_blows_up_is_reported_with_its_time(reduced, tmp_path):
    """A load of 1e12 N on the cantilever's end: the state stops being physical (inverted,
    non-finite or unsolvable) in the first step; ``gcms simulate`` ends with exit status 1,
    the message says at which time, and the results up to there are written, incomplete."""
    scene = SCENE + """
[[scene.loads]]
group = "end_xL"
force = [0.0, 0.0, -1e12]
"""
    out = output_folder(tmp_path, reduced)
    before = contents(out)
    run = gcms("simulate", str(study(tmp_path, scene)), "--out", str(out))
    traj, _ = _stopped_early(run, out, before)
    assert "t = 0.001 s" in traj.message


def test_initial_mode_amplitude_that_inverts_the_body_is_a_clear_error(reduced, tmp_path):
    """KNOWN BUG (fails today). initial = { mode = 3, amplitude = 10 } (10 m on a 0.5 m beam)
    turns the body's affine map inside out already at t = 0. That is bad input and should end
    like any other (exit status 2, one line naming [scene.initial]); today
    ``integrator.start`` raises InvertedBodyError, which nothing catches: a traceback."""
    scene = SCENE.replace("time_step = 1e-3",
                          "time_step = 1e-3\ninitial = { mode = 3, amplitude = 10.0 }")
    out = output_folder(tmp_path)
    before = contents(out)
    run = standalone(str(reduced), str(study(tmp_path, scene)), "--out", str(out))
    assert_one_line_error(run, "[scene.initial]")
    assert contents(out) == before


def test_ill_conditioned_reduced_model_is_a_clear_error(tmp_path):
    """A square beam reduced without preconditioning ([selection] orthonormalize = false,
    cond(Mr) = 6e11) makes the integrator refuse its mass matrix ("numerically singular",
    raised by ``dense_factorization``). ``gcms simulate`` reports that in one line (exit
    status 1 or 2), also through ``outputs.on_rank0``: no traceback; the line blames Mr with
    its condition number and names the setting that cures it ([selection] orthonormalize =
    true), not the time step (whose own diagnosis is tested in test_dynamics_failures)."""
    text = """
[geometry]
kind = "beam"
section = "square"
side = 0.03
length = 0.5

[mesh]
size = 0.012

[modes]
count = 8

[selection]
cosine_tolerance = 1e-15
svd_tolerance = 1e-15
orthonormalize = false
""" + SCENE
    config = tmp_path / "plain.toml"
    config.write_text(text)
    out = output_folder(tmp_path)
    run = gcms("simulate", str(config), "--out", str(out))
    assert run.returncode in (1, 2), run.stderr
    assert "Traceback" not in run.stderr, run.stderr[-2000:]
    failed = [line for line in run.stderr.splitlines() if "failed" in line or "error" in line]
    assert len(failed) == 1 and "singular" in failed[0], run.stderr
    assert re.search(r"mass matrix Mr is numerically singular \(\|Mr Mr\^-1 - I\| = \S+, "
                     r"cond \d\.\de\+\d\d\)", failed[0]), failed[0]
    assert "orthonormalize = true" in failed[0] and "time_step" not in failed[0]
