"""The ``gcms`` command end to end: files it writes, errors it reports, nothing half-written."""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import REPO, gcms, mpirun
from gcms_fenicsx.config.study import default_config_text, load_config
from gcms_fenicsx.config.table import ConfigError

BEAM = """
[geometry]
kind = "beam"
section = "rectangle"
width = 0.03
height = 0.02
length = 0.4

[mesh]
size = 0.012
order = 2

[modes]
count = 6
"""


@pytest.fixture
def beam_config(tmp_path):
    path = tmp_path / "beam.toml"
    path.write_text(BEAM)
    return path


@pytest.mark.slow
def test_mesh_writes_msh_and_json(beam_config, tmp_path):
    out = tmp_path / "out"
    run = gcms("mesh", str(beam_config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    report = json.loads((out / "mesh.json").read_text())
    assert {"nodes", "cells", "volume_m3", "mass_properties", "physical_groups"} <= set(report)
    assert report["volume_m3"] == pytest.approx(0.03 * 0.02 * 0.4, rel=1e-9)
    assert set(report["physical_groups"]) == {"body", "end_x0", "end_xL"}
    assert (out / "mesh.msh").stat().st_size > 0
    assert "volume" in run.stdout
    assert sorted(p.name for p in out.iterdir()) == ["cache.json", "mesh.json", "mesh.msh"]


@pytest.mark.slow
def test_modes_writes_json_and_mode_shapes_only_when_asked(beam_config, tmp_path):
    """gcms modes writes modes.h5 and modes.json, and no mode shapes unless [outputs] asks;
    asked, the next command reuses the solve and writes them as binary XDMF + HDF5 whose
    vectors are the cached mode shapes at the same coordinates (so the node order of the
    cache and of the file agree)."""
    import h5py

    from gcms_fenicsx.files.modes_file import read_modes

    out = tmp_path / "out"
    run = gcms("modes", str(beam_config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    report = json.loads((out / "modes.json").read_text())
    assert report["rigid_mode_count"] == 6
    assert len(report["elastic_frequencies_hz"]) == 6
    assert report["missed_eigenvalues"] == 0
    assert report["max_relative_residual"] < 1e-8
    assert {"assembly", "eigensolve", "inertia_check"} <= set(report["timings_s"])
    assert report["ndofs"] == 3 * json.loads((out / "mesh.json").read_text())["nodes"]
    assert report["stages"]["modes"]["status"] == "computed"
    assert not (out / "mode_shapes").exists()
    assert "[   " in run.stderr  # progress lines

    asking = tmp_path / "shapes.toml"
    asking.write_text(beam_config.read_text() + "\n[outputs]\nmode_shapes = true\n")
    run = gcms("modes", str(asking), "--out", str(out))
    assert run.returncode == 0, run.stderr
    stages = json.loads((out / "modes.json").read_text())["stages"]
    assert stages["modes"]["status"] == "reused" and stages["mode_shapes"]["status"] == "computed"
    assert "modes: reusing" in run.stderr
    basis = read_modes(out / "modes.h5").basis
    with h5py.File(out / "mode_shapes" / "mode_shapes.h5") as f:
        x = f["Mesh/mesh/geometry"][()]
        shapes = [f[f"Function/mode_shape/{j + 1}"][()] for j in range(6)]
    assert len(x) == len(basis.nodes_m)
    # the two coordinate sets are computed apart (geometry and space nodes): equal to 1e-16 m
    mine, theirs = (np.lexsort(np.round(c / 1e-9).T) for c in (basis.nodes_m, x))
    np.testing.assert_allclose(x[theirs], basis.nodes_m[mine], rtol=0, atol=1e-14)
    for j, shape in enumerate(shapes):  # dolfinx's writer leaves round-off: 9e-15 measured
        expected = basis.mode_fields()[mine, :, j]
        np.testing.assert_allclose(shape[theirs], expected, rtol=0,
                                   atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("patch, key", [
    ("[material]\nnu = 0.5\n", "[material] nu"),
    ("[material]\nE = -1.0\n", "[material] E"),
    ("[modes]\ncount = 6\n", "not valid TOML"),  # a table declared twice
    ("[solver]\nx = 1\n", "[solver]"),
    ("[material]\nrho_ = 7800.0\n", "[material] rho_"),
])
def test_bad_input_is_one_clear_line_and_writes_nothing(beam_config, tmp_path, patch, key):
    beam_config.write_text(BEAM + patch)
    out = tmp_path / "out"
    run = gcms("modes", str(beam_config), "--out", str(out))
    assert run.returncode == 2
    assert key in run.stderr and "Traceback" not in run.stderr
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.slow
def test_failed_solve_keeps_earlier_results_and_adds_nothing(beam_config, tmp_path):
    out = tmp_path / "out"
    assert gcms("mesh", str(beam_config), "--out", str(out)).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    beam_config.write_text(BEAM.replace("count = 6", "count = 30\nmax_iterations = 1\n"
                                        "tolerance = 1e-15"))
    run = gcms("modes", str(beam_config), "--out", str(out))
    assert run.returncode == 1
    assert "converged" in run.stderr and "max_iterations" in run.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing changed


@pytest.mark.slow
@pytest.mark.mpi
def test_modes_on_two_ranks_match_serial(beam_config, tmp_path):
    serial, parallel = tmp_path / "one", tmp_path / "two"
    assert gcms("modes", str(beam_config), "--out", str(serial)).returncode == 0
    run = mpirun(["-m", "gcms_fenicsx.cli", "modes", str(beam_config), "--out", str(parallel)])
    assert run.returncode == 0, run.stderr
    one = json.loads((serial / "modes.json").read_text())
    two = json.loads((parallel / "modes.json").read_text())
    assert two["mpi_ranks"] == 2 and two["ndofs"] == one["ndofs"]
    np.testing.assert_allclose(two["elastic_frequencies_hz"], one["elastic_frequencies_hz"],
                               rtol=1e-8)
    assert two["missed_eigenvalues"] == 0


def test_built_in_default_is_the_shipped_workflow_file():
    assert (REPO / "workflows" / "default.toml").read_text() == default_config_text()
    cfg = load_config(None)
    assert cfg.geometry.kind == "crankshaft"


def test_gcms_run_without_a_study_runs_the_built_in_crank_train(tmp_path, monkeypatch):
    """The main job's default: ``gcms run --out DIR`` runs the shipped crank train (the same
    file as workflows/crank_train.toml) as a system study."""
    from gcms_fenicsx.app import commands

    shipped = REPO / "gcms_fenicsx" / "data" / "crank_train.toml"
    assert (REPO / "workflows" / "crank_train.toml").read_text() == shipped.read_text()
    seen = []
    monkeypatch.setattr(commands, "run_system", lambda cfg, out, fresh: seen.append(cfg) or "")
    commands.run(None, tmp_path / "out")
    (cfg,) = seen
    assert cfg.source == "<built-in default>" and cfg.engine is not None
    assert sorted(b.name for b in cfg.flexible) == ["conrod1", "conrod2", "conrod3", "conrod4",
                                                    "crankshaft"]


def test_missing_config_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="cannot be read"):
        load_config(tmp_path / "nope.toml")
