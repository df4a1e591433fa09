"""``modes.h5``: the modes stage's product kept in ``--out`` for later commands to reuse.

It holds the body's :class:`~gcms_fenicsx.files.modal_basis.ModalBasis` (every GCMS
field at every node in the mesh file's order, G, FᵀF and Kr of all fields, the
eigenvalues, the node groups), the ``modes.json`` document of the solve, and the key of
the inputs it was computed from (``key``: geometry, mesh, material and the solve's
accuracy, not the mode count: fewer modes are a leading block of more). Written atomically
and sealed with content checksums (``versioned``), so a damaged or changed file is refused,
never used. NumPy and h5py only.

Layout (schema 1): root attributes ``schema_version``, ``key`` (str), ``rigid_count``
(int), ``document`` (JSON), ``attachment`` (JSON: the attachment modes' labels, whose
fields follow the eigenmodes'); datasets ``/fields``, ``/nodes_m``, ``/gram_mass``,
``/gram_euclid``, ``/stiffness``, ``/eigenvalues``, ``/center_m`` and
``/groups/<name>/nodes``, ``/groups/<name>/weights``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gcms_fenicsx.files.outputs import atomic_file, json_text
from gcms_fenicsx.files.reduced_model import NodeGroup, write_groups
from gcms_fenicsx.files.versioned import created, open_versioned, seal
from gcms_fenicsx.files.modal_basis import RIGID_FIELDS, ModalBasis

SCHEMA_VERSION = 1
_ARRAYS = ("fields", "nodes_m", "gram_mass", "gram_euclid", "stiffness", "eigenvalues",
           "center_m")


class ModesFileError(ValueError):
    """A modes.h5 that is missing, damaged, of a newer schema or inconsistent."""


@dataclass(frozen=True)
class StoredModes:
    """What modes.h5 holds: the basis, the modes.json document of its solve, its input key."""

    basis: ModalBasis
    document: dict
    key: str


def write_modes(path: str | Path, stored: StoredModes) -> None:
    """Write ``stored`` to ``path`` atomically, sealed with content checksums."""
    b = stored.basis
    with atomic_file(Path(path)) as tmp, created(tmp) as f:
        f.attrs["schema_version"] = SCHEMA_VERSION
        f.attrs["key"] = stored.key
        f.attrs["rigid_count"] = b.rigid_count
        f.attrs["document"] = json_text(stored.document)
        f.attrs["attachment"] = json_text(list(b.attachment))
        for name in _ARRAYS:
            f.create_dataset(name, data=np.asarray(getattr(b, name), dtype=np.float64))
        write_groups(f, b.groups)
        seal(f)


def read_modes(path: str | Path) -> StoredModes:
    """The content of a modes.h5, checksums verified; ModesFileError naming what is wrong."""
    path = Path(path)
    where = str(path)
    with open_versioned(path, ModesFileError, "modes file", "schema", SCHEMA_VERSION,
                        checksums_since=1) as (f, _):
        missing = [f"/{name}" for name in (*_ARRAYS, "groups") if name not in f]
        missing += [f"attribute {name}" for name in ("key", "rigid_count", "document")
                    if name not in f.attrs]
        if missing:
            raise ModesFileError(f"{where}: missing " + ", ".join(missing))
        arrays = {name: np.asarray(f[name][()], dtype=np.float64) for name in _ARRAYS}
        groups = {name: NodeGroup(nodes=np.asarray(g["nodes"][()], dtype=np.int64),
                                  weights=np.asarray(g["weights"][()], dtype=np.float64))
                  for name, g in f["groups"].items()}
        key, rigid_count = str(f.attrs["key"]), int(f.attrs["rigid_count"])
        document = json.loads(f.attrs["document"])
        attachment = tuple(json.loads(f.attrs.get("attachment", "[]")))
    basis = ModalBasis(**arrays, rigid_count=rigid_count, groups=groups, attachment=attachment)
    _check(basis, where)
    return StoredModes(basis=basis, document=document, key=key)


def _check(b: ModalBasis, where: str) -> None:
    """ModesFileError if the arrays do not fit together."""
    n, nf = b.fields.shape if b.fields.ndim == 2 else (0, -1)
    problems = []
    if nf != len(RIGID_FIELDS) + 3 * (b.mode_count + len(b.attachment)) or b.mode_count < 1:
        problems.append(f"/fields has {nf} columns for {b.mode_count} modes")
    if b.nodes_m.shape != (n, 3):
        problems.append(f"/nodes_m has shape {b.nodes_m.shape}, expected ({n}, 3)")
    for name, shape in (("gram_mass", (nf, nf)), ("gram_euclid", (nf, nf)),
                        ("stiffness", (3 * nf, 3 * nf)), ("center_m", (3,))):
        if getattr(b, name).shape != shape:
            problems.append(f"/{name} has shape {getattr(b, name).shape}, expected {shape}")
    for name, g in b.groups.items():
        if g.nodes.shape != g.weights.shape or (g.nodes.size and not
                                                  0 <= g.nodes.min() <= g.nodes.max() < n):
            problems.append(f"/groups/{name} does not index the {n} nodes")
    if problems:
        raise ModesFileError(f"{where}: " + "; ".join(problems))
