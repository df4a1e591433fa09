"""The reduced-model file: round trip, positions, damaged and foreign files, atomic writes, and
a reader that needs NumPy and h5py only."""
from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import REPO
from gcms_fenicsx.files import reduced_model as rm
from gcms_fenicsx.files.versioned import dataset_digest, seal

ARRAYS = ("mass", "stiffness", "gravity", "fields", "nodes_m", "frequencies_hz",
          "reduced_frequencies_hz")
ATTRS = ("field_names", "selection", "tolerances", "material", "mesh", "units", "input_hash",
         "schema_version")


@pytest.fixture
def model() -> rm.ReducedModel:
    """A small consistent model: a unit cube's 8 corners, fields 1, X, Y, Z and two more."""
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    X = corners - corners.mean(axis=0)
    rng = np.random.default_rng(1)
    F = np.hstack([np.ones((8, 1)), X, rng.standard_normal((8, 2))])
    G = F.T @ F * 7.85  # a lumped Fᵀ Ms F
    K = rng.standard_normal((18, 12))
    return rm.ReducedModel(
        mass=np.kron(G, np.eye(3)), stiffness=K @ K.T, gravity=np.kron(G[:, :1], np.eye(3)),
        fields=F, nodes_m=corners, field_names=("1", "X", "Y", "Z", "phi1_x", "phi1_y"),
        groups={"bottom": rm.NodeGroup(nodes=np.array([0, 2, 4, 6]),
                                       weights=np.array([0.1, 0.2, 0.3, 0.4])),
                "corner": rm.NodeGroup(nodes=np.array([7]), weights=np.array([1.0]))},
        frequencies_hz=np.array([10.0, 20.0]), reduced_frequencies_hz=np.array([10.0, 20.5]),
        selection={"columns_before": 24, "columns_after": 18, "fields_dropped": []},
        tolerances={"cosine_tolerance": 1e-8, "svd_tolerance": 1e-6},
        material={"E": 2.1e11, "nu": 0.3, "rho": 7850.0}, mesh={"nodes": 8, "cells": 6},
        input_hash="ab" * 32)


@pytest.fixture
def written(model, tmp_path) -> Path:
    path = tmp_path / "reduced.h5"
    rm.write_reduced(path, model)
    return path


def damaged(path: Path, edit: Callable[[h5py.File], None], resealed: bool = True) -> Path:
    """``path`` after ``edit``; ``resealed``: with checksums that fit the edited content (a file
    written wrong, which the content checks must catch), else the checksums of before."""
    with h5py.File(path, "r+") as f:
        edit(f)
        if resealed:
            seal(f)
    return path


def scale_entry(f: h5py.File, name: str, index: tuple[int, ...], factor: float) -> None:
    data = f[name][()]
    data[index] *= factor
    f[name][...] = data


def flip_bit(name: str, index: tuple[int, ...], bit: int = 0) -> Callable[[h5py.File], None]:
    """Flip one bit of one float64 of dataset ``name`` in place."""
    def edit(f: h5py.File) -> None:
        data = f[name][()]
        data.view(np.uint64)[index] ^= np.uint64(1 << bit)
        f[name][...] = data
    return edit


def replace_dataset(name: str, data) -> Callable[[h5py.File], None]:
    def edit(f: h5py.File) -> None:
        del f[name]
        f[name] = data
    return edit


def test_round_trip(model, written):
    back = rm.read_reduced(written)
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
        assert getattr(back, name).dtype == np.float64
    for name in ATTRS:
        if name != "schema_version":
            assert getattr(back, name) == getattr(model, name), name
    assert back.schema_version == rm.schema_for(model) == 2     # no SVK coefficients
    assert back.groups.keys() == model.groups.keys()
    for name, g in model.groups.items():
        np.testing.assert_array_equal(back.groups[name].nodes, g.nodes)
        np.testing.assert_array_equal(back.groups[name].weights, g.weights)
        assert back.groups[name].nodes.dtype == np.int64
    assert back.dofs == 18
    assert written.stat().st_mode & 0o777 == 0o644


def test_positions_are_linear_in_q(model):
    q0 = model.undeformed_coordinates()
    np.testing.assert_allclose(model.fields @ q0.reshape(-1, 3), model.nodes_m, atol=1e-12)
    bottom = model.groups["bottom"]
    np.testing.assert_allclose(model.position(q0, "bottom"),
                               bottom.weights @ model.nodes_m[bottom.nodes], atol=1e-12)
    np.testing.assert_allclose(model.position(q0, "corner"), [1, 1, 1], atol=1e-12)
    # a rigid motion x -> R x + t of the coordinates moves every group's position alike
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    t = np.array([1.0, -2.0, 0.5])
    Q = q0.reshape(-1, 3) @ R.T
    Q[0] += t  # the field "1" carries translations
    np.testing.assert_allclose(model.position(Q.ravel(), "bottom"),
                               R @ model.position(q0, "bottom") + t, atol=1e-12)
    with pytest.raises(rm.ReducedModelError, match="no node group 'top'.*bottom, corner"):
        model.position(q0, "top")
    with pytest.raises(rm.ReducedModelError, match=r"q has shape \(17,\), expected \(18,\)"):
        model.position(q0[:-1], "bottom")


@pytest.mark.parametrize("make, message", [
    (lambda p: None, "no such file"),
    (lambda p: p.mkdir(), "not a file"),
    (lambda p: p.write_text("not HDF5\n"), "not a readable HDF5"),
])
def test_missing_or_foreign_file(tmp_path, make, message):
    path = tmp_path / "reduced.h5"
    make(path)
    with pytest.raises(rm.ReducedModelError, match=f"{re.escape(str(path))}: {message}"):
        rm.read_reduced(path)


def test_truncated_file(written):
    data = written.read_bytes()
    written.write_bytes(data[: len(data) // 2])
    with pytest.raises(rm.ReducedModelError, match=re.escape(str(written))):
        rm.read_reduced(written)


@pytest.mark.parametrize("edit, where", [
    (flip_bit("stiffness", (4, 4)), "dataset /stiffness"),             # still symmetric enough
    (flip_bit("mass", (0, 0), bit=40), "dataset /mass"),
    (lambda f: scale_entry(f, "mass", (0, 0), 1.0001), "dataset /mass"),  # still SPD
    (replace_dataset("groups/bottom/weights", np.array([0.4, 0.3, 0.2, 0.1])),
     "dataset /groups/bottom/weights"),
    (lambda f: f.attrs.__setitem__("input_hash", "ef" * 32), "the root attributes"),
    (lambda f: f["stiffness"].attrs.__delitem__("sha256"), "dataset /stiffness has no content"),
])
def test_content_changed_on_disk_is_refused(written, edit, where):
    """A value changed after writing is refused even when the model it gives is valid: every
    dataset and the root attributes carry a SHA-256 the reader checks."""
    with pytest.raises(rm.ReducedModelError, match=f"{re.escape(str(written))}: {where}"):
        rm.read_reduced(damaged(written, edit, resealed=False))


def test_changed_but_valid_model_passes_validation(written):
    """The edits above give models that validate_model alone accepts: the checksum is what
    catches them."""
    model = rm.read_reduced(damaged(written, lambda f: scale_entry(f, "mass", (0, 0), 1.0001)))
    assert model.checksummed and model.schema_version == rm.schema_for(model)


def test_schema_1_files_are_read_without_checksums(written):
    def old(f):
        f.attrs["schema_version"] = 1
        for ds in ("mass", "stiffness"):
            del f[ds].attrs["sha256"]
        del f.attrs["attributes_sha256"]
    model = rm.read_reduced(damaged(written, old, resealed=False))
    assert not model.checksummed


def test_newer_or_missing_schema(written):
    def newer(f):
        f.attrs["schema_version"] = rm.SCHEMA_VERSION + 1
    with pytest.raises(rm.ReducedModelError, match=f"newer gcms-fenicsx: schema "
                                                   f"{rm.SCHEMA_VERSION + 1}, this reader "
                                                   f"understands up to {rm.SCHEMA_VERSION}"):
        rm.read_reduced(damaged(written, newer))

    def missing(f):
        del f.attrs["schema_version"]
    with pytest.raises(rm.ReducedModelError, match="no schema_version"):
        rm.read_reduced(damaged(written, missing))


@pytest.mark.parametrize("edit, message", [
    (lambda f: f.__delitem__("stiffness"), "missing dataset /stiffness"),
    (lambda f: f.attrs.__delitem__("units"), "missing attribute units"),
    (lambda f: f.__delitem__("groups/bottom/weights"), "missing dataset /groups/bottom/weights"),
    (replace_dataset("stiffness", np.eye(18, 17)),
     r"/stiffness has shape \(18, 17\), expected \(18, 18\) like /mass"),
    (replace_dataset("mass", np.eye(18, 15)), r"/mass is not square: shape \(18, 15\)"),
    (replace_dataset("mass", np.eye(15)), r"/mass has shape \(15, 15\), expected \(18, 18\)"),
    (replace_dataset("fields", np.ones((8, 5))), r"/fields has shape \(8, 5\), expected \(8, 6\)"),
    (replace_dataset("nodes_m", np.ones((7, 3))),
     r"/nodes_m has shape \(7, 3\), expected \(8, 3\)"),
    (replace_dataset("frequencies_hz", np.array([1.0, np.nan])),
     "/frequencies_hz holds 1 non-finite"),
    (replace_dataset("groups/bottom/nodes", np.array([0, 2, 4, 8])),
     "/groups/bottom/nodes refers to node 8, outside 0..7"),
    (replace_dataset("groups/bottom/weights", np.full(4, 0.3)), "weights must sum to 1"),
    (replace_dataset("groups/bottom/weights", np.array([0.5, 0.5, 0.5, -0.5])), "must be >= 0"),
    (replace_dataset("stiffness", np.triu(np.ones((18, 18)))), "/stiffness is not symmetric"),
])
def test_damaged_content(written, edit, message):
    with pytest.raises(rm.ReducedModelError, match=f"{re.escape(str(written))}: .*{message}"):
        rm.read_reduced(damaged(written, edit))


@pytest.mark.parametrize("change, message", [
    ({"stiffness": np.eye(18, 17)}, r"/stiffness has shape \(18, 17\)"),
    ({"field_names": ("1", "X", "Y", "Z", "phi1_x")}, r"/mass has shape \(18, 18\), expected"),
    ({"gravity": np.ones((18, 2))}, r"/gravity has shape \(18, 2\)"),
    ({"mass": -np.eye(18)}, "not positive definite"),
    ({"groups": {"bottom": rm.NodeGroup(np.array([0, 2]), np.array([0.5, np.nan]))}},
     "non-finite"),
    ({"selection": {"cond": np.float32(1.0)}}, "selection is not JSON-serializable"),
])
def test_inconsistent_model_is_refused_and_nothing_written(model, tmp_path, change, message):
    with pytest.raises(rm.ReducedModelError, match=message):
        rm.write_reduced(tmp_path / "reduced.h5", replace(model, **change))
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("interrupt", [KeyboardInterrupt, OSError])
def test_interrupted_write_leaves_the_previous_file(model, written, monkeypatch, interrupt):
    before = written.read_bytes()
    original = h5py.Group.create_dataset
    calls = []

    def failing(self, name, *args, **kwargs):
        calls.append(name)
        if len(calls) > 2:
            raise interrupt("interrupted")
        return original(self, name, *args, **kwargs)

    monkeypatch.setattr(h5py.Group, "create_dataset", failing)
    with pytest.raises(interrupt):
        rm.write_reduced(written, replace(model, input_hash="cd" * 32))
    assert len(calls) == 3
    assert written.read_bytes() == before
    assert [p.name for p in written.parent.iterdir()] == [written.name]


def test_reader_needs_numpy_and_h5py_only(written):
    script = f"""
import importlib.abc, sys
BLOCKED = {{"dolfinx", "ufl", "basix", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy"}}
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{{name}} is blocked")
sys.meta_path.insert(0, Block())
from gcms_fenicsx.files.reduced_model import read_reduced
model = read_reduced({str(written)!r})
print(model.dofs, model.position(model.undeformed_coordinates(), "corner").round(12).tolist())
"""
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         cwd=REPO, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["18", "[1.0,", "1.0,", "1.0]"]


@pytest.fixture
def svk_written(model, tmp_path) -> tuple[rm.ReducedModel, Path]:
    """The small model with (random, symmetric) SVK coefficients of its six fields, written."""
    rng = np.random.default_rng(2)
    s = 6 * 7 // 2
    A = rng.standard_normal((s, s))
    with_svk = replace(model, svk=rm.SVKCoefficients(
        quadratic=A + A.T, linear=rng.standard_normal(s), constant=3.5,
        fields_digest=dataset_digest(model.fields)))
    path = tmp_path / "reduced_svk.h5"
    rm.write_reduced(path, with_svk)
    return with_svk, path


def test_svk_coefficients_round_trip_as_schema_3(svk_written, written):
    """The coefficients come back bit for bit from a schema-3 file (A stored as its upper
    triangle, half the bytes); a model without them is written as schema 2."""
    model, path = svk_written
    back = rm.read_reduced(path)
    assert back.schema_version == 3 and rm.read_reduced(written).schema_version == 2
    np.testing.assert_array_equal(back.svk.quadratic, model.svk.quadratic)
    np.testing.assert_array_equal(back.svk.linear, model.svk.linear)
    assert back.svk.constant == 3.5
    with h5py.File(path) as f:
        assert f["svk/quadratic_upper"].shape == (21 * 22 // 2,)


@pytest.mark.parametrize("edit, message, resealed", [
    (flip_bit("svk/quadratic_upper", (5,), 40), "svk/quadratic_upper", False),
    (replace_dataset("svk/linear", np.ones(20)), r"/svk/quadratic_upper has shape \(231,\), "
                                                  r"expected \(210,\)", True),
    (lambda f: f.__delitem__("svk/linear"), r"SVK coefficients \(which schema 3 holds\) "
                                            "are incomplete: missing svk/linear", True),
    (lambda f: f.__delitem__("svk"), "are incomplete: missing svk/quadratic_upper, "
                                     "svk/linear", True),
    (replace_dataset("fields", np.ones((8, 6))), "the SVK coefficients were computed for "
                                                 "other fields", True),
    (replace_dataset("svk/linear", np.full(21, np.nan)), "/svk/linear holds 21 non-finite", True),
])
def test_damaged_svk_coefficients_are_refused(svk_written, edit, message, resealed):
    """A flipped bit fails the checksum; a short, missing or non-finite dataset is named."""
    _, path = svk_written
    with pytest.raises(rm.ReducedModelError, match=f"{re.escape(str(path))}: .*{message}"):
        rm.read_reduced(damaged(path, edit, resealed=resealed))


def test_svk_coefficients_of_other_fields_are_refused_before_writing(svk_written, tmp_path):
    """Coefficients whose size does not fit the fields (nf = 6: s = 21) are refused, naming
    the expected shape, and nothing is written."""
    model, _ = svk_written
    wrong = replace(model, svk=replace(model.svk, quadratic=np.eye(15), linear=np.zeros(15)))
    with pytest.raises(rm.ReducedModelError, match=r"/svk/quadratic has shape \(15, 15\), "
                                                   r"expected \(21, 21\)"):
        rm.write_reduced(tmp_path / "out" / "reduced.h5", wrong)
    assert not (tmp_path / "out").exists()
