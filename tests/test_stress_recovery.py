"""Stresses from the reduced model (docs/design.md §9): a static cantilever against beam theory
and against its full-order model, and the stress modes as a stage of ``gcms run`` — computed
only when a scene asks, reused, formed alone when asked later, written for ParaView."""
from __future__ import annotations

import json
import logging
import tomllib
import xml.etree.ElementTree as ElementTree

import h5py
import numpy as np
import pytest

from beams import HEIGHT_Z, LENGTH, WIDTH_Y, beam_study
from conftest import full_and_reduced, gcms, gcms_reduce, mpirun
from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.config.study import parse_config
from gcms_fenicsx.dynamics.constraints.statics import held_static
from gcms_fenicsx.dynamics.run.capacity import Capacity
from gcms_fenicsx.dynamics.run.simulate import prepare_run
from gcms_fenicsx.dynamics.run.stress_recovery import corotated_stress, von_mises
from gcms_fenicsx.fe.nodal_gradients import stress_nodes
from gcms_fenicsx.fe.node_order import input_node_indices
from gcms_fenicsx.files.stress_nodes import read_stress_nodes
from gcms_fenicsx.numerics.rotation import polar
from gcms_fenicsx.references.full_order import full_held_static

logging.disable(logging.INFO)

TIP_N = 100.0
SCENE = """
[basis]
attachment = "scene"

[scene]
end_time = 0.04
time_step = 1e-4
damping = { beta = 3e-3 }
initial = { equilibrium = true }
outputs = { every = 10 }

[[scene.joints]]
type = "fixed"
group = "end_x0"
name = "clamp"

[[scene.loads]]
group = "end_xL"
force = [0.0, 0.0, -100.0]
name = "tip"
"""


def _text() -> str:
    """The test beam's study (four modes, svd_tolerance 1e-7) with the cantilever scene."""
    return beam_study(4).replace("cosine_tolerance = 1e-12",
                                 "cosine_tolerance = 1e-12\nsvd_tolerance = 1e-7") + SCENE


def _study(size: float) -> dict:
    return dict(tomllib.loads(_text()), mesh={"size": size, "order": 2})


@pytest.mark.slow
def test_cantilever_stress_is_beam_theory_and_the_full_models(tmp_path):
    """The test beam (30 × 20 mm, 0.5 m, P2 cells of 6 mm) clamped at end_x0 (a fixed joint)
    with 100 N at end_xL, reduced with four modes and the scene's attachment modes:

    - in the co-rotated law's static equilibrium (the scene's equilibrium start), σ_xx on the
      top and bottom faces farther than 2 h from either end is M c / I = F (L − x) h/2 / I
      within 1 % at every node (measured 0.76 %; 3.3 % on 12 mm cells: it is the mesh's);
    - at the linear static states of the reduced and the full-order model (where the attachment
      modes make the reduced response the full one), the stress tensors formed the same way
      (B at the same nodes, the co-rotated law) agree at every surface node to 1e-6 of the
      largest von Mises stress: the selection prunes at 1e-7 (measured 1.7e-9)."""
    cfg = parse_config(_study(0.006))
    chain, full, reduced = full_and_reduced(cfg, tmp_path)
    fe = chain.assembly.model
    nodes = stress_nodes(chain.body, StressOutputs(surface=True), len(reduced.nodes_m), "")
    index = input_node_indices(fe.Vs)
    mu, lmbda = cfg.material.lame

    def stresses(q: np.ndarray, body, to_file: bool) -> tuple[np.ndarray, np.ndarray]:
        Q = q.reshape(-1, 3)
        x = body.node_fields @ Q if not to_file else np.empty_like(Q)
        if to_file:
            x[index] = Q
        F = nodes.gradient.dot(x).reshape(-1, 3, 3).transpose(0, 2, 1)
        return corotated_stress(F, polar(Q.T @ body.affine).rotation, mu, lmbda)

    state = prepare_run(reduced, cfg.scene, Capacity(1 << 40, "test")).state
    local, _ = stresses(state.q, reduced, False)
    X = reduced.nodes_m[nodes.nodes]
    second_moment = WIDTH_Y * HEIGHT_Z ** 3 / 12
    for side in (1.0, -1.0):
        on = (np.abs(X[:, 2] - side * HEIGHT_Z / 2) < 1e-9) & (X[:, 0] > 2 * HEIGHT_Z) & \
            (X[:, 0] < LENGTH - 2 * HEIGHT_Z)
        theory = side * TIP_N * (LENGTH - X[on, 0]) * HEIGHT_Z / 2 / second_moment
        error = np.abs(local[on, 0, 0] / theory - 1.0)
        assert on.sum() > 500 and error.max() < 0.01, (side, error.max())

    load_time = cfg.scene.loads_risen_s
    linear_full = full_held_static(full, cfg.scene, None, load_time)
    linear = held_static(reduced, cfg.scene, None, time_s=load_time)
    _, sigma_full = stresses(full.q0 + linear_full.displacement, full, True)
    _, sigma = stresses(reduced.q0 + linear.displacement, reduced, False)
    scale = von_mises(sigma_full).max()
    assert np.abs(sigma - sigma_full).max() <= 1e-6 * scale


@pytest.mark.slow
def test_stress_modes_only_when_asked_reused_and_formed_alone_later(tmp_path):
    """``gcms run`` on the cantilever (12 mm cells): without stress outputs no stress modes
    and no stress in the results; asked later, only the stress modes are formed (the
    reduction reused), results.h5 holds the recorded nodes' peaks and series and summary.json
    the hot spot, stress.xdmf the whole body at the stress times; a third run reuses them."""
    base = _text().replace("[mesh]\nsize = 0.012", "[mesh]\nsize = 0.012\norder = 2")
    study, out = tmp_path / "study.toml", tmp_path / "out"
    study.write_text(base)
    result = gcms("run", str(study), "--out", str(out))
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stress"] is None and "stress_modes" not in summary["stages"]
    assert not (out / "stress_modes.h5").exists() and not (out / "stress.xdmf").exists()
    with h5py.File(out / "results.h5") as f:
        assert "stress" not in f

    asked = 'outputs = { every = 10, stress_groups = ["end_x0", "end_xL"], ' \
            'stress_times = [0.02, 0.04] }'
    study.write_text(base.replace("outputs = { every = 10 }", asked))
    result = gcms("run", str(study), "--out", str(out))
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    stages = summary["stages"]
    assert stages["reduction"]["status"] == "reused"
    assert stages["stress_modes"]["status"] == "computed"
    stress = summary["stress"]
    assert stress["peak_group"] == "end_x0"            # the clamp carries the moment
    assert stress["peak_position_m"][0] == pytest.approx(0.0, abs=1e-12)
    assert "peak von Mises stress" in result.stdout
    with h5py.File(out / "results.h5") as f:
        k = len(f["stress/node_index"])
        rows = len(f["time"])
        assert f["stress/nodes"].shape == (k, 3) and f["stress/von_mises"].shape == (rows, k)
        peak = f["stress/peak_von_mises"][()]
        assert peak.max() == pytest.approx(stress["peak_von_mises_pa"])
        series = f["stress/von_mises"][()]
        np.testing.assert_allclose(series.max(axis=0), peak, rtol=1e-6)    # float32 series
        assert f["stress/groups/end_xL/principal"].shape == (rows, 3)
    document = ElementTree.parse(out / "stress.xdmf").getroot()
    times = [float(t.get("Value")) for t in document.iter("Time")]
    assert times == pytest.approx([0.02, 0.04])
    with h5py.File(out / "stress.h5") as f:
        nodes = f["geometry"].shape[0]
        assert f["cells"].shape[1] == 10 and f["von_mises/1"].shape == (nodes,)
        assert f["stress/1"].shape == (nodes, 6)

    result = gcms("run", str(study), "--out", str(out))
    assert result.returncode == 0, result.stderr
    stages = json.loads((out / "summary.json").read_text())["stages"]
    assert stages["stress_modes"]["status"] == "reused"


def _dense(nodes) -> np.ndarray:
    g = nodes.gradient
    out = np.zeros(g.shape)
    for r in range(g.shape[0]):
        out[r, g.indices[g.indptr[r]:g.indptr[r + 1]]] += g.data[g.indptr[r]:g.indptr[r + 1]]
    return out


@pytest.mark.slow
def test_stress_modes_on_two_ranks_are_the_serial_ones(tmp_path):
    """The stress modes' mesh part of the 12 mm P2 test beam — every surface node with the
    whole body's operator and cells, and the nodes of two groups — formed on one and on two
    ranks: the same nodes and groups, the same cells (in another order), and the operator B
    equal to round-off (bound 1e-12 of its largest entry: the same cells' rows summed in
    another order)."""
    out = tmp_path / "out"
    gcms_reduce(_text().replace("[mesh]\nsize = 0.012", "[mesh]\nsize = 0.012\norder = 2"),
                tmp_path / "study.toml", out)
    results = {}
    for ranks in (1, 2):
        folder = tmp_path / f"ranks{ranks}"
        folder.mkdir()
        run = mpirun(["tests/mpi_stress_nodes.py", str(out), str(folder)], n=ranks)
        assert run.returncode == 0, run.stderr
        results[ranks] = {name: read_stress_nodes(folder / f"{name}.h5")
                          for name in ("surface", "groups")}
    for name in ("surface", "groups"):
        one, two = results[1][name], results[2][name]
        np.testing.assert_array_equal(one.nodes, two.nodes)
        np.testing.assert_array_equal(one.gradient_nodes, two.gradient_nodes)
        assert one.groups.keys() == two.groups.keys()
        for group in one.groups:
            np.testing.assert_array_equal(one.groups[group], two.groups[group])
        B1, B2 = _dense(one), _dense(two)
        assert np.abs(B1 - B2).max() <= 1e-12 * np.abs(B1).max()
        assert sorted(map(tuple, one.cells)) == sorted(map(tuple, two.cells))
    assert len(results[1]["surface"].cells) > 0 and len(results[1]["groups"].cells) == 0
