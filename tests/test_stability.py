"""Numerical-stability invariants at small scale (the full stress suite is
``workflows/stability.py``): a symmetric section perturbed by ε = 1e-6, mm-t-s against SI,
E over ten decades, a long pendulum run's energy balance, Kr and Mr on two ranks, and the
suite's own judgement of how a command ended.

Every study goes through the ``gcms`` command, as the suite drives it, with the suite's own
study writer and readers (so a test failing here says the suite would mis-read too). Slender
beams (``test_eigen``), the size-independence of the condition numbers (``test_reduce``,
``test_selection``) and the serial/parallel frequencies (``test_reduce``, ``test_cli``) have
their own tests and are not repeated.
"""
from __future__ import annotations

import shutil
import sys

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "workflows"))  # the suite's package, beside its entry point
from stress import readers, runner, studies

EPS = np.finfo(float).eps

SIDE, LENGTH = 0.03, 0.5
#: The 30 mm square steel beam at 7.5 mm: one field of the near-repeated first bending pair
#: lies below the SVD threshold (σ_min = 0.51 of it), so the selection has a choice to make.
#: Seven modes keep the third bending pair (modes 6 and 7, split 2e-6) whole: six would take
#: one member, bending in a direction the mesh's asymmetry picks, and the pendulum below then
#: differs between ε = 0 and 1e-6 by 2.4e-7 L instead of 5e-11 L (workflows/stability.py,
#: class symmetry).
SQUARE_SIZE, SQUARE_MODES = 0.0075, 7
PENDULUM = studies.pendulum_scene(0.05, 1e-3)   # 50 steps, pinned at x = 0, gravity −z


def square(epsilon: float) -> dict:
    study = studies.beam_study("rectangle", {"width": SIDE * (1 + epsilon), "height": SIDE},
                               LENGTH, SQUARE_SIZE, SQUARE_MODES)
    study["scene"] = dict(PENDULUM)
    study["basis"] = {"attachment": "none"}   # the eigenmodes' selection, as measured above
    return study


def result(run) -> dict:
    """Everything the suite reads from a finished command's --out (asserting it succeeded)."""
    assert run.exit_status == 0 and run.outcome == "ok", (run.outcome, run.problem, run.stderr)
    row = readers.both(readers.read_modes, readers.read_selection)(run.out)
    row["out"] = run.out
    if (run.out / "results.h5").exists():
        row.update(readers.read_summary(run.out))
        row["tip"] = readers.tip_positions(run.out)
    return row


@pytest.fixture(scope="module")
def widened(tmp_path_factory):
    """`gcms run` of the square beam (ε = 0) and of the beam widened by ε = 1e-6."""
    folder = tmp_path_factory.mktemp("widened")
    return {eps: result(runner.gcms("run", square(eps), folder / f"eps{eps:g}"))
            for eps in (0.0, 1e-6)}


def threshold_ratio(row: dict) -> float:
    """σ_min over the SVD threshold (svd_tolerance σ_max, default 1e-6)."""
    return min(row["singular_values"]) / (1e-6 * max(row["singular_values"]))


@pytest.mark.slow
def test_widening_a_square_beam_by_1e_6_keeps_the_selection_and_the_swing(widened):
    """ε = 1e-6 is a new mesh (Gmsh meshes each width afresh), so what may change is what two
    meshes of one nominal size differ by, never a decision of the selection:

    - the rank: σ_min is 0.51–0.52 of the threshold on both (not on the knife edge,
      asserted), so the same number of fields is kept; which of the pair's fields goes may
      differ;
    - σ_min within 25 %: it falls with the element size h at a rate of about 3 on this beam
      (5.8e-6 at 15 mm, 7.2e-7 at 7.5 mm), and two meshes of one size differ by a few % in
      local h (2 % measured);
    - the pruning error within a factor 3: it is set by the dropped direction, the same
      near-dependency either way, while losing or keeping a field of the pair moves it by
      orders of magnitude (1e-12 with nothing dropped, 10 % with the pair's Poisson fields
      gone: tests/test_reduce.py);
    - the pendulum's tip trajectory within 1e-8 L: the tip moves elastically by δ ≈ 4e-5 m
      (8e-5 L; ρgL⁴/(8EI) with I = h⁴/12) against the rigid swing about y, which widening
      along y does not stiffen; ε and a new mesh of the same size change δ by ε plus the
      meshes' discretisation difference (1e-6 in the bending frequencies here), far below
      1e-4 of δ = 8e-9 L. A field of the pair lost (~10 % of δ) or a pair cut by Nm (2.4e-7
      L) fails it.
    """
    a, b = widened[0.0], widened[1e-6]
    for row in (a, b):
        assert not 0.8 < threshold_ratio(row) < 1.25, threshold_ratio(row)
    assert b["fields_kept_count"] == a["fields_kept_count"]
    assert b["columns_after"] == a["columns_after"] < a["columns_before"]
    assert b["sigma_min"] == pytest.approx(a["sigma_min"], rel=0.25)
    assert 1 / 3 < b["pruning_error"] / a["pruning_error"] < 3
    assert a["pruning_error"] < 1e-4 and b["pruning_error"] < 1e-4
    tip = np.linalg.norm(b["tip"] - a["tip"], axis=1).max()
    assert tip < 1e-8 * LENGTH, tip / LENGTH   # measured 5e-11 L


@pytest.mark.slow
def test_mm_t_s_gives_the_si_results(widened, tmp_path):
    """The same study in mm, t, s (lengths ×1e3, E in MPa, ρ in t/mm³, gravity in mm/s²) is the
    same problem with every quantity scaled by a power of ten: the same mesh (Gmsh scales),
    the same fields kept, frequencies to 1e-9 (each matrix entry is rounded once more, ε
    relative, amplified by the (L/h)⁴ ≈ 1e5 cancellation of slender bending), condition
    numbers before selection to the round-off of a Gram matrix of that condition (10 ε cond,
    the rule of test_selection; 2e-4 of 8e-3 measured) and after it, where the Gram matrix is
    near the identity and carries the round-off of T, to ε cond (1.6e-6 of 9e-4), singular
    values to ε/(2σ²) (σ² is a Gram eigenvalue known to ε), the tip trajectory ×1e3 to 1e-9 L
    (Newton stops at a relative residual of 1e-10; 3e-15 L measured) and the same Newton
    iterations (their mean to 0.02: one step in 50 may take one more near the tolerance)."""
    si = widened[0.0]
    mm = result(runner.gcms("run", studies.mm_t_s(square(0.0)), tmp_path / "mm"))
    assert (mm["nodes"], mm["cells"]) == (si["nodes"], si["cells"])
    assert mm["fields_kept"] == si["fields_kept"]
    np.testing.assert_allclose(mm["frequencies_hz"], si["frequencies_hz"], rtol=1e-9)
    gram = si["cond_mr_before"]  # the conditioning every quantity here is computed through
    for key, factor in (("cond_mr_before", 10), ("cond_phi_before", 10), ("cond_mr_after", 1),
                        ("cond_phi_after", 1)):
        assert mm[key] == pytest.approx(si[key], rel=factor * EPS * gram), key
    sv_si, sv_mm = np.array(si["singular_values"]), np.array(mm["singular_values"])
    np.testing.assert_allclose(sv_mm, sv_si, rtol=10 * EPS / (2 * sv_si.min() ** 2))
    tip = np.linalg.norm(mm["tip"] / 1e3 - si["tip"], axis=1).max()
    assert tip < 1e-9 * LENGTH, tip / LENGTH
    assert mm["newton_iterations_mean"] == pytest.approx(si["newton_iterations_mean"], abs=0.02)
    assert mm["energy_drift_rel"] == pytest.approx(si["energy_drift_rel"], rel=1e-6)


@pytest.mark.slow
def test_frequencies_scale_as_sqrt_E_over_ten_decades(tmp_path):
    """E = 1e5 and 1e15 Pa on one mesh (the same mesh file, asserted): K scales by exactly
    1e10, so every frequency by 1e5; what is left is round-off amplified by the shifted
    solve and the (L/h)⁴ cancellation, 1e-12 measured, bound 1e-9. The fields are the
    M-normalised mode shapes, which E does not change: the same fields kept, the same
    singular values and condition numbers (10 ε cond(G) before selection, ε cond(G) after
    it, as in test_mm_t_s_gives_the_si_results)."""
    runs = {}
    for E in (1e5, 1e15):
        study = studies.beam_study("rectangle", {"width": 0.03, "height": 0.02}, 0.5, 0.012, 6,
                                   dict(studies.STEEL, E=E))
        runs[E] = result(runner.gcms("reduce", study, tmp_path / f"E{E:g}"))
    lo, hi = runs[1e5], runs[1e15]
    assert hi["mesh_sha256"] == lo["mesh_sha256"]
    np.testing.assert_allclose(np.array(hi["frequencies_hz"]) / 1e5, lo["frequencies_hz"],
                               rtol=1e-9)
    np.testing.assert_allclose(np.array(hi["reduced_frequencies_hz"]) / 1e5,
                               lo["reduced_frequencies_hz"], rtol=1e-9)
    assert hi["fields_kept"] == lo["fields_kept"]
    sv = np.array(lo["singular_values"])
    np.testing.assert_allclose(hi["singular_values"], sv, rtol=10 * EPS / (2 * sv.min() ** 2))
    gram = lo["cond_mr_before"]
    assert hi["cond_mr_before"] == pytest.approx(lo["cond_mr_before"], rel=10 * EPS * gram)
    assert hi["cond_mr_after"] == pytest.approx(lo["cond_mr_after"], rel=EPS * gram)
    # no absolute floor: the zero-energy check's limit scales with the shift, so the lowest
    # elastic eigenvalue sits the same factor (7e10) above it at either E
    assert hi["margins"]["zero_energy"] == pytest.approx(lo["margins"]["zero_energy"], rel=1e-9)


@pytest.mark.slow
def test_energy_balance_of_a_long_pendulum_run_does_not_grow(tmp_path):
    """4000 steps (about 2.5 swings) of the soft flexible pendulum: the largest balance error
    of the last quarter is at most twice that of the first. A drift linear in t makes that
    ratio 4 and a random walk 2; on this undamped, unloaded swing it is 0.98 (the error is
    set in the first swing and repeats with it; 20 s of it in workflows/stability.py)."""
    study = studies.beam_study("square", {"side": 0.02}, 1.0, 0.02, 6,
                               {"E": 1.0e8, "nu": 0.35, "rho": 1150.0})
    study["scene"] = studies.pendulum_scene(4.0, 1e-3)
    run = runner.gcms("run", study, tmp_path / "pendulum")
    summary = result(run)
    assert summary["complete"] and summary["steps"] == 4000
    t, err = readers.balance_history(readers.read_trajectory(run.out))
    a, q = np.abs(err), len(err) // 4
    assert 0 < a[-q:].max() <= 2 * a[:q].max(), (a[:q].max(), a[-q:].max())
    assert summary["energy_drift_rel"] < 1e-4  # measured 1.2e-5 (the release transient)


@pytest.mark.slow
@pytest.mark.mpi
def test_two_ranks_give_the_serial_kr_and_mr_entries(tmp_path):
    """`gcms reduce` on 1 and 2 ranks: the nodes come in another order and each mode with
    either sign; matched by position and sign (the suite's ``reduced_difference``), F, Mr
    and Kr agree entry by entry. The two runs' modes agree to about 1e-12 (their frequencies
    to 5e-13); the preconditioned basis undoes a near-dependency of cond(G) (1.5e11 here) and
    amplifies that by up to √cond(G): bound 1e-12 √cond(G) of the largest entry."""
    study = studies.beam_study("rectangle", {"width": 0.03, "height": 0.02}, 0.5, 0.012, 6)
    one = result(runner.gcms("reduce", study, tmp_path / "one"))
    run = runner.gcms("reduce", study, tmp_path / "two", ranks=2)
    two = result(run)
    assert two["fields_kept"] == one["fields_kept"]
    d = readers.reduced_difference(tmp_path / "one" / "reduced.h5", run.out / "reduced.h5")
    assert d["node_match_over_size"] < 1e-12 and d["field_names_equal"]
    bound = 1e-12 * np.sqrt(one["cond_mr_before"])
    for key in ("fields_difference", "mr_difference", "kr_difference"):
        assert d[key] < bound, (key, d[key], bound)


@pytest.mark.slow
def test_the_suite_tells_a_clean_failure_from_a_broken_one(widened, tmp_path):
    """How the suite judges endings, on real ones: a bad input (ν = 0.5) into an --out holding
    a user's file ends with exit status 2, one line naming the key and --out as it was
    ('bad input (2)', the line recorded); a simulation whose Newton may take one iteration
    stops early with exit status 1 and its results marked incomplete ('incomplete', the one
    documented change of --out). The same endings with a traceback, another exit status, a
    second line or a changed or created --out are judged BROKEN."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("the user's own file\n")
    study = studies.beam_study("square", {"side": 0.03}, 0.5, 0.015, 4,
                               dict(studies.STEEL, nu=0.5))
    run = runner.gcms("modes", study, out)
    assert (run.exit_status, run.outcome, run.problem) == (2, "bad input (2)", "")
    assert "[material] nu" in run.row()["last_stderr"] and run.wall_s > 0
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]

    stopped = tmp_path / "stopped"
    shutil.copytree(widened[0.0]["out"], stopped)  # the reduced model is reused: no FE work
    study = square(0.0)
    study["scene"]["solver"] = {"tolerance": 1e-15, "max_iterations": 1}
    run = runner.gcms("simulate", study, stopped)
    assert (run.exit_status, run.outcome, run.problem) == (1, "incomplete", "")
    assert not readers.read_trajectory(stopped).complete

    now = runner.snapshot(out)
    endings = {  # name: (exit status, stderr, --out before, --out after)
        "traceback": (2, "Traceback (most recent call last):\n  ...\nValueError: x", now, now),
        "exit status": (3, "gcms modes: error: x", now, now),
        "two lines": (1, "gcms modes: failed: x\nand another line", now, now),
        "--out changed": (1, "gcms modes: failed: x", now, {**now, "mesh.json": "0" * 64}),
        "--out created": (2, "gcms modes: error: x", None, {}),
        "clean": (1, "[   0.1 s] eigen-solve\ngcms modes: failed: x", now, now),
    }
    for name, (status, stderr, before, after) in endings.items():
        fake = runner.Run("gcms modes", out, "", status, stderr, 0.1)
        outcome, problem = runner.judge(fake, "modes", before, after, mpi=False)
        if name == "clean":
            assert (outcome, problem) == ("failed (1)", "")
        else:
            assert outcome == "BROKEN" and problem, name


def test_the_suite_judges_a_system_study_by_its_own_files(tmp_path):
    """``gcms run`` of a system study (the rigid slider crank, no FE work) writes system.h5
    and summary.json, not a body's stage files: the suite judges it 'ok' by those, and one
    whose Newton may take one iteration 'incomplete' by its summary.json saying so (before,
    every finished system run was judged BROKEN for the body's files it does not write)."""
    import tomllib

    from test_system_study import RIGID

    study = tomllib.loads(RIGID)
    assert tomllib.loads(studies.toml_text(study)) == study   # [[joints]] written back
    run = runner.gcms("run", study, tmp_path / "rigid")
    assert (run.exit_status, run.outcome, run.problem) == (0, "ok", "")
    study["system"].update(tolerance=1e-15, max_iterations=1)
    run = runner.gcms("run", study, tmp_path / "stopped")
    assert (run.exit_status, run.outcome, run.problem) == (1, "incomplete", "")
    assert not readers.strict_json(tmp_path / "stopped" / "summary.json")["complete"]


def test_assembly_runs_are_compared_at_the_times_both_recorded(tmp_path):
    """``probes_assembly.difference`` of a run at half the step (recorded every 8 steps of h/2)
    against one at h (every 4 of h): the rows at the same times are compared, each run's own
    last row (its end time) left out; the difference is max_t |a − b| over b's peak (a torque
    off by 0.05 at one shared time: 0.05 / 2); runs sharing too few times are refused."""
    import h5py

    from stress.probes_assembly import difference

    def write(name: str, t: np.ndarray, torque: np.ndarray) -> None:
        (tmp_path / name).mkdir()
        with h5py.File(tmp_path / name / "system.h5", "w") as f:
            f["time_s"] = t
            f["joints/main_0/drive_torque_nm"] = torque
            f["joints/big_end_1/force_n"] = np.stack([torque, torque, 0 * torque], axis=1)

    h = 5e-5
    coarse = np.append(np.arange(0, 401) * 4 * h, 0.08005)
    fine = np.append(np.arange(0, 401) * 8 * (h / 2), 0.080025)
    base = 2.0 * np.sin(coarse * 300.0)
    base[1] = 2.0
    write("h", coarse, base)
    shifted = 2.0 * np.sin(fine * 300.0)
    shifted[1] = 2.0 + 0.05
    shifted[-1] = 99.0                                 # its end row: no partner, not compared
    write("half", fine, shifted)
    out = difference(tmp_path / "half", tmp_path / "h")
    assert out["torque_difference_rel"] == pytest.approx(0.05 / 2.0, rel=1e-9)
    write("other", coarse + 1e-4, base)
    with pytest.raises(ValueError, match="share"):
        difference(tmp_path / "other", tmp_path / "h")
