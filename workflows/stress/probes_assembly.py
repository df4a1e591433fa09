"""Probe class 8: assemblies. The crank train (``workflows/crank_train.toml``: a GCMS
crankshaft in five main bearings, four GCMS conrods of one reduced model, four pistons under
firing pressure) on coarse meshes through its spin-up and one cycle at speed, run by ``gcms
run`` as a user runs it: as written, without and with five times its damping, slower and
faster, at half and double the time step (does the step converge as a second-order method's),
with the crankshaft in the rotor basis, for four cycles (the energy balance over time), and
given inputs a user might give by mistake (a joint to a body that is not there, a piston of a
microgram, a rubber conrod, a step of a millisecond). Every run after the first starts from a
copy of its folder, so each body's reduced model is reused where its study is unchanged."""
from __future__ import annotations

import math
import shutil
import tomllib
from pathlib import Path

import h5py
import numpy as np

from stress import REPO
from stress.measures import growth_fit
from stress.readers import strict_json
from stress.runner import Run, gcms
from stress.suite import Suite

#: The coarse train: mesh sizes (m) of the crankshaft and the conrods; the long run's end (s:
#: the 40 ms spin-up and four four-stroke cycles at 3000 rpm).
CRANKSHAFT_MESH_M, CONROD_MESH_M = 0.016, 0.005
LONG_END_S = 0.2
DRIVE = "main_0"


def coarse_train(speed: float = 1.0, step: float = 1.0, end_s: float | None = None) -> dict:
    """The crank train on coarse meshes, its drive's speed × ``speed`` (ending after the
    spin-up and one cycle at that speed unless ``end_s``), its time step × ``step`` (recorded
    at the same times)."""
    raw = tomllib.loads((REPO / "workflows" / "crank_train.toml").read_text())
    for name, body in raw["bodies"].items():
        if "geometry" in body:
            size = CRANKSHAFT_MESH_M if name == "crankshaft" else CONROD_MESH_M
            body["mesh"] = {"size": size}
    drive = next(j["drive"] for j in raw["joints"] if j["name"] == DRIVE)
    drive["angular_velocity"] *= speed
    system = raw["system"]
    system["end_time"] = end_s or drive["ramp_time"] + 4.0 * math.pi / drive["angular_velocity"]
    system["time_step"] *= step
    system["record_every"] = round(system["record_every"] / step)
    return raw


def read_train(out: Path) -> dict:
    """A system run's summary (completeness, speed, drift, Newton iterations, dropped rows),
    its peak drive torque, big-end and main-bearing forces, what damping dissipated and the
    energy balance error over time (``growth_fit``, in the scale of the drift)."""
    s = strict_json(out / "summary.json")
    row = {k: s.get(k) for k in ("complete", "steps", "coordinates", "steps_per_second",
                                 "energy_drift_rel", "newton_iterations_mean", "message")}
    joints = s["joints"]
    row.update(dropped_rows=len(s["dropped_rows"]),
               drive_torque_peak_nm=joints[DRIVE]["peak_drive_torque_nm"],
               big_end_peak_n=max(v["peak_force_n"] for k, v in joints.items()
                                  if k.startswith("big_end")),
               main_peak_n=max(v["peak_force_n"] for k, v in joints.items()
                               if k.startswith("main")))
    with h5py.File(out / "system.h5") as f:
        t, e = f["time_s"][()], {k: f[f"energy/{k}"][()] for k in f["energy"]}
    largest = float(np.max(np.abs(e["balance"])))      # energy_drift_rel = largest / scale
    scale = largest / row["energy_drift_rel"] if row["energy_drift_rel"] else 1.0
    row.update(growth_fit(t, e["balance"] / scale),
               damping_dissipation_j=float(e["damping_dissipation"][-1]))
    return row


def series(out: Path) -> dict[str, np.ndarray]:
    """The recorded times, the drive torque and big-end 1's force of a finished run."""
    with h5py.File(out / "system.h5") as f:
        return {"time_s": f["time_s"][()], "torque": f[f"joints/{DRIVE}/drive_torque_nm"][()],
                "big_end": f["joints/big_end_1/force_n"][()]}


def difference(run: Path, reference: Path) -> dict:
    """max_t |run − reference| over the reference's peak, of the drive torque and of big-end
    1's force, at the recorded times both have (to 1 ns; a run's last row is its end time)."""
    a, b = series(run), series(reference)
    ia, ib = np.nonzero(np.abs(a["time_s"][:, None] - b["time_s"][None, :]) < 1e-9)
    if len(ia) < 0.9 * min(len(a["time_s"]), len(b["time_s"])):
        raise ValueError(f"the runs share {len(ia)} recorded times of "
                         f"{len(a['time_s'])} and {len(b['time_s'])}")
    out = {}
    for key in ("torque", "big_end"):
        d, r = a[key][ia] - b[key][ib], b[key][ib]
        if d.ndim == 2:
            d, r = np.linalg.norm(d, axis=1), np.linalg.norm(r, axis=1)
        out[f"{key}_difference_rel"] = float(np.abs(d).max() / np.abs(r).max())
    return out


def on_copy(suite: Suite, first: Run, study: dict, name: str, case: str, **extra) -> dict:
    """``gcms run`` of ``study`` in a copy of the first run's folder (its bodies' stages
    reused where their studies are unchanged): the class's row."""
    out = suite.path(name)
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(first.out, out)
    run = gcms("run", study, out)
    row = suite.probe("assembly", case, run, read_train, **extra)
    row["reused_models"] = run.stderr.count("reduced model: reusing")
    if run.outcome == "incomplete":             # where and why it stopped
        s = strict_json(out / "summary.json")
        row.update(stopped_at_s=s["end_time_s"], message=s["message"], steps=s["steps"])
    return row


def compared(suite: Suite, row: dict, name: str, reference: str) -> None:
    """Add to ``row`` its run's differences from the run ``reference`` (both finished)."""
    if row["outcome"] == "ok" and (suite.path(reference) / "system.h5").exists():
        row.update(difference(suite.path(name), suite.path(reference)), against=reference)


def damped(beta_factor: float) -> dict:
    """The coarse train with the crankshaft's damping × ``beta_factor``."""
    raw = coarse_train()
    crank = raw["bodies"]["crankshaft"]
    crank["damping"] = {k: v * beta_factor for k, v in crank["damping"].items()}
    return raw


def mistaken(kind: str) -> dict:
    """The coarse train with a user's mistake: a joint to a body that is not there, a piston
    of a microgram, a rubber conrod (E = 21 MPa: 1e-4 of steel), a time step of 1 ms."""
    raw = coarse_train()
    if kind == "missing body":
        raw["joints"][-1]["body"] = "piston9"
    elif kind == "light piston":
        raw["bodies"]["piston1"]["point_mass"] = 1e-9
    elif kind == "rubber conrod":
        for k in range(1, 5):
            raw["bodies"][f"conrod{k}"]["material"]["E"] = 21e6
    else:
        raw["system"].update(time_step=1e-3, record_every=1)
    return raw


def assembly(suite: Suite) -> None:
    """Class 8 (module docstring); quick: as written, undamped, half the step, one mistake."""
    first = gcms("run", coarse_train(), suite.path("train"))
    suite.probe("assembly", "as written", first, read_train)
    if not first.ok:
        return
    cases = [("train_undamped", "undamped", damped(0.0), "train"),
             ("train_half_step", "half the step", coarse_train(step=0.5), "train")]
    if not suite.quick:
        cases += [("train_damped_x5", "damping ×5", damped(5.0), "train"),
                  ("train_double_step", "double the step", coarse_train(step=2.0),
                   "train_half_step"),
                  ("train_2700", "2700 rpm", coarse_train(speed=0.9), None),
                  ("train_3600", "3600 rpm", coarse_train(speed=1.2), None),
                  ("train_rotor", "crankshaft in the rotor basis", rotor_train(), "train"),
                  ("train_long", "four cycles", coarse_train(end_s=LONG_END_S), None)]
    for name, case, study, reference in cases:
        row = on_copy(suite, first, study, name, case)
        if reference:
            compared(suite, row, name, reference)
    for kind in (("missing body", "light piston", "rubber conrod", "1 ms step")
                 if not suite.quick else ("missing body",)):
        on_copy(suite, first, mistaken(kind), f"train_{kind}", kind)


def rotor_train() -> dict:
    """The coarse train with its crankshaft in the rotor basis."""
    raw = coarse_train()
    raw["bodies"]["crankshaft"]["basis"]["kind"] = "rotor"
    return raw
