"""The reduced GCMS body and its HDF5 file: what a simulation needs, and nothing of the FE model.

``gcms reduce`` writes one ``reduced.h5`` per body (docs/design.md §5); the standalone integrator
(docs/design.md §6) reads it. This module therefore imports NumPy, h5py and the standard library
only, so the file can be read without dolfinx, PETSc, MPI or SciPy.

The writer validates a model before it writes and writes atomically (a temporary file beside
the target, then a rename), so a failed or interrupted write leaves the previous file as it
was. The reader checks the schema version, every dataset and attribute, every shape and
every value, and raises :class:`ReducedModelError` saying which file and what is wrong.

Coordinates: q is Q read row by row, Q holding one 3-vector per field (docs/design.md §2), so node i
is at x_i = Σ_f F[i, f] Q[f, :] and a node group's mean position is Σ_i w_i x_i; both are
linear in q.

File layout (schemas 2 and 3): root attributes ``schema_version`` (int), ``input_hash`` (str) and
``units``, ``field_names``, ``selection``, ``tolerances``, ``material``, ``mesh`` (JSON
strings); datasets ``/mass``, ``/stiffness``, ``/gravity``, ``/fields``, ``/nodes_m``,
``/frequencies_hz``, ``/reduced_frequencies_hz``; and ``/groups/<name>/nodes`` (int64),
``/groups/<name>/weights`` for every node group. Every dataset carries the SHA-256 of its
contents and the root the SHA-256 of its attributes (``versioned.seal``); the reader
verifies them, so a matrix changed on disk is refused even when it still looks valid.
Schema 1 (before checksums) is still read; :attr:`ReducedModel.checksummed` tells.

Schema 3 adds the constant coefficients of the geometrically exact Saint Venant–Kirchhoff
energy (docs/design.md §7.2, ``dynamics.bodies.svk``) for ``[scene] elasticity = "svk"``:
``/svk/quadratic_upper`` (A's upper triangle, row by row), ``/svk/linear`` (b) and the
root attributes ``svk_constant`` (c) and ``svk_fields_sha256`` (``files.svk_data``). A model
without them is written as schema 2, which readers of schema 2 still read; one with them is
schema 3, which they refuse as newer, and a schema-3 file without them is refused.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

import h5py
import numpy as np

from gcms_fenicsx.files.array_checks import Fail, check_real_array, check_symmetric
from gcms_fenicsx.files.outputs import atomic_file, json_text
from gcms_fenicsx.files.svk_data import (SVK_CONSTANT, SVK_DATASETS, SVK_FIELDS,
                                         SVKCoefficients, check_svk, from_upper, write_svk)
from gcms_fenicsx.files.versioned import created, open_versioned, seal

SCHEMA_VERSION: int = 3
#: The first schema whose files carry content checksums.
CHECKSUMS_SINCE: int = 2
#: The first schema with the Saint Venant–Kirchhoff coefficients; a model without them is
#: written as the schema before.
SVK_SINCE: int = 3

_ARRAYS = ("mass", "stiffness", "gravity", "fields", "nodes_m", "frequencies_hz",
           "reduced_frequencies_hz")
_NDIM = {"mass": 2, "stiffness": 2, "gravity": 2, "fields": 2, "nodes_m": 2,
         "frequencies_hz": 1, "reduced_frequencies_hz": 1}
_DICT_ATTRS = ("units", "selection", "tolerances", "material", "mesh")
_JSON_ATTRS = ("field_names", *_DICT_ATTRS)
_WEIGHT_SUM_TOL = 1e-9
# what h5py raises for a truncated or corrupted file, depending on where the damage is
class ReducedModelError(ValueError):
    """A reduced-model file or model that is missing data, malformed or of a newer schema."""


@dataclass(frozen=True)
class NodeGroup:
    """A named node set (joint, load, sensor): node indices and the weights of its mean position.

    ``nodes`` (int64) index the rows of :attr:`ReducedModel.fields` and
    :attr:`ReducedModel.nodes_m`; ``weights`` (float64, same length, ≥ 0, sum 1) are area
    weights, so the group's mean position is Σ_i w_i x_i.
    """

    nodes: np.ndarray
    weights: np.ndarray


def _default_units() -> dict:
    return {"length": "m", "mass": "kg", "time": "s", "force": "N"}


@dataclass(frozen=True)
class ReducedModel:
    """Constant reduced matrices of one body, its fields at every node, and their provenance.

    With n = 3·len(field_names): ``mass`` Mr (n, n) is symmetric positive definite,
    ``stiffness`` Kr (n, n) symmetric, ``gravity`` (n, 3) the generalized force per unit
    gravity vector g [m/s²] (the force is ``gravity @ g``). ``fields`` F (N, fields) holds the
    kept scalar fields at every node and ``nodes_m`` (N, 3) the undeformed node coordinates.
    ``frequencies_hz`` are the full model's elastic frequencies, ``reduced_frequencies_hz``
    those of (Kr, Mr); ``svk`` the Saint Venant–Kirchhoff coefficients of the fields, when
    the reduction was asked for them. ``selection``, ``tolerances``, ``material``, ``mesh`` and ``units``
    are JSON-able dicts; ``input_hash`` is the sha256 hex digest of every input. The
    provenance (``material``, ``mesh``, ``input_hash``) is what a file records; a model
    built in memory (a workflow's) may leave it empty.
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
    material: dict = field(default_factory=dict)
    mesh: dict = field(default_factory=dict)
    input_hash: str = ""
    units: dict = field(default_factory=_default_units)
    schema_version: int = SCHEMA_VERSION
    svk: SVKCoefficients | None = None

    @property
    def dofs(self) -> int:
        """Number of generalized coordinates n = 3·len(field_names)."""
        return self.mass.shape[0]

    @property
    def checksummed(self) -> bool:
        """Whether the file it was read from carried content checksums (schema ≥ 2)."""
        return self.schema_version >= CHECKSUMS_SINCE

    def group(self, name: str) -> NodeGroup:
        """The node group ``name``; ReducedModelError listing the known groups if there is none."""
        if name not in self.groups:
            known = ", ".join(sorted(self.groups)) or "(none)"
            raise ReducedModelError(f"no node group {name!r}; the groups are: {known}")
        return self.groups[name]

    def position(self, q: np.ndarray, group: str) -> np.ndarray:
        """Mean position Σ_i w_i x_i (3,) of the node group ``group`` at coordinates q."""
        g = self.group(group)
        q = np.asarray(q, dtype=float)
        if q.shape != (self.dofs,):
            raise ReducedModelError(f"q has shape {q.shape}, expected ({self.dofs},): three "
                                    f"coordinates for each of {len(self.field_names)} fields")
        return g.weights @ (self.fields[g.nodes] @ q.reshape(-1, 3))

    def undeformed_coordinates(self) -> np.ndarray:
        """q0 (n,) with F Q0 = nodes_m, from the four rigid fields alone.

        The first four fields span {1, x, y, z} (possibly scaled and shifted), so the
        undeformed body is exactly a combination of them and the flexible rows of Q0 are
        zero; a least-squares fit over all fields would instead pick up round-off along
        near-dependent flexible fields, which a preconditioned basis amplifies.
        """
        Q0 = np.zeros((len(self.field_names), 3))
        Q0[:4], *_ = np.linalg.lstsq(self.fields[:, :4], self.nodes_m, rcond=None)
        return Q0.ravel()


def validate_model(model: ReducedModel, where: str = "reduced model") -> None:
    """Raise ReducedModelError, prefixed with ``where``, for anything inconsistent in ``model``.

    Checks types, shapes (n = 3·len(field_names)), finiteness, symmetry of Mr and Kr,
    positive definiteness of Mr and every node group's indices and weights.
    """
    def fail(message: str) -> NoReturn:
        raise ReducedModelError(f"{where}: {message}")

    _check_attributes(model, fail)
    _check_arrays(model, fail)
    _check_matrices(model, fail)
    if model.svk is not None:
        check_svk(model.svk, model.fields, fail)
    for name, g in model.groups.items():
        _check_group(name, g, model.fields.shape[0], fail)


def _check_attributes(model: ReducedModel, fail: Fail) -> None:
    names = model.field_names
    if (not isinstance(names, tuple) or not names
            or not all(isinstance(s, str) for s in names)):
        fail(f"field_names must be a non-empty tuple of strings, found {names!r}")
    if len(set(names)) != len(names):
        fail(f"field_names repeat a name: {list(names)}")
    version = model.schema_version
    if not isinstance(version, int) or not 1 <= version <= SCHEMA_VERSION:
        fail(f"schema_version is {version!r}, expected 1..{SCHEMA_VERSION}")
    if not isinstance(model.input_hash, str):
        fail(f"input_hash must be a string, found {type(model.input_hash).__name__}")
    for name in _DICT_ATTRS:
        if not isinstance(getattr(model, name), dict):
            fail(f"{name} must be a dict, found {type(getattr(model, name)).__name__}")


def _check_arrays(model: ReducedModel, fail: Fail) -> None:
    for name in _ARRAYS:
        a = getattr(model, name)
        check_real_array(f"/{name}", a, fail)
        if a.ndim != _NDIM[name]:
            fail(f"/{name} has shape {a.shape}, expected {_NDIM[name]} dimensions")


def _check_matrices(model: ReducedModel, fail: Fail) -> None:
    """Shapes against the field names, symmetry of Mr and Kr, Mr positive definite."""
    names = model.field_names
    n, nf, mass = 3 * len(names), len(names), model.mass
    if mass.shape[0] != mass.shape[1]:
        fail(f"/mass is not square: shape {mass.shape}")
    if mass.shape != (n, n):
        fail(f"/mass has shape {mass.shape}, expected ({n}, {n}): three coordinates for each "
             f"of {nf} fields {list(names)}")
    if model.stiffness.shape != mass.shape:
        fail(f"/stiffness has shape {model.stiffness.shape}, expected {mass.shape} like /mass")
    if model.gravity.shape != (n, 3):
        fail(f"/gravity has shape {model.gravity.shape}, expected ({n}, 3)")
    if model.fields.shape[1] != nf:
        fail(f"/fields has shape {model.fields.shape}, expected ({model.fields.shape[0]}, "
             f"{nf}): one column per field name")
    if model.nodes_m.shape != (model.fields.shape[0], 3):
        fail(f"/nodes_m has shape {model.nodes_m.shape}, expected ({model.fields.shape[0]}, 3): "
             f"one row per row of /fields")
    for name in ("mass", "stiffness"):
        check_symmetric(f"/{name}", getattr(model, name), fail)
    try:
        np.linalg.cholesky(mass)
    except np.linalg.LinAlgError:
        fail("/mass is not positive definite (Cholesky fails)")


def _check_group(name: str, g: NodeGroup, n_nodes: int, fail: Fail) -> None:
    where_g = f"/groups/{name}"
    if not isinstance(name, str) or not name or "/" in name or name == ".":
        fail(f"group name {name!r} must be a non-empty string without '/'")
    if not isinstance(g.nodes, np.ndarray) or g.nodes.dtype.kind not in "iu":
        found = g.nodes.dtype if isinstance(g.nodes, np.ndarray) else type(g.nodes).__name__
        fail(f"{where_g}/nodes must be an integer array, found {found}")
    if not isinstance(g.weights, np.ndarray) or g.weights.dtype.kind not in "fiu":
        fail(f"{where_g}/weights must be an array of real numbers")
    if g.nodes.ndim != 1 or g.nodes.size == 0 or g.weights.shape != g.nodes.shape:
        fail(f"{where_g} has nodes of shape {g.nodes.shape} and weights of shape "
             f"{g.weights.shape}, expected two non-empty vectors of the same length")
    outside = g.nodes[(g.nodes < 0) | (g.nodes >= n_nodes)]
    if outside.size:
        fail(f"{where_g}/nodes refers to node {outside[0]}, outside 0..{n_nodes - 1}")
    if not np.all(np.isfinite(g.weights)):
        fail(f"{where_g}/weights holds non-finite values")
    if np.any(g.weights < 0):
        fail(f"{where_g}/weights must be >= 0, found {g.weights.min():.6g}")
    total = float(g.weights.sum())
    if abs(total - 1.0) > _WEIGHT_SUM_TOL:
        fail(f"{where_g}/weights must sum to 1 (within {_WEIGHT_SUM_TOL:g}), found "
             f"{total:.12g}")


def _json_attributes(model: ReducedModel) -> dict[str, str]:
    """The model's JSON attributes as strings; ReducedModelError if one is not JSON-able."""
    out = {}
    for name in _JSON_ATTRS:
        value = getattr(model, name)
        try:
            out[name] = json_text(list(value) if name == "field_names" else value)
        except (TypeError, ValueError) as exc:
            raise ReducedModelError(f"reduced model: {name} is not JSON-serializable: "
                                    f"{exc}") from exc
    return out


def write_reduced(path: str | Path, model: ReducedModel) -> None:
    """Validate ``model``, then write it to ``path`` atomically (temporary file, then rename).

    Nothing is written for an invalid model; on any failure, including an interrupt, the
    temporary file is removed and a previous file at ``path`` is left untouched.
    """
    path = Path(path)
    validate_model(model)
    attributes = _json_attributes(model)
    with atomic_file(path) as tmp, created(tmp) as f:
        f.attrs["schema_version"] = schema_for(model)
        f.attrs["input_hash"] = model.input_hash
        for name, text in attributes.items():
            f.attrs[name] = text
        for name in _ARRAYS:
            f.create_dataset(name, data=np.asarray(getattr(model, name), dtype=np.float64))
        write_groups(f, model.groups)
        if model.svk is not None:
            write_svk(f, model.svk)
        seal(f)


def write_groups(f: h5py.File, groups: dict[str, NodeGroup]) -> None:
    """``/groups/<name>/nodes`` (int64) and ``/groups/<name>/weights`` of every node group."""
    folder = f.create_group("groups")
    for name, g in groups.items():
        folder.create_dataset(f"{name}/nodes", data=g.nodes.astype(np.int64))
        folder.create_dataset(f"{name}/weights", data=g.weights.astype(np.float64))


def schema_for(model: ReducedModel) -> int:
    """The schema a file of ``model`` is written with: SVK_SINCE with the SVK coefficients,
    the one before without them (which readers of that schema still read)."""
    return SVK_SINCE - 1 if model.svk is None else SCHEMA_VERSION


def _read_svk(f: h5py.File, where: str) -> SVKCoefficients:
    """The coefficients of a schema-3 file that has them; ReducedModelError if incomplete."""
    def fail(message: str) -> NoReturn:
        raise ReducedModelError(f"{where}: {message}")

    missing = [name for name in SVK_DATASETS if name not in f]
    missing += [f"attribute {name}" for name in (SVK_CONSTANT, SVK_FIELDS)
                if name not in f.attrs]
    if missing:
        fail("the SVK coefficients (which schema 3 holds) are incomplete: missing "
             + ", ".join(missing))
    upper, linear = (_dataset(f, name, float, where) for name in SVK_DATASETS)
    return from_upper(upper, linear, f.attrs[SVK_CONSTANT], f.attrs[SVK_FIELDS], fail)


def read_reduced(path: str | Path) -> ReducedModel:
    """Read and validate a reduced-model file; ReducedModelError names the path and the problem."""
    path = Path(path)
    with open_versioned(path, ReducedModelError, "reduced model", "schema", SCHEMA_VERSION,
                        checksums_since=CHECKSUMS_SINCE) as (f, version):
        model = _read_open(f, version, str(path))
    validate_model(model, str(path))
    return model


def _read_open(f: h5py.File, version: int, where: str) -> ReducedModel:
    """The model in the open file ``f`` of schema ``version``, after checking nothing is missing."""
    def fail(message: str) -> NoReturn:
        raise ReducedModelError(f"{where}: {message}")

    missing = [f"attribute {name}" for name in ("input_hash", *_JSON_ATTRS)
               if name not in f.attrs]
    missing += [f"dataset /{name}" for name in _ARRAYS if name not in f]
    missing += ["group /groups"] if "groups" not in f else []
    if missing:
        fail("missing " + ", ".join(missing))
    if not isinstance(f["groups"], h5py.Group):
        fail("/groups is not a group")

    attrs: dict[str, Any] = {}
    for name in _JSON_ATTRS:
        text = f.attrs[name]
        if not isinstance(text, (str, bytes)):
            fail(f"attribute {name} is not a JSON string")
        try:
            attrs[name] = json.loads(text)
        except json.JSONDecodeError as exc:
            fail(f"attribute {name} is not valid JSON: {exc}")
    field_names = attrs.pop("field_names")
    if not isinstance(field_names, list):
        fail(f"attribute field_names is not a list: {field_names!r}")
    input_hash = f.attrs["input_hash"]
    if not isinstance(input_hash, str):
        fail("attribute input_hash is not a string")

    arrays = {name: _dataset(f, name, float, where) for name in _ARRAYS}
    groups = {}
    for name, g in f["groups"].items():
        if not isinstance(g, h5py.Group):
            fail(f"/groups/{name} is not a group")
        absent = [f"/groups/{name}/{part}" for part in ("nodes", "weights") if part not in g]
        if absent:
            fail("missing dataset " + ", ".join(absent))
        groups[name] = NodeGroup(nodes=_dataset(g, "nodes", np.int64, where),
                                 weights=_dataset(g, "weights", float, where))
    svk = _read_svk(f, where) if version >= SVK_SINCE else None
    return ReducedModel(**arrays, field_names=tuple(field_names), groups=groups,
                        input_hash=input_hash, schema_version=version, svk=svk, **attrs)


def _dataset(parent: h5py.Group, name: str, dtype: type, where: str) -> np.ndarray:
    """Dataset ``name`` of ``parent`` as ``dtype`` if its numbers convert exactly in kind.

    Integers are required for an integer ``dtype`` and real numbers for a float one; data of
    another kind is returned unconverted, for :func:`validate_model` to name.
    """
    obj = parent[name]
    if not isinstance(obj, h5py.Dataset):
        raise ReducedModelError(f"{where}: {obj.name} is not a dataset")
    if obj.chunks is None and obj.size * obj.dtype.itemsize > obj.file.id.get_filesize():
        raise ReducedModelError(f"{where}: {obj.name} claims shape {obj.shape}, more data than "
                                f"the whole file holds: the file is damaged")
    data = np.asarray(obj[()])
    kinds = "iu" if np.dtype(dtype).kind in "iu" else "fiu"
    return data.astype(dtype) if data.dtype.kind in kinds else data
