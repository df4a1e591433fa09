"""Reliability of the ``gcms`` commands on inputs that break naive tools: a cached model changed
on disk, work too large for the machine, stale plots beside a stopped simulation, a P1 mesh
that will lock, a mode count that cuts a repeated pair, a drive that turns too fast per step."""
from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from conftest import gcms, strict_json
from gcms_fenicsx.config.scene import parse_scene
from simulate_runs import (SCENE, assert_one_line_error, contents, output_folder, standalone,
                           study)


def flip_bit(path, dataset: str, index: tuple[int, int]) -> None:
    """One bit of one entry of ``dataset`` flipped in place: still finite and symmetric enough."""
    with h5py.File(path, "r+") as f:
        data = f[dataset][()]
        data.view(np.uint64)[index] ^= np.uint64(1)
        f[dataset][...] = data


@pytest.mark.slow
def test_a_cache_changed_on_disk_is_rebuilt_and_refused_standalone(beam6_reduced, tmp_path):
    """One flipped bit in Kr of the cached reduced.h5: ``gcms simulate`` says in one progress
    line that it cannot use it and rebuilds it (the file is written anew and reads back);
    the standalone integrator, which cannot rebuild, refuses it in one line naming the
    dataset (exit 2)."""
    out = output_folder(tmp_path, beam6_reduced)
    flip_bit(out / "reduced.h5", "stiffness", (3, 3))
    alone = standalone(str(out / "reduced.h5"), str(study(tmp_path)), "--out",
                       str(tmp_path / "alone"))
    assert_one_line_error(alone, "dataset /stiffness does not match its checksum")
    assert not (tmp_path / "alone").exists()
    run = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "does not match its checksum" in run.stderr and "rebuilding it" in run.stderr
    assert "eigen-solve" in run.stderr
    again = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert again.returncode == 0 and "reusing" in again.stderr, again.stderr


@pytest.mark.parametrize("table, key", [
    ("[mesh]\nsize = 1e-5\n", "[mesh] size = 1e-05"),  # 1e12 cells: refused before meshing
    ("[modes]\ncount = 50000\n", "[modes] count = 50000"),  # a Krylov basis of 1e5 vectors
])
def test_work_beyond_the_machine_is_refused_before_it_starts(tmp_path, table, key):
    """A mesh size of 10 µm on a 1 m beam and 50,000 modes are refused in one line with the
    estimate and the machine's limit, before anything is meshed, and create no --out."""
    text = ('[geometry]\nkind = "beam"\nsection = "square"\nside = 0.02\nlength = 1.0\n'
            + (table if "[mesh]" in table else "[mesh]\nsize = 0.004\n" + table))
    config = tmp_path / "big.toml"
    config.write_text(text)
    out = tmp_path / "out"
    run = gcms("modes", str(config), "--out", str(out))
    assert_one_line_error(run, key, "GiB", "available")
    assert "geometry and mesh" not in run.stderr or key.startswith("[mesh]")
    assert not out.exists()


@pytest.mark.slow
def test_a_stopped_simulation_leaves_no_plots_of_an_earlier_run(beam6_reduced, tmp_path):
    """A complete run draws trajectory.png and energy.png; a rerun whose Newton fails in its
    first step records one row, draws nothing, and the earlier plots are removed instead of
    being left beside results they do not show. The user's own file stays."""
    out = output_folder(tmp_path, beam6_reduced)
    first = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert first.returncode == 0, first.stderr
    assert {"trajectory.png", "energy.png"} <= set(contents(out))
    failing = SCENE.replace("time_step = 1e-3",
                            "time_step = 1e-3\nsolver = { tolerance = 1e-15, max_iterations = 1 }")
    run = gcms("simulate", str(study(tmp_path, failing, "failing.toml")), "--out", str(out))
    assert run.returncode == 1, run.stderr
    assert not {"trajectory.png", "energy.png", "joints.png"} & set(contents(out))
    assert {"notes.txt", "reduced.h5", "results.h5", "summary.json"} <= set(contents(out))
    assert strict_json(out / "summary.json")["complete"] is False


@pytest.mark.slow
def test_a_p1_mesh_that_will_lock_is_warned(tmp_path):
    """A P1 beam meshed at about two elements across its depth (predicted 30 % too stiff in
    bending, geometry.element_order_warning): ``gcms mesh`` says so and mesh.json keeps it;
    the same mesh at order 2 says nothing."""
    text = ('[geometry]\nkind = "beam"\nsection = "square"\nside = 0.02\nlength = 1.0\n'
            "[mesh]\nsize = 0.01\norder = {order}\n")
    for order, warned in ((1, True), (2, False)):
        config = tmp_path / f"p{order}.toml"
        config.write_text(text.format(order=order))
        out = tmp_path / f"p{order}"
        run = gcms("mesh", str(config), "--out", str(out))
        assert run.returncode == 0, run.stderr
        assert ("warning:" in run.stderr) == warned, run.stderr
        assert bool(strict_json(out / "mesh.json")["warnings"]) == warned


@pytest.mark.slow
def test_a_count_that_cuts_a_repeated_pair_is_warned(tmp_path):
    """A square beam's bending modes come in pairs: one mode keeps half of the first pair,
    chosen by the solver, and the run says so (modes.json keeps it); two modes do not."""
    text = ('[geometry]\nkind = "beam"\nsection = "square"\nside = 0.02\nlength = 0.4\n'
            "[mesh]\nsize = 0.01\n[modes]\ncount = {count}\n")
    for count, warned in ((1, True), (2, False)):
        config = tmp_path / f"n{count}.toml"
        config.write_text(text.format(count=count))
        out = tmp_path / f"n{count}"
        run = gcms("modes", str(config), "--out", str(out))
        assert run.returncode == 0, run.stderr
        warnings = strict_json(out / "modes.json")["warnings"]
        assert bool(warnings) == warned and ("cut a near-repeated group" in run.stderr) == warned
        if warned:
            assert "ask for 2 or more" in warnings[0]


def test_a_drive_that_turns_too_far_per_step_is_warned():
    """A drive at 314 rad/s turns 1.57 rad in a 5 ms step: warned, with a step that keeps it
    below 0.05 rad; at 0.1 ms (0.031 rad per step) nothing is said."""
    table = {"end_time": 0.1, "time_step": 5e-4,
             "joints": [{"type": "revolute", "group": "g", "axis": [1, 0, 0], "name": "shaft",
                         "drive": {"angular_velocity": 314.0}}]}
    fast = parse_scene(dict(table, time_step=5e-3))  # 1.57 rad per step
    [warning] = fast.warnings()
    assert "'shaft' turns its group 1.57 rad per step" in warning and "0.00016 s" in warning
    slow = parse_scene(dict(table, time_step=1e-4))
    assert slow.warnings() == []


@pytest.mark.slow
def test_a_copied_cache_is_reused_only_when_intact(beam6_reduced, tmp_path):
    """The unchanged copy of the cache is reused (its checksums hold)."""
    out = tmp_path / "out"
    out.mkdir()
    shutil.copy2(beam6_reduced, out / "reduced.h5")
    run = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert run.returncode == 0 and "reusing" in run.stderr, run.stderr


@pytest.mark.slow
def test_spherical_joints_draw_no_empty_moment_panel(beam6_reduced, tmp_path):
    """A scene whose joints constrain no rotation draws joints.png with the force panel only
    (no empty moment panel, no legend warning); a fixed joint draws both."""
    import struct

    def png_height(path):
        return struct.unpack(">I", path.read_bytes()[20:24])[0]

    out = output_folder(tmp_path, beam6_reduced)
    spherical = SCENE.replace('type = "fixed"', 'type = "spherical"')
    run = gcms("simulate", str(study(tmp_path, spherical, "ball.toml")), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "legend" not in run.stderr.lower() and "warning" not in run.stderr.lower()
    one_panel = png_height(out / "joints.png")
    run = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert png_height(out / "joints.png") > 1.5 * one_panel


def test_a_folder_where_a_result_file_goes_is_refused_and_kept(beam6_reduced, tmp_path):
    """A folder of the user's named results.h5 in --out (with a file in it) is refused in one
    line naming it, before anything runs, and --out is left exactly as it was — the folder is
    never replaced by the file."""
    out = output_folder(tmp_path, beam6_reduced)
    (out / "results.h5").mkdir()
    (out / "results.h5" / "mine.txt").write_text("kept\n")

    def tree() -> dict:
        return {str(p.relative_to(out)): p.read_bytes() if p.is_file() else None
                for p in out.rglob("*")}

    before = tree()
    run = gcms("simulate", str(study(tmp_path)), "--out", str(out))
    assert_one_line_error(run, "--out", "'results.h5'", "folder")
    assert tree() == before and before["results.h5/mine.txt"] == b"kept\n"


#: Joint sets on one group in which a later joint keeps a moment row but loses every force
#: row to the earlier ones (README: several joints on one group are allowed; the redundant
#: rows are dropped), each as (type, axis) on end_x0.
PARTLY_REDUNDANT = {
    "fixed+revolute": [("fixed", None), ("revolute", (0, 1, 0))],
    "revolute_y+revolute_z": [("revolute", (0, 1, 0)), ("revolute", (0, 0, 1))],
    "revolute+revolute+fixed": [("revolute", (0, 1, 0)), ("revolute", (0, 0, 1)),
                                ("fixed", None)],
    "spherical+revolute+spherical+fixed": [("spherical", None), ("revolute", (0, 0, 1)),
                                           ("spherical", None), ("fixed", None)],
}


def joints_scene(joints: list[tuple[str, tuple | None]]) -> str:
    """SCENE with its clamp replaced by ``joints`` on end_x0, named a, b, c, …"""
    tables = "".join(
        f'\n[[scene.joints]]\ntype = "{kind}"\ngroup = "end_x0"\nname = "{chr(97 + i)}"\n'
        + (f"axis = {list(axis)}\n" if axis else "") for i, (kind, axis) in enumerate(joints))
    head, _, rest = SCENE.partition("[[scene.joints]]")
    return head + tables + "\n[basis]" + rest.partition("[basis]")[2]


@pytest.mark.slow
@pytest.mark.parametrize("joints", list(PARTLY_REDUNDANT))
def test_partly_redundant_joints_finish_with_their_pictures(beam6_reduced, tmp_path, joints):
    """Each partly redundant joint set runs to the end, exit 0, with joints.png drawn: a
    joint left with moment rows only is in the moment panel, not in the force panel (before,
    revolute(y) + revolute(z) raised ResultsError after the whole run and left nothing)."""
    out = output_folder(tmp_path, beam6_reduced)
    run = gcms("simulate", str(study(tmp_path, joints_scene(PARTLY_REDUNDANT[joints]))),
               "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "warning" not in run.stderr.lower(), run.stderr
    summary = strict_json(out / "summary.json")
    assert summary["complete"] and "joints.png" in summary["plots"]
    assert (out / "joints.png").stat().st_size > 0


def _failing_picture(monkeypatch, name: str, error: BaseException) -> None:
    """``app.plots`` with the picture ``name`` raising ``error`` when drawn."""
    from gcms_fenicsx.app import plots

    def fail(traj, path):
        raise error
    monkeypatch.setattr(plots, "PICTURES", tuple(
        (n, fail if n == name else draw, shown) for n, draw, shown in plots.PICTURES))


def test_a_picture_that_cannot_be_drawn_is_a_warning(beam6_reduced, tmp_path, monkeypatch,
                                                     capsys):
    """energy.png forced to fail: the run ends with exit 0, results.h5 and summary.json
    published, the other pictures drawn, energy.png absent (no temporary file left) and one
    warning line naming it; summary.json lists the pictures drawn."""
    from gcms_fenicsx import cli

    out = output_folder(tmp_path, beam6_reduced)
    _failing_picture(monkeypatch, "energy.png", RuntimeError("no font"))
    status = cli.main(["simulate", str(study(tmp_path)), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 0, err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "energy.png" in warnings[0] and "no font" in warnings[0]
    files = set(contents(out))
    assert {"results.h5", "summary.json", "trajectory.png", "joints.png"} <= files
    assert "energy.png" not in files and not any(n.endswith(".tmp") for n in files), files
    assert strict_json(out / "summary.json")["plots"] == ["trajectory.png", "joints.png"]


def test_an_interrupt_while_drawing_keeps_the_published_results(beam6_reduced, tmp_path,
                                                                monkeypatch, capsys):
    """SIGINT while joints.png is drawn (after results.h5 and summary.json are published):
    exit 130 and one line saying the results are in --out; the run is not lost, the
    unfinished picture is not there."""
    import signal

    from gcms_fenicsx import cli
    from gcms_fenicsx.runtime.interrupts import Interrupted

    out = output_folder(tmp_path, beam6_reduced)
    _failing_picture(monkeypatch, "joints.png", Interrupted(signal.SIGINT))
    status = cli.main(["simulate", str(study(tmp_path)), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 130, err
    assert "while drawing the pictures; the results are in" in err.splitlines()[-1], err
    files = set(contents(out))
    assert {"results.h5", "summary.json"} <= files and "joints.png" not in files
    assert strict_json(out / "summary.json")["complete"] is True
