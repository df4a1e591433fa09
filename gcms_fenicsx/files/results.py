"""Simulation results: what was recorded, ``results.h5`` and ``summary.json``.

NumPy and h5py only. A run with an output file streams its rows into it block by block
(:class:`ResultsWriter`: resizable datasets of a temporary file beside the target, renamed at
the end), so its memory does not grow with the number of steps; a run without one keeps them
in memory (:class:`MemorySink`, a :class:`Trajectory`). The reader checks the schema and the
content checksums and names what is wrong with a file that does not fit.

File layout (schema 2): root attributes ``schema_version``, ``complete`` (bool),
``message``, ``model_hash`` (the reduced model's input hash), ``scene`` and ``rows``
(JSON); datasets ``/time``, ``/newton_iterations``; ``/energy/<name>``,
``/momentum/linear``, ``/momentum/angular``; ``/groups/<name>/position`` and
``.../velocity``; ``/constraints/multipliers`` (one column per row, described by the
``rows`` attribute); ``/coordinates/q``, ``/coordinates/v`` when recorded;
``/fields/time``, ``/fields/displacement`` (times × nodes × 3) and ``/fields/nodes_m``
when requested; ``/stress/...`` when the scene asks for stresses (``dynamics.run.
stress_recovery``: the time series ``/stress/von_mises`` and ``/stress/groups/<name>/...``,
and ``/stress/nodes``, ``/stress/node_index``, ``/stress/peak_von_mises``,
``/stress/peak_time``, ``/stress/groups/<name>/nodes``). Every time series has one row per recorded step. Every dataset carries the
SHA-256 of its contents and the root the SHA-256 of its attributes (``files.versioned.seal``;
the streamed datasets are hashed as their rows are written, nothing is read back). Schema 1
(before checksums) is still read.
"""
from __future__ import annotations

import json
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn, Protocol

import h5py
import numpy as np

from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.files.versioned import (DigestBuilder, created, dataset_digest,
                                          open_versioned, seal)

RESULTS_SCHEMA_VERSION: int = 2
#: The first results schema whose files carry content checksums.
CHECKSUMS_SINCE: int = 2
ENERGY_NAMES = ("kinetic", "elastic", "gravity", "load_work", "constraint_work",
                "damping_dissipation", "balance_error")
MULTIPLIERS = "constraints/multipliers"
#: Rows are written (and chunked in the file) in blocks of about this many bytes.
BLOCK_BYTES = 1 << 20


class ResultsError(ValueError):
    """A results file that is missing data, malformed or of a newer schema."""


@dataclass(frozen=True)
class Series:
    """One recorded time series: its dataset name and the shape and dtype of one row."""

    name: str
    shape: tuple[int, ...] = ()
    dtype: str = "<f8"

    @property
    def row_bytes(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64)) * np.dtype(self.dtype).itemsize


def block_rows(layout: tuple[Series, ...], rows: int) -> int:
    """Rows per block (and file chunk) of ``layout``: about ``BLOCK_BYTES``, at least 1, at most
    ``rows``."""
    return max(1, min(rows, BLOCK_BYTES // sum(s.row_bytes for s in layout)))


def series_layout(groups: tuple[str, ...], energy: bool, multipliers: int,
                  coordinates: int) -> tuple[Series, ...]:
    """Every time series of a run (module docstring), in file order: ``multipliers`` columns,
    and q, q̇ of ``coordinates`` entries when that is not 0."""
    return (Series("time"), Series("newton_iterations", (), "<i4"),
            *(Series(f"groups/{g}/{s}", (3,)) for g in groups for s in ("position", "velocity")),
            *(Series(f"energy/{n}") for n in (ENERGY_NAMES if energy else ())),
            Series("momentum/linear", (3,)), Series("momentum/angular", (3,)),
            Series(MULTIPLIERS, (multipliers,)),
            *(Series(f"coordinates/{n}", (coordinates,)) for n in ("q", "v") if coordinates))


@dataclass(frozen=True)
class RunInfo:
    """What a run says about itself besides its series (the file's root attributes)."""

    complete: bool
    message: str
    model_hash: str
    scene: dict
    rows: list[dict]


@dataclass
class Trajectory:
    """Recorded time series of one simulation (rows: recorded steps)."""

    time: np.ndarray
    newton_iterations: np.ndarray
    groups: dict[str, dict[str, np.ndarray]]
    energy: dict[str, np.ndarray]
    momentum: dict[str, np.ndarray]
    multipliers: np.ndarray
    rows: list[dict]
    coordinates: dict[str, np.ndarray] = field(default_factory=dict)
    field_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    displacement: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    nodes_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    stress: dict[str, np.ndarray] = field(default_factory=dict)   # by dataset name
    complete: bool = True
    message: str = ""
    model_hash: str = ""
    scene: dict = field(default_factory=dict)
    schema_version: int = RESULTS_SCHEMA_VERSION

    def joint_force(self, joint: str) -> np.ndarray:
        """The force (N, global frame) the joint exerts on the body: −λ of its position rows."""
        return joint_force(self.rows, self.multipliers, joint)

    def series(self) -> dict[str, np.ndarray]:
        """The time series by dataset name (module docstring)."""
        return {"time": self.time, "newton_iterations": self.newton_iterations,
                **{f"groups/{g}/{s}": a for g, d in self.groups.items() for s, a in d.items()},
                **{f"energy/{n}": a for n, a in self.energy.items()},
                **{f"momentum/{n}": a for n, a in self.momentum.items()},
                MULTIPLIERS: self.multipliers,
                **{f"coordinates/{n}": a for n, a in self.coordinates.items()}}

    @classmethod
    def from_series(cls, series: Mapping[str, np.ndarray], info: RunInfo,
                    schema_version: int = RESULTS_SCHEMA_VERSION) -> "Trajectory":
        """The trajectory of the time series ``series`` (by dataset name) and ``info``."""
        nested: dict[str, dict[str, np.ndarray]] = {"groups": {}, "energy": {}, "momentum": {},
                                                    "coordinates": {}}
        for name, data in series.items():
            kind, _, rest = name.partition("/")
            if kind == "groups":
                group, _, which = rest.partition("/")
                nested["groups"].setdefault(group, {})[which] = data
            elif kind in nested:
                nested[kind][rest] = data
        return cls(time=series["time"], newton_iterations=series["newton_iterations"],
                   groups=nested["groups"], energy=nested["energy"],
                   momentum=nested["momentum"], multipliers=series[MULTIPLIERS],
                   rows=info.rows, coordinates=nested["coordinates"],
                   stress={n: a for n, a in series.items() if n.startswith("stress/")},
                   complete=info.complete,
                   message=info.message, model_hash=info.model_hash, scene=info.scene,
                   schema_version=schema_version)


def joint_force(rows: list[dict], multipliers: np.ndarray, joint: str) -> np.ndarray:
    """−λ of the force rows of ``joint``: the force (N, global frame) it exerts on the body."""
    cols = [i for i, r in enumerate(rows) if r["joint"] == joint and r["kind"] == "force"]
    if not cols:
        raise ResultsError(f"no joint {joint!r} with force rows in these results")
    return -multipliers[:, cols]


class Sink(Protocol):
    """Where a recorder's rows go: blocks of rows of every series, field snapshots, the end."""

    def append(self, block: Mapping[str, np.ndarray]) -> None: ...

    def snapshot(self, t: float, displacement: np.ndarray) -> None: ...

    def put(self, name: str, data: np.ndarray) -> None: ...

    def close(self, info: RunInfo) -> Trajectory | None: ...


class MemorySink:
    """Rows kept in memory, preallocated for ``rows`` rows; :meth:`close` gives the Trajectory.
    ``nodes_m``: the undeformed nodes when field snapshots are requested, else None."""

    def __init__(self, layout: tuple[Series, ...], rows: int,
                 nodes_m: np.ndarray | None) -> None:
        self.arrays = {s.name: np.empty((rows, *s.shape), s.dtype) for s in layout}
        self.filled = 0
        self.nodes_m = nodes_m
        self.snapshots: list[tuple[float, np.ndarray]] = []
        self.datasets: dict[str, np.ndarray] = {}

    def append(self, block: Mapping[str, np.ndarray]) -> None:
        k = len(block["time"])
        for name, rows in block.items():
            self.arrays[name][self.filled:self.filled + k] = rows
        self.filled += k

    def snapshot(self, t: float, displacement: np.ndarray) -> None:
        self.snapshots.append((t, displacement))

    def put(self, name: str, data: np.ndarray) -> None:
        self.datasets[name] = np.asarray(data)

    def close(self, info: RunInfo) -> Trajectory:
        traj = Trajectory.from_series({n: a[:self.filled] for n, a in self.arrays.items()}, info)
        if self.nodes_m is not None:
            traj.field_time = np.array([t for t, _ in self.snapshots])
            traj.displacement = np.array([d for _, d in self.snapshots]).reshape(
                -1, len(self.nodes_m), 3)
            traj.nodes_m = self.nodes_m
        traj.stress.update(self.datasets)
        return traj


class ResultsWriter:
    """Rows streamed into an open results file: one resizable dataset per series (chunks of
    ``chunk_rows`` rows), field snapshots one at a time; every dataset's checksum is built
    from what is written (:class:`~gcms_fenicsx.files.versioned.DigestBuilder`), and
    :meth:`close` writes the attributes and seals the file."""

    def __init__(self, f: h5py.File, layout: tuple[Series, ...], chunk_rows: int,
                 nodes_m: np.ndarray | None) -> None:
        self.f, self.layout, self.rows = f, layout, 0
        self.digests = {s.name: DigestBuilder() for s in layout}
        self.sealed: dict[str, str] = {}
        for s in layout:
            if s.row_bytes:   # HDF5 has no chunks with a zero extent: those come at close
                f.create_dataset(s.name, shape=(0, *s.shape), maxshape=(None, *s.shape),
                                 chunks=(chunk_rows, *s.shape), dtype=s.dtype)
        self.snapshots = 0
        self.field_digests: dict[str, DigestBuilder] = {}
        if nodes_m is not None:
            nodes = np.ascontiguousarray(nodes_m, "<f8")
            f.create_dataset("fields/time", shape=(0,), maxshape=(None,), chunks=(64,),
                             dtype="<f8")
            f.create_dataset("fields/displacement", shape=(0, *nodes.shape),
                             maxshape=(None, *nodes.shape), chunks=(1, *nodes.shape),
                             dtype="<f8", compression="gzip", compression_opts=4)
            f.create_dataset("fields/nodes_m", data=nodes)
            self.sealed["/fields/nodes_m"] = dataset_digest(nodes)
            self.field_digests = {"fields/time": DigestBuilder(),
                                  "fields/displacement": DigestBuilder()}

    def append(self, block: Mapping[str, np.ndarray]) -> None:
        k = len(block["time"])
        for s in self.layout:
            rows = np.ascontiguousarray(block[s.name], dtype=s.dtype)
            if s.row_bytes:
                ds = self.f[s.name]
                ds.resize(self.rows + k, axis=0)
                ds[self.rows:] = rows
            self.digests[s.name].update(rows)
        self.rows += k

    def snapshot(self, t: float, displacement: np.ndarray) -> None:
        k = self.snapshots
        for name, data in (("fields/time", np.array([t], "<f8")),
                           ("fields/displacement", np.ascontiguousarray(displacement,
                                                                        "<f8")[None])):
            ds = self.f[name]
            ds.resize(k + 1, axis=0)
            ds[k:] = data
            self.field_digests[name].update(data)
        self.snapshots += 1

    def put(self, name: str, data: np.ndarray) -> None:
        """A dataset that is not a time series, written whole."""
        data = np.ascontiguousarray(data)
        self.f.create_dataset(name, data=data)
        self.sealed[f"/{name}"] = dataset_digest(data)

    def close(self, info: RunInfo) -> None:
        f = self.f
        for s in self.layout:
            if not s.row_bytes:
                f.create_dataset(s.name, shape=(self.rows, *s.shape), dtype=s.dtype)
            self.sealed[f"/{s.name}"] = self.digests[s.name].hexdigest(s.dtype,
                                                                        (self.rows, *s.shape))
        for name, builder in self.field_digests.items():
            self.sealed[f"/{name}"] = builder.hexdigest(f[name].dtype, f[name].shape)
        f.attrs["schema_version"] = RESULTS_SCHEMA_VERSION
        f.attrs["complete"] = bool(info.complete)
        f.attrs["message"] = info.message
        f.attrs["model_hash"] = info.model_hash
        f.attrs["scene"] = json.dumps(info.scene, allow_nan=False)
        f.attrs["rows"] = json.dumps(info.rows, allow_nan=False)
        seal(f, self.sealed)


def write_results(path: str | Path, traj: Trajectory) -> None:
    """Write ``traj`` to ``path`` atomically; a failure leaves a previous file untouched."""
    series = traj.series()
    layout = tuple(Series(n, a.shape[1:], a.dtype.str) for n, a in series.items())
    info = RunInfo(traj.complete, traj.message, traj.model_hash, traj.scene, traj.rows)
    block = block_rows(layout, len(traj.time))
    with atomic_file(Path(path)) as tmp, created(tmp) as f:
        writer = ResultsWriter(f, layout, block, traj.nodes_m if len(traj.nodes_m) else None)
        for start in range(0, len(traj.time), block):
            writer.append({n: a[start:start + block] for n, a in series.items()})
        for t, d in zip(traj.field_time, traj.displacement):
            writer.snapshot(float(t), d)
        for name, data in traj.stress.items():
            writer.put(name, data)
        writer.close(info)


def _stored_series(f: h5py.File, columns: int) -> Iterator[tuple[str, tuple[int, ...]]]:
    """(name, row shape) of every time series in the file: what it holds under the groups
    of the layout, with the row shapes the layout gives them (coordinates: as stored)."""
    yield "time", ()
    yield "newton_iterations", ()
    for g in f.get("groups", {}):
        for s in f["groups"][g]:
            yield f"groups/{g}/{s}", (3,)
    for n in f.get("energy", {}):
        yield f"energy/{n}", ()
    for n in f.get("momentum", {}):
        yield f"momentum/{n}", (3,)
    yield MULTIPLIERS, (columns,)
    for n in f.get("coordinates", {}):
        yield f"coordinates/{n}", f[f"coordinates/{n}"].shape[1:2]


@contextmanager
def open_results(path: str | Path, verify: bool = True) -> Iterator[tuple[h5py.File, int]]:
    """``(file, schema_version)`` of a results file, its checksums verified unless ``verify``
    is false (a reader of parts of a file this run has just written: the plots)."""
    with open_versioned(Path(path), ResultsError, "results file", "results schema",
                        RESULTS_SCHEMA_VERSION,
                        checksums_since=CHECKSUMS_SINCE if verify else None) as opened:
        yield opened


def read_results(path: str | Path) -> Trajectory:
    """Read a results file; ResultsError names the file and what is wrong with it."""
    path = Path(path)

    def fail(message: str) -> NoReturn:
        raise ResultsError(f"{path}: {message}")

    with open_results(path) as (f, version):
        missing = [n for n in ("time", "newton_iterations", MULTIPLIERS) if n not in f]
        missing += [a for a in ("complete", "message", "rows", "scene", "model_hash")
                    if a not in f.attrs]
        if missing:
            fail("missing " + ", ".join(missing))
        rows = json.loads(f.attrs["rows"])
        k = len(f["time"])
        series = {}
        for name, shape in _stored_series(f, len(rows)):
            data = f[name][()]
            if data.shape != (k, *shape):
                fail(f"/{name} has shape {data.shape}, expected {(k, *shape)}")
            series[name] = data
        info = RunInfo(bool(f.attrs["complete"]), str(f.attrs["message"]),
                       str(f.attrs["model_hash"]), json.loads(f.attrs["scene"]), rows)
        traj = Trajectory.from_series(series, info, version)
        if "fields" in f:
            traj.field_time = f["fields/time"][()]
            traj.displacement = f["fields/displacement"][()]
            traj.nodes_m = f["fields/nodes_m"][()]
        if "stress" in f:
            f["stress"].visititems(lambda name, item: traj.stress.__setitem__(
                f"stress/{name}", item[()]) if isinstance(item, h5py.Dataset) else None)
        return traj
