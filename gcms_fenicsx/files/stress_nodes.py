"""The stress modes' mesh part and its file, ``stress_modes.h5`` (docs/design.md §9): the nodes
a scene records stresses at, the operator B that gives a nodal field's gradient there
(``fe.nodal_gradients``), and, for whole-body stress fields, the mesh's cells.

B does not depend on the modes: it is the mesh's, so the file is keyed by the mesh and the
nodes asked for (``config.plan.stress_key``) and serves every reduced model of that mesh;
the gradients of a model's fields, D = B F, are formed when a run starts (one sparse product,
``dynamics.run.stress_recovery``). A scene that asks for no stress has no such file.

File layout (schema 1): root attributes ``schema_version``, ``key``, ``node_count`` (the
mesh's nodes N) and ``groups`` (JSON: the recorded groups' names in order); datasets
``/gradient/indptr``, ``/gradient/indices``, ``/gradient/data`` (B in CSR, 3 r × N, three
rows per node of ``/gradient_nodes``, x, y, z), ``/gradient_nodes`` (r mesh-file indices),
``/requested`` (the recorded nodes, k positions in ``/gradient_nodes``), ``/groups/<name>``
(each group's nodes, positions in the recorded nodes) and ``/cells`` (C × 10 mesh-file
indices in VTK's Tetrahedron_10 order, C × 4 on a P1 mesh; C = 0 without whole-body fields). Sealed with content
checksums (``files.versioned``). NumPy and h5py only.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.files.versioned import created, open_versioned, seal

SCHEMA_VERSION = 1
#: Rows of B multiplied at once by :meth:`SparseRows.dot`: its products hold about this
#: many nonzeros times the columns of the right-hand side.
ROWS_NONZEROS = 1 << 16


class StressNodesError(ValueError):
    """A stress_modes.h5 that is missing data, malformed or of a newer schema."""


@dataclass(frozen=True)
class SparseRows:
    """A sparse matrix in CSR form, with the one product the recovery needs, in NumPy."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    shape: tuple[int, int]

    def dot(self, X: np.ndarray) -> np.ndarray:
        """B X for a dense X (N × m), a block of rows at a time."""
        X = np.asarray(X)
        out = np.zeros((self.shape[0], X.shape[1]))
        start, rows = 0, self.shape[0]
        while start < rows:
            stop = int(np.searchsorted(self.indptr, self.indptr[start] + ROWS_NONZEROS,
                                       side="right")) - 1
            stop = min(max(stop, start + 1), rows)
            lo, hi = self.indptr[start], self.indptr[stop]
            products = self.data[lo:hi, None] * X[self.indices[lo:hi]]
            counts = np.diff(self.indptr[start:stop + 1])
            full = counts > 0
            if hi > lo:
                out[start:stop][full] = np.add.reduceat(products, (self.indptr[start:stop]
                                                                   - lo)[full], axis=0)
            start = stop
        return out


@dataclass(frozen=True)
class StressNodes:
    """The recorded nodes and the gradient operator at them (module docstring)."""

    key: str
    node_count: int
    gradient_nodes: np.ndarray     # (r,) mesh-file indices: B's nodes, three rows each
    requested: np.ndarray          # (k,) the recorded nodes: positions in gradient_nodes
    groups: dict[str, np.ndarray]  # name -> positions in the recorded nodes
    gradient: SparseRows           # B, 3 r × node_count
    cells: np.ndarray              # (C, 4 or 10) VTK-ordered, C = 0 without whole-body fields

    @property
    def nodes(self) -> np.ndarray:
        """The recorded nodes' mesh-file indices (k,)."""
        return self.gradient_nodes[self.requested]

    def renumbered(self, order: np.ndarray) -> StressNodes:
        """The same nodes and operator in another numbering of the mesh's nodes, whose node j
        is node ``order[j]`` of this one (a full-order body's: ``fe.node_order``); the
        recorded nodes and groups keep their positions."""
        new = np.empty_like(order)
        new[order] = np.arange(len(order))
        g = self.gradient
        return replace(self, gradient_nodes=new[self.gradient_nodes],
                       gradient=SparseRows(g.indptr, new[g.indices], g.data, g.shape),
                       cells=new[self.cells])

    @property
    def nbytes(self) -> int:
        g = self.gradient
        return int(g.indptr.nbytes + g.indices.nbytes + g.data.nbytes + self.cells.nbytes
                   + self.gradient_nodes.nbytes + self.requested.nbytes)


def write_stress_nodes(path: str | Path, nodes: StressNodes) -> None:
    """Write ``nodes`` to ``path`` atomically, sealed with content checksums."""
    with atomic_file(Path(path)) as tmp, created(tmp) as f:
        f.attrs["schema_version"] = SCHEMA_VERSION
        f.attrs["key"] = nodes.key
        f.attrs["node_count"] = nodes.node_count
        f.attrs["groups"] = json.dumps(list(nodes.groups))
        for name in ("indptr", "indices", "data"):
            f.create_dataset(f"gradient/{name}", data=getattr(nodes.gradient, name))
        f.create_dataset("gradient_nodes", data=nodes.gradient_nodes.astype(np.int64))
        f.create_dataset("requested", data=nodes.requested.astype(np.int64))
        for name, members in nodes.groups.items():
            f.create_dataset(f"groups/{name}", data=members.astype(np.int64))
        f.create_dataset("cells", data=nodes.cells.astype(np.int64))
        seal(f)


def read_stress_nodes(path: str | Path) -> StressNodes:
    """The content of a stress_modes.h5, checksums verified; StressNodesError naming what is
    wrong."""
    path = Path(path)
    with open_versioned(path, StressNodesError, "stress modes file", "schema", SCHEMA_VERSION,
                        checksums_since=1) as (f, _):
        missing = [f"/{n}" for n in ("gradient/indptr", "gradient/indices", "gradient/data",
                                     "gradient_nodes", "requested", "cells") if n not in f]
        missing += [f"attribute {n}" for n in ("key", "node_count", "groups") if n not in f.attrs]
        if missing:
            raise StressNodesError(f"{path}: missing " + ", ".join(missing))
        names = json.loads(f.attrs["groups"])
        if not all(f"groups/{n}" in f for n in names):
            raise StressNodesError(f"{path}: a group of the groups attribute is missing")
        N = int(f.attrs["node_count"])
        rows = f["gradient_nodes"][()]
        gradient = SparseRows(f["gradient/indptr"][()], f["gradient/indices"][()],
                              f["gradient/data"][()], (3 * len(rows), N))
        nodes = StressNodes(key=str(f.attrs["key"]), node_count=N, gradient_nodes=rows,
                            requested=f["requested"][()],
                            groups={n: f[f"groups/{n}"][()] for n in names},
                            gradient=gradient, cells=f["cells"][()])
    _check(nodes, str(path))
    return nodes


def _check(nodes: StressNodes, where: str) -> None:
    """StressNodesError if the arrays do not fit together."""
    g, N, r = nodes.gradient, nodes.node_count, len(nodes.gradient_nodes)
    k = len(nodes.requested)
    problems = []
    if len(g.indptr) != 3 * r + 1 or g.indptr[0] != 0 or g.indptr[-1] != len(g.data) \
            or np.any(np.diff(g.indptr) < 0) or len(g.indices) != len(g.data):
        problems.append("/gradient is not a CSR matrix of three rows per gradient node")
    if len(g.indices) and (g.indices.min() < 0 or g.indices.max() >= N):
        problems.append("/gradient has columns outside the mesh's nodes")
    if not np.all(np.isfinite(g.data)):
        problems.append("/gradient holds values that are not finite")
    if r and (nodes.gradient_nodes.min() < 0 or nodes.gradient_nodes.max() >= N):
        problems.append("/gradient_nodes are not nodes of the mesh")
    if k and (nodes.requested.min() < 0 or nodes.requested.max() >= r):
        problems.append("/requested are not positions of /gradient_nodes")
    if any(len(m) and (m.min() < 0 or m.max() >= k) for m in nodes.groups.values()):
        problems.append("a group holds positions outside the recorded nodes")
    if nodes.cells.ndim != 2 or nodes.cells.shape[1] not in (4, 10):
        problems.append("/cells are not tetrahedra of 4 or 10 nodes")
    elif nodes.cells.size and (nodes.cells.min() < 0 or nodes.cells.max() >= N):
        problems.append("/cells are not nodes of the mesh")
    if problems:
        raise StressNodesError(f"{where}: " + "; ".join(problems))
