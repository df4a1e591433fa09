"""The reduced-model file: round trip, damaged and foreign files, atomic writes, and a
reader that needs NumPy and h5py only."""
from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import h5py
import numpy as np
import pytest

from conftest import REPO
from gcms_fenicsx import reduced_model as rm


@pytest.fixture
def model() -> rm.ReducedModel:
    """A small consistent model: a unit cube's 8 corners, fields 1, X, Y, Z and two more."""
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    X = corners - corners.mean(axis=0)
    rng = np.random.default_rng(1)
    F = np.hstack([np.ones((8, 1)), X, rng.standard_normal((8, 2))])
    G = F.T @ F * 7.85
    K = rng.standard_normal((18, 18))
    return rm.ReducedModel(
        mass=np.kron(G, np.eye(3)), stiffness=K @ K.T, gravity=np.kron(G[:, :1], np.eye(3)),
        fields=F, nodes_m=corners, field_names=("1", "X", "Y", "Z", "psi1", "psi2"),
        groups={"bottom": rm.NodeGroup(nodes=np.array([0, 2, 4, 6]), weights=np.full(4, 0.25))},
        frequencies_hz=np.array([10.0, 20.0]), reduced_frequencies_hz=np.array([10.0, 20.0]),
        selection={"columns_after": 18}, tolerances={"svd_tolerance": 1e-6},
        material={"E": 1.0, "nu": 0.3, "rho": 7.85}, mesh={"nodes": 8}, input_hash="abc")


def test_round_trip(model, tmp_path):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    back = rm.read_reduced(path)
    for name in ("mass", "stiffness", "gravity", "fields", "nodes_m", "frequencies_hz"):
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
    assert back.field_names == model.field_names and back.input_hash == "abc"
    assert back.selection == model.selection and back.units["length"] == "m"
    np.testing.assert_array_equal(back.groups["bottom"].nodes, [0, 2, 4, 6])
    assert oct(path.stat().st_mode & 0o777) == "0o644"


def test_positions_are_linear_in_q(model):
    q0 = model.undeformed_coordinates()
    np.testing.assert_allclose(model.fields @ q0.reshape(-1, 3), model.nodes_m, atol=1e-12)
    np.testing.assert_allclose(model.position(q0, "bottom"), [0.5, 0.5, 0.0], atol=1e-12)
    with pytest.raises(rm.ReducedModelError, match="no node group 'top'.*bottom"):
        model.position(q0, "top")


def test_truncated_file(model, tmp_path):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(rm.ReducedModelError, match=f"{path}.*not a readable HDF5"):
        rm.read_reduced(path)


def test_newer_schema(model, tmp_path):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = rm.SCHEMA_VERSION + 1
    with pytest.raises(rm.ReducedModelError, match="newer gcms-fenicsx: schema 2"):
        rm.read_reduced(path)


def test_missing_dataset_and_wrong_shape(model, tmp_path):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    with h5py.File(path, "r+") as f:
        del f["stiffness"]
    with pytest.raises(rm.ReducedModelError, match="missing .*stiffness"):
        rm.read_reduced(path)
    rm.write_reduced(path, model)
    with h5py.File(path, "r+") as f:
        del f["stiffness"]
        f["stiffness"] = np.zeros((18, 17))
    with pytest.raises(rm.ReducedModelError, match=r"/stiffness has shape \(18, 17\), expected \(18, 18\)"):
        rm.read_reduced(path)


@pytest.mark.parametrize("weights, message", [
    (np.full(4, 0.3), "sum to 1"), (np.array([0.5, 0.5, 0.5, -0.5]), ">= 0"),
])
def test_bad_group_weights_are_refused_and_nothing_written(model, tmp_path, weights, message):
    bad = replace(model, groups={"bottom": rm.NodeGroup(np.array([0, 2, 4, 6]), weights)})
    with pytest.raises(rm.ReducedModelError, match=message):
        rm.write_reduced(tmp_path / "reduced.h5", bad)
    assert not any(tmp_path.iterdir())


def test_interrupted_write_leaves_the_previous_file(model, tmp_path, monkeypatch):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    before = path.read_bytes()
    calls = []

    def failing(self, name, *args, **kwargs):
        calls.append(name)
        if len(calls) > 2:
            raise KeyboardInterrupt
        return original(self, name, *args, **kwargs)

    original = h5py.Group.create_dataset
    monkeypatch.setattr(h5py.Group, "create_dataset", failing)
    with pytest.raises(KeyboardInterrupt):
        rm.write_reduced(path, replace(model, input_hash="new"))
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["reduced.h5"]


def test_reader_needs_numpy_and_h5py_only(model, tmp_path):
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    script = f"""
import importlib.abc, sys
BLOCKED = {{"dolfinx", "ufl", "basix", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy"}}
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{{name}} is blocked")
sys.meta_path.insert(0, Block())
from gcms_fenicsx.reduced_model import read_reduced
print(read_reduced({str(path)!r}).dofs)
"""
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         cwd=REPO)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "18"
