"""Simulation results: what was recorded, ``results.h5`` and ``summary.json``.

NumPy and h5py only. The file is written atomically (temporary file, then rename); the
reader checks the schema and names what is wrong with a file that does not fit.

File layout (schema 1): root attributes ``schema_version``, ``complete`` (bool),
``message``, ``model_hash`` (the reduced model's input hash), ``scene`` and ``rows``
(JSON); datasets ``/time``, ``/newton_iterations``; ``/energy/<name>``,
``/momentum/linear``, ``/momentum/angular``; ``/groups/<name>/position`` and
``.../velocity``; ``/constraints/multipliers`` (one column per row, described by the
``rows`` attribute); ``/coordinates/q``, ``/coordinates/v`` when recorded;
``/fields/time``, ``/fields/displacement`` (times × nodes × 3) and ``/fields/nodes_m``
when requested. Every time series has one row per recorded step.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import h5py
import numpy as np

from gcms_fenicsx.outputs import atomic_file
from gcms_fenicsx.versioned_file import open_versioned

RESULTS_SCHEMA_VERSION: int = 1
ENERGY_NAMES = ("kinetic", "elastic", "gravity", "load_work", "constraint_work",
                "damping_dissipation", "balance_error")


class ResultsError(ValueError):
    """A results file that is missing data, malformed or of a newer schema."""


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
    complete: bool = True
    message: str = ""
    model_hash: str = ""
    scene: dict = field(default_factory=dict)
    schema_version: int = RESULTS_SCHEMA_VERSION

    def joint_force(self, joint: str) -> np.ndarray:
        """The force (N, global frame) the joint exerts on the body: −λ of its position rows."""
        cols = [i for i, r in enumerate(self.rows) if r["joint"] == joint and r["kind"] == "force"]
        if not cols:
            raise ResultsError(f"no joint {joint!r} with force rows in these results")
        return -self.multipliers[:, cols]


def energy_drift(energy: dict[str, np.ndarray]) -> float | None:
    """max |balance error| over the run / max (kinetic + elastic): the relative energy drift."""
    if not energy or len(energy["balance_error"]) == 0:
        return None
    scale = max(float(np.max(energy["kinetic"] + energy["elastic"])),
                float(np.max(np.abs(energy["load_work"]))),
                float(np.max(np.abs(energy["constraint_work"]))))
    err = float(np.max(np.abs(energy["balance_error"])))
    return err / scale if scale > 0 else err


def write_results(path: str | Path, traj: Trajectory) -> None:
    """Write ``traj`` to ``path`` atomically; a failure leaves a previous file untouched."""
    path = Path(path)
    with atomic_file(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["schema_version"] = RESULTS_SCHEMA_VERSION
        f.attrs["complete"] = bool(traj.complete)
        f.attrs["message"] = traj.message
        f.attrs["model_hash"] = traj.model_hash
        f.attrs["scene"] = json.dumps(traj.scene)
        f.attrs["rows"] = json.dumps(traj.rows)
        f.create_dataset("time", data=traj.time)
        f.create_dataset("newton_iterations", data=traj.newton_iterations)
        for name, data in traj.energy.items():
            f.create_dataset(f"energy/{name}", data=data)
        for name, data in traj.momentum.items():
            f.create_dataset(f"momentum/{name}", data=data)
        for group, series in traj.groups.items():
            for name, data in series.items():
                f.create_dataset(f"groups/{group}/{name}", data=data)
        f.create_dataset("constraints/multipliers", data=traj.multipliers)
        for name, data in traj.coordinates.items():
            f.create_dataset(f"coordinates/{name}", data=data)
        if len(traj.field_time):
            f.create_dataset("fields/time", data=traj.field_time)
            f.create_dataset("fields/displacement", data=traj.displacement,
                             compression="gzip", compression_opts=4)
            f.create_dataset("fields/nodes_m", data=traj.nodes_m)


def read_results(path: str | Path) -> Trajectory:
    """Read a results file; ResultsError names the file and what is wrong with it."""
    path = Path(path)

    def fail(message: str) -> NoReturn:
        raise ResultsError(f"{path}: {message}")

    with open_versioned(path, ResultsError, "results file", "results schema",
                        RESULTS_SCHEMA_VERSION) as (f, version):
        missing = [n for n in ("time", "newton_iterations", "constraints/multipliers")
                   if n not in f]
        missing += [a for a in ("complete", "message", "rows", "scene", "model_hash")
                    if a not in f.attrs]
        if missing:
            fail("missing " + ", ".join(missing))
        time = f["time"][()]
        k = len(time)

        def series(name: str, shape: tuple[int, ...] = ()) -> np.ndarray:
            data = f[name][()]
            if data.shape[:1] != (k,) or data.shape[1:] != shape:
                fail(f"/{name} has shape {data.shape}, expected {(k, *shape)}")
            return data

        rows = json.loads(f.attrs["rows"])
        groups = {g: {s: series(f"groups/{g}/{s}", (3,)) for s in f["groups"][g]}
                  for g in f.get("groups", {})}
        traj = Trajectory(
            time=time, newton_iterations=series("newton_iterations"),
            groups=groups,
            energy={n: series(f"energy/{n}") for n in f.get("energy", {})},
            momentum={n: series(f"momentum/{n}", (3,)) for n in f.get("momentum", {})},
            multipliers=series("constraints/multipliers", (len(rows),)),
            rows=rows,
            coordinates={n: f[f"coordinates/{n}"][()] for n in f.get("coordinates", {})},
            complete=bool(f.attrs["complete"]), message=str(f.attrs["message"]),
            model_hash=str(f.attrs["model_hash"]), scene=json.loads(f.attrs["scene"]),
            schema_version=version)
        if "fields" in f:
            traj.field_time = f["fields/time"][()]
            traj.displacement = f["fields/displacement"][()]
            traj.nodes_m = f["fields/nodes_m"][()]
        return traj
