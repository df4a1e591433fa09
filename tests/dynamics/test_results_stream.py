"""results.h5 without bounds: streamed as the run goes (same values as in memory, memory flat
in the number of steps), refused before the run when it would not fit, sealed with content
checksums; progress lines with the rate and the time left.

The body is the six-mode test beam of ``beams`` (30 × 20 mm, 0.5 m), read from its committed
reduced.h5.
"""
from __future__ import annotations

import importlib
import re
import shutil
import tracemalloc

import h5py
import numpy as np
import pytest

from gcms_fenicsx.files import results
from gcms_fenicsx.dynamics.run.capacity import Capacity, check_capacity
from gcms_fenicsx.dynamics.constraints.joints import build_constraints
from gcms_fenicsx.dynamics.run.recorder import record_plan
from gcms_fenicsx.files.results import RESULTS_SCHEMA_VERSION, ResultsError, read_results
from gcms_fenicsx.config.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate, simulate_body, simulate_to_file
from gcms_fenicsx.app.plots import plot_results, read_plot_data
from gcms_fenicsx.files.versioned import dataset_digest
from simulate_runs import assert_one_line_error, contents, output_folder, standalone, study

#: The module (the package's ``simulate`` is the function of that name).
MARCH_MODULE = importlib.import_module("gcms_fenicsx.dynamics.run.march")
#: Summary entries that are measured times, not results.
TIMINGS = ("wall_time_s", "setup_time_s", "steps_per_second", "time_per_step_us")


def everything(end_time: float = 0.05, **outputs):
    """A clamped beam under gravity and a harmonic tip load, recording every output: both end
    groups every 3rd step, energies, multipliers, coordinates, two field snapshots."""
    return parse_scene({
        "end_time": end_time, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81],
        "joints": [{"type": "fixed", "group": "end_x0", "name": "clamp"}],
        "loads": [{"group": "end_xL", "force": [0.0, 30.0, 50.0], "time": "harmonic",
                   "frequency_hz": 60.0}],
        "outputs": {"groups": ["end_xL", "end_x0"], "every": 3, "coordinates": True,
                    "field_times": [0.004, end_time], **outputs}})


@pytest.fixture(scope="module")
def model(beam6_model):
    return beam6_model


@pytest.fixture(scope="module")
def body(beam6_body):
    return beam6_body


def test_streamed_results_equal_the_in_memory_ones(model, body, tmp_path, monkeypatch):
    """The same scene kept in memory and streamed to results.h5 in blocks of 4 rows (18 rows:
    five blocks, the last one partial): every series, snapshot, row description and status
    is identical bit for bit, so are the summaries (but for the timings); the file's series
    are resizable datasets written in chunks of one block."""
    scene = everything()
    plan = record_plan(body, build_constraints(body, scene.joints, body.q0), scene)
    monkeypatch.setattr(results, "BLOCK_BYTES", 4 * plan.row_bytes + 1)
    traj, summary = simulate(model, scene)
    path = tmp_path / "results.h5"
    streamed = simulate_to_file(model, scene, path)
    back = read_results(path)
    assert len(back.time) == plan.rows == 18
    series = traj.series()
    assert back.series().keys() == series.keys()
    for name, data in series.items():
        assert back.series()[name].dtype == data.dtype, name
        np.testing.assert_array_equal(back.series()[name], data, err_msg=name)
    for name in ("field_time", "displacement", "nodes_m"):
        np.testing.assert_array_equal(getattr(back, name), getattr(traj, name), err_msg=name)
    assert back.displacement.shape == (2, len(body.nodes_m), 3)
    assert (back.rows, back.complete, back.message, back.model_hash) == \
        (traj.rows, traj.complete, traj.message, traj.model_hash)
    assert {k: v for k, v in streamed.items() if k not in TIMINGS} == \
        {k: v for k, v in summary.items() if k not in TIMINGS}
    with h5py.File(path) as f:
        assert f["time"].maxshape == (None,) and f["time"].chunks == (4,)
        assert f["coordinates/q"].chunks == (4, body.dofs)


def test_estimate_is_the_size_of_the_stored_results(model, body, tmp_path):
    """The estimate checked against the limits, made before the run, counts exactly the values
    a complete run stores (rows, snapshots and nodes): it equals the sum of the datasets'
    uncompressed sizes in its results.h5."""
    scene = everything()
    plan = record_plan(body, build_constraints(body, scene.joints, body.q0), scene)
    simulate_to_file(model, scene, tmp_path / "results.h5")
    stored = []
    with h5py.File(tmp_path / "results.h5") as f:
        f.visititems(lambda _, ds: stored.append(ds.size * ds.dtype.itemsize)
                     if isinstance(ds, h5py.Dataset) else None)
    assert plan.total_bytes == sum(stored)


def _peak_traced_bytes(run) -> int:
    tracemalloc.start()
    try:
        run()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_of_a_streamed_run_does_not_grow_with_its_length(model, body, tmp_path):
    """A free beam under gravity recording its coordinates every step (about 1.2 kB a row),
    1000 and 4000 steps: the peak of Python's and NumPy's allocations (tracemalloc) grows by
    less than a tenth of the 3000 extra rows when they are streamed to a file; kept in memory
    they add about their own size (at least 90 %: the measurement sees them)."""
    def scene(steps: int):
        return parse_scene({"end_time": steps * 1e-4, "time_step": 1e-4,
                            "gravity": [0.0, 0.0, -9.81], "outputs": {"coordinates": True}})
    plan = record_plan(body, build_constraints(body, (), body.q0), scene(1000))
    extra = (record_plan(body, build_constraints(body, (), body.q0), scene(4000)).rows
             - plan.rows) * plan.row_bytes
    streamed = [_peak_traced_bytes(lambda: simulate_to_file(model, scene(n),
                                                            tmp_path / f"{n}.h5"))
                for n in (1000, 4000)]
    kept = [_peak_traced_bytes(lambda: simulate_body(body, scene(n))) for n in (1000, 4000)]
    assert streamed[1] - streamed[0] < 0.1 * extra, (streamed, extra)
    assert kept[1] - kept[0] >= 0.9 * extra, (kept, extra)


def test_results_beyond_the_free_disk_space_are_refused_before_the_run(beam6_file, tmp_path):
    """end_time = 1e9 s at 1 ms (today: a traceback allocating 7 TiB): the standalone
    integrator stops with exit status 2 and one line naming [scene] end_time and its value,
    the estimate (steps, rows, bytes) and the free space where results.h5 goes; nothing is
    stepped and the output folder is unchanged."""
    text = (study(tmp_path).read_text()
            .replace("end_time = 0.01", "end_time = 1e9"))
    config = tmp_path / "long.toml"
    config.write_text(text)
    out = output_folder(tmp_path)
    before = contents(out)
    run = standalone(str(beam6_file), str(config), "--out", str(out))
    assert_one_line_error(run, "[scene] end_time = 1e+09: 1e+12 steps of 0.001 s record "
                          "1e+12 rows", "TB of results, more than the", "B free on ")
    assert "simulate: t =" not in run.stderr
    assert contents(out) == before


def test_results_beyond_available_memory_are_refused(body):
    """The same run kept in memory: SceneError with the estimate against the available memory,
    before anything is allocated."""
    with pytest.raises(SceneError, match=r"\[scene\] end_time = 1e\+09: .* of results, more "
                                         r"than the .* of available memory"):
        simulate_body(body, parse_scene({"end_time": 1e9, "time_step": 1e-3}))


def test_the_refusal_names_field_times_when_snapshots_dominate(body):
    """Two hundred field snapshots of a short run are most of its results: over a limit, the
    refusal names [scene.outputs] field_times; the rows' own size names end_time."""
    scene = everything(end_time=0.2, field_times=list(np.linspace(0.0, 0.2, 200)))
    plan = record_plan(body, build_constraints(body, scene.joints, body.q0), scene)
    assert plan.snapshot_bytes > plan.series_bytes
    with pytest.raises(SceneError, match=r"\[scene.outputs\] field_times = \(200 times\): .*"
                                         r"200 field snapshots"):
        check_capacity(plan, Capacity(plan.total_bytes - 1, "free on /nowhere"), scene)
    check_capacity(plan, Capacity(plan.total_bytes, "free on /nowhere"), scene)


def test_progress_lines_give_the_rate_and_the_time_left(body, monkeypatch):
    """Progress lines of a run (every step here) say how many of the steps are done, at what
    rate, and when the run will end; the first one gives the estimate of the results."""
    monkeypatch.setattr(MARCH_MODULE, "PROGRESS_INTERVAL_S", -1.0)
    lines: list[str] = []
    simulate_body(body, parse_scene({"end_time": 0.01, "time_step": 1e-3}),
                  progress=lines.append)
    assert re.match(r"simulate: 10 steps of 0.001 s, 66 coordinates, 0 constraint rows; 11 "
                    r"recorded rows and 0 field snapshots, \S+ k?B \(limit .* of available "
                    r"memory\)$", lines[0]), lines[0]
    steps = [line for line in lines if line.startswith("simulate: t =")]
    assert len(steps) == 10
    assert re.fullmatch(r"simulate: t = 0.005 / 0.01 s \(5 of 10 steps, \d+ steps/s, "
                        r"ETA \d+ s\)", steps[4]), steps[4]


def test_pictures_read_a_bounded_part_of_the_results(model, tmp_path):
    """The pictures read from results.h5 what they show — the time, the first output group,
    the energies, the multipliers — every k-th row, k = ⌈rows / max_rows⌉, so their memory
    is bounded whatever the run's length; all three are drawn from the file."""
    path = tmp_path / "results.h5"
    simulate_to_file(model, everything(), path)
    back = read_results(path)
    data = read_plot_data(path, max_rows=5)
    k = -(-len(back.time) // 5)
    assert data.stride == k and len(data.time) <= 5 and data.sensor == "end_xL"
    np.testing.assert_array_equal(data.time, back.time[::k])
    np.testing.assert_array_equal(data.sensor_position, back.groups["end_xL"]["position"][::k])
    np.testing.assert_array_equal(data.multipliers, back.multipliers[::k])
    assert data.energy.keys() == back.energy.keys()
    assert plot_results(path, tmp_path) == ["trajectory.png", "energy.png", "joints.png"]
    assert all((tmp_path / name).stat().st_size > 0 for name in ("trajectory.png", "energy.png"))


def test_results_carry_content_checksums(model, tmp_path):
    """results.h5 is schema 2 and sealed: every dataset's checksum, built while its rows were
    streamed, is the one of its contents read back. A bit flipped in a series or a changed
    attribute is refused naming the file and the dataset (or the root attributes); a schema-1
    file (no checksums) is still read."""
    path = tmp_path / "results.h5"
    simulate_to_file(model, everything(), path)
    with h5py.File(path) as f:
        assert f.attrs["schema_version"] == RESULTS_SCHEMA_VERSION == 2
        datasets = []
        f.visititems(lambda _, ds: datasets.append(ds) if isinstance(ds, h5py.Dataset) else None)
        assert len(datasets) == 21
        for ds in datasets:
            assert ds.attrs["sha256"] == dataset_digest(ds[()]), ds.name

    def edited(name: str, edit) -> str:
        copy = tmp_path / f"{name}.h5"
        shutil.copy2(path, copy)
        with h5py.File(copy, "r+") as f:
            edit(f)
        return str(copy)

    def flip(f):
        data = f["groups/end_xL/position"][()]
        data.view(np.uint64)[3, 2] ^= np.uint64(1)
        f["groups/end_xL/position"][...] = data

    flipped = edited("flipped", flip)
    with pytest.raises(ResultsError, match=rf"^{re.escape(flipped)}: dataset "
                                           r"/groups/end_xL/position does not match its checksum"):
        read_results(flipped)
    relabelled = edited("relabelled", lambda f: f.attrs.__setitem__("complete", False))
    with pytest.raises(ResultsError, match=rf"^{re.escape(relabelled)}: the root attributes do "
                                           "not match their checksum"):
        read_results(relabelled)

    def schema_1(f):
        f.attrs["schema_version"] = 1
        del f.attrs["attributes_sha256"]
        f.visititems(lambda _, ds: ds.attrs.__delitem__("sha256")
                     if isinstance(ds, h5py.Dataset) else None)
    old = read_results(edited("old", schema_1))
    assert old.schema_version == 1 and old.complete
