"""``gcms simulate`` end to end: the cached reduced model, bad input (one line, exit status 2,
nothing lost) and simulations that stop early (exit status 1, results kept, incomplete).
The standalone integrator (``python -m gcms_fenicsx.dynamics``) on the committed test beam,
without the finite-element stack, is ``tests/dynamics/test_standalone_cli.py``."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from conftest import gcms
from gcms_fenicsx.files.results import Trajectory, read_results
from gcms_fenicsx.files.reduced_model import read_reduced
from simulate_runs import (BAD_SCENES, SCENE, assert_one_line_error, contents, non_finite_copy,
                           output_folder, study)


@pytest.fixture
def reduced(beam6_reduced):
    """reduced.h5 of the six-mode test beam (shared by the session; tests only read or copy it)."""
    return beam6_reduced


# -- 8. the cached reduced model ---------------------------------------------------------------

@pytest.mark.slow
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


@pytest.mark.parametrize("case", BAD_SCENES)
def test_bad_scene_is_one_clear_line_and_changes_nothing(reduced, tmp_path, case):
    """Bad [scene] input — time_step = 0, rho_inf outside 0..1, a zero joint axis, no [scene]
    at all — ends with exit status 2 and one line naming the key, for the command as for the
    standalone integrator (tests/dynamics/test_standalone_cli.py), before anything is
    computed; the output folder (the user's file, the cached model) is left as it was."""
    scene, key = BAD_SCENES[case]
    config = study(tmp_path, scene)
    out = output_folder(tmp_path, reduced)
    before = contents(out)
    run = gcms("simulate", str(config), "--out", str(out))
    assert_one_line_error(run, key)
    assert contents(out) == before


@pytest.mark.slow
def test_non_finite_reduced_model_in_the_cache_is_rebuilt(reduced, tmp_path):
    """A reduced.h5 written with a NaN in Kr (checksums that fit it, so the content check must
    catch it), which the standalone integrator refuses (tests/dynamics/test_standalone_cli.py):
    ``gcms simulate`` treats the same file in its output folder as a stale cache: it says so
    and rebuilds it."""
    cache = output_folder(tmp_path, name="cache")
    non_finite_copy(reduced, cache / "reduced.h5")
    rebuilt = gcms("simulate", str(study(tmp_path)), "--out", str(cache))
    assert rebuilt.returncode == 0, rebuilt.stderr
    assert "cannot be used" in rebuilt.stderr and "/stiffness" in rebuilt.stderr
    assert np.isfinite(read_reduced(cache / "reduced.h5").stiffness).all()


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


@pytest.mark.slow
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
