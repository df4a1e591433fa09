"""The reduced GCMS body and its HDF5 file: what a simulation needs, and nothing of the FE model.

This module imports NumPy and h5py only, so the standalone integrator (and anybody else)
can read ``reduced.h5`` without dolfinx, PETSc or MPI. The writer checks a model before it
writes, and writes atomically (temporary file, then rename); the reader checks the schema
version, every dataset and every shape, and says what is wrong with a file that does not fit.

Coordinates: q is Q read row by row, Q holding one 3-vector per field (DESIGN §2), so a
node's position is x_i = Σ_f F[i, f] Q[f, :] and a group's is Σ_i w_i x_i.
"""
from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

SCHEMA_VERSION = 1
_ARRAYS = ("mass", "stiffness", "gravity", "fields", "nodes_m", "frequencies_hz",
           "reduced_frequencies_hz")
_JSON_ATTRS = ("field_names", "units", "selection", "tolerances", "material", "mesh")


class ReducedModelError(ValueError):
    """A reduced-model file (or model) that is missing data, malformed or of a newer schema."""


@dataclass(frozen=True)
class NodeGroup:
    """A named node set: global node indices and the weights of its mean position (sum 1)."""

    nodes: np.ndarray
    weights: np.ndarray


@dataclass(frozen=True)
class ReducedModel:
    """Constant reduced matrices of one body, its fields at every node, and their provenance.

    ``mass`` Mr and ``stiffness`` Kr are (n, n) with n = 3·len(field_names); ``gravity``
    (n, 3) is the generalised force per unit gravity vector g [m/s²]; ``fields`` (N, fields)
    and ``nodes_m`` (N, 3) are F and the undeformed coordinates at every node.
    """

    mass: np.ndarray
    stiffness: np.ndarray
    gravity: np.ndarray
    fields: np.ndarray
    nodes_m: np.ndarray
    field_names: tuple[str, ...]
    groups: dict[str, NodeGroup]
    frequencies_hz: np.ndarray
    reduced_frequencies_hz: np.ndarray
    selection: dict
    tolerances: dict
    material: dict
    mesh: dict
    input_hash: str
    units: dict = field(default_factory=lambda: {"length": "m", "mass": "kg", "time": "s",
                                                 "force": "N"})
    schema_version: int = SCHEMA_VERSION

    @property
    def dofs(self) -> int:
        return self.mass.shape[0]

    def group(self, name: str) -> NodeGroup:
        if name not in self.groups:
            raise ReducedModelError(f"no node group {name!r}; the groups are: "
                                    + ", ".join(sorted(self.groups)))
        return self.groups[name]

    def position(self, q: np.ndarray, name: str) -> np.ndarray:
        """Mean position Σ_i w_i x_i of group ``name`` for coordinates q (linear in q)."""
        g = self.group(name)
        return g.weights @ (self.fields[g.nodes] @ np.asarray(q).reshape(-1, 3))

    def undeformed_coordinates(self) -> np.ndarray:
        """q0 with F Q0 = X (the undeformed nodes), from the four rigid fields alone.

        The first four fields span {1, x, y, z} (possibly scaled and shifted), so the
        undeformed body is exactly a combination of them; the flexible rows of Q0 are zero.
        """
        Q0 = np.zeros((len(self.field_names), 3))
        Q0[:4], *_ = np.linalg.lstsq(self.fields[:, :4], self.nodes_m, rcond=None)
        return Q0.ravel()


def check(model: ReducedModel, where: str = "reduced model") -> None:
    """Raise ReducedModelError naming what is inconsistent (shapes, weights, non-finite values)."""
    n = 3 * len(model.field_names)
    expected = {"mass": (n, n), "stiffness": (n, n), "gravity": (n, 3),
                "fields": (model.nodes_m.shape[0], len(model.field_names)),
                "nodes_m": (model.fields.shape[0], 3)}
    for name, shape in expected.items():
        found = getattr(model, name).shape
        if found != shape:
            raise ReducedModelError(f"{where}: /{name} has shape {found}, expected {shape} "
                                    f"({len(model.field_names)} fields)")
    if model.reduced_frequencies_hz.shape != model.frequencies_hz.shape:
        raise ReducedModelError(
            f"{where}: /reduced_frequencies_hz has shape {model.reduced_frequencies_hz.shape}, "
            f"expected {model.frequencies_hz.shape} like /frequencies_hz")
    for name in _ARRAYS:
        if not np.all(np.isfinite(getattr(model, name))):
            raise ReducedModelError(f"{where}: /{name} holds non-finite values")
    for name, g in model.groups.items():
        if g.nodes.shape != g.weights.shape or g.nodes.ndim != 1:
            raise ReducedModelError(f"{where}: group {name!r} has {g.nodes.shape} nodes but "
                                    f"{g.weights.shape} weights")
        if len(g.nodes) and (g.nodes.min() < 0 or g.nodes.max() >= model.fields.shape[0]):
            raise ReducedModelError(f"{where}: group {name!r} refers to nodes outside "
                                    f"0..{model.fields.shape[0] - 1}")
        if np.any(g.weights < 0) or abs(g.weights.sum() - 1.0) > 1e-9:
            raise ReducedModelError(f"{where}: group {name!r} weights must be >= 0 and sum to "
                                    f"1 (sum {g.weights.sum():.12g})")


def write_reduced(path: str | Path, model: ReducedModel) -> None:
    """Check the model, then write it atomically: a temporary file beside ``path``, then rename."""
    path = Path(path)
    check(model)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f.attrs["schema_version"] = model.schema_version
            f.attrs["input_hash"] = model.input_hash
            for name in _JSON_ATTRS:
                value = getattr(model, name)
                f.attrs[name] = json.dumps(list(value) if name == "field_names" else value)
            for name in _ARRAYS:
                f.create_dataset(name, data=getattr(model, name))
            groups = f.create_group("groups")
            for name, g in model.groups.items():
                groups.create_dataset(f"{name}/nodes", data=g.nodes.astype(np.int64))
                groups.create_dataset(f"{name}/weights", data=g.weights)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def read_reduced(path: str | Path) -> ReducedModel:
    """Read and check a reduced-model file; ReducedModelError says what does not fit."""
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise ReducedModelError(f"{path}: not a readable HDF5 file (truncated or not HDF5?): "
                                f"{exc}") from exc
    with f:
        if "schema_version" not in f.attrs:
            raise ReducedModelError(f"{path}: no schema_version: not a gcms reduced model")
        version = int(f.attrs["schema_version"])
        if version > SCHEMA_VERSION:
            raise ReducedModelError(f"{path}: written by a newer gcms-fenicsx: schema {version}, "
                                    f"this reader understands up to {SCHEMA_VERSION}")
        try:
            arrays = {name: np.asarray(f[name][()], dtype=float) for name in _ARRAYS}
            attrs = {name: json.loads(f.attrs[name]) for name in _JSON_ATTRS}
            groups = {name: NodeGroup(nodes=np.asarray(g["nodes"][()], dtype=np.int64),
                                      weights=np.asarray(g["weights"][()], dtype=float))
                      for name, g in f["groups"].items()}
            input_hash = str(f.attrs["input_hash"])
        except KeyError as exc:
            raise ReducedModelError(f"{path}: missing dataset or attribute: {exc}") from exc
        except (OSError, json.JSONDecodeError) as exc:
            raise ReducedModelError(f"{path}: damaged content: {exc}") from exc
    model = ReducedModel(**arrays, field_names=tuple(attrs.pop("field_names")), groups=groups,
                         input_hash=input_hash, schema_version=version, **attrs)
    check(model, str(path))
    return model
