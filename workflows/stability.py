"""Numerical-stability stress suite: the ``gcms`` command on perturbed, rescaled, slender, large,
long, extreme and parallel studies.

It drives the tool as a user does: every probe writes a study TOML file into a temporary
folder, runs ``python -m gcms_fenicsx.cli`` (under ``mpirun -n 2`` for the parallel class)
and reads the files the command wrote (``modes.json``, ``selection.json``, ``summary.json``,
``results.h5`` through ``gcms_fenicsx.dynamics.read_results``, ``reduced.h5`` through
``gcms_fenicsx.reduced_model.read_reduced``), so it keeps working while the package inside is
reorganised. The probe classes (``--only``):

  symmetry     a square steel beam widened by ε = 0 … 0.1: fields kept, smallest singular
               values, cond(Mr), pruning error, pendulum tip trajectory against ε = 0
  units        SI against mm-t-s, and the body scaled by 1e-3 and 1e3
  slenderness  10 mm square steel beams of L/h = 10 … 1000: verification margins, first
               bending frequency against Euler–Bernoulli and Timoshenko, solve time
  modes        Nm = 10 … 100 on a beam and the default crankshaft: selection, conditioning,
               cost, Newton iterations and steps/s of a short scene
  long         2e4 steps of the flexible pendulum; the default crankshaft scene with its
               drive ×1, ×3, ×10: energy balance over time (fitted growth), Newton iterations
  material     ν up to 0.499 (locking), E over ten decades (frequencies ∝ √E, same selection)
  mpi          ``gcms reduce`` on 1 and 2 ranks: frequencies, fields, Mr and Kr entries

Every command's row records its exit status, its last stderr line and its wall time, and the
suite checks the command's contract (README, "Using it"): it ends in a result (exit status 0,
its files written, strict JSON) or in one line with exit status 1 or 2 and ``--out`` exactly
as it was (a snapshot of the folder before and after) and no staging folder left behind. The
one documented exception, a simulation that stops early, keeps ``results.h5`` marked
incomplete (exit status 1; it prints the run's summary, its last line says so). Anything
else (a traceback, another exit status, more lines, a changed ``--out``, a time-out, a file
that is not strict JSON) is reported as BROKEN with the study to reproduce it, and the script
then exits with status 1.

    python workflows/stability.py [--quick] [--only CLASS ...] [--out docs/stability]
                                  [--keep DIR] [--redraw]

``--quick`` runs the smallest members of each class (about 2 minutes); the full run took 6
minutes on the 2-core development machine (allow up to half an hour on a busy one). Writes
OUT.json (every row; with ``--only`` the other classes' rows of an existing OUT.json are
kept, each class with its date and mode), OUT.png and OUT.md (the tables and a paragraph per
class for the README's "Numerical stability", numbers taken from the rows), and prints a
table per class; ``--redraw`` rewrites OUT.md and OUT.png from OUT.json alone. Child
processes run with one BLAS thread.
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CLASSES = ("symmetry", "units", "slenderness", "modes", "long", "material", "mpi")
STEEL = {"E": 210e9, "nu": 0.3, "rho": 7850.0}
EPS = float(np.finfo(float).eps)
#: Longest a single command may take before it is stopped and reported as BROKEN.
TIMEOUT_S = 1200.0
#: The files each command must have written when it succeeds (README, "Using it").
EXPECTED = {
    "mesh": ("mesh.json", "mesh.msh"),
    "modes": ("mesh.json", "modes.json"),
    "reduce": ("mesh.json", "modes.json", "selection.json", "reduced.h5"),
    "simulate": ("results.h5", "summary.json"),
    "run": ("mesh.json", "modes.json", "selection.json", "reduced.h5", "results.h5",
            "summary.json"),
}
STRICT_JSON = ("mesh.json", "modes.json", "selection.json", "summary.json")


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# -- study files -------------------------------------------------------------------------------

def toml_value(v: Any) -> str:
    """One TOML value: numbers, strings, booleans, arrays and inline tables."""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if math.isnan(v):
            return "nan"
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML form for {v!r}")


def toml_text(study: dict) -> str:
    """The study (tables as nested dicts, arrays of tables as lists of dicts) as a TOML file."""
    lines: list[str] = []
    for name, table in study.items():
        arrays = {k: v for k, v in table.items()
                  if isinstance(v, list) and v and all(isinstance(x, dict) for x in v)}
        lines.append(f"[{name}]")
        lines += [f"{k} = {toml_value(v)}" for k, v in table.items() if k not in arrays]
        for key, items in arrays.items():
            for item in items:
                lines += ["", f"[[{name}.{key}]]"]
                lines += [f"{k} = {toml_value(v)}" for k, v in item.items()]
        lines.append("")
    return "\n".join(lines)


def beam_study(section: str, dims: dict, length: float, size: float, modes: int,
               material: dict | None = None) -> dict:
    return {"geometry": {"kind": "beam", "section": section, **dims, "length": length},
            "mesh": {"size": size, "order": 2},
            "material": dict(STEEL if material is None else material),
            "modes": {"count": modes}}


def pendulum_scene(end_time: float, step: float, gravity: float = 9.81) -> dict:
    """Pinned at end face x = 0 by a revolute joint about y, released horizontally at rest."""
    return {"end_time": end_time, "time_step": step, "gravity": [0.0, 0.0, -gravity],
            "outputs": {"groups": ["end_xL"]},
            "joints": [{"type": "revolute", "group": "end_x0", "axis": [0.0, 1.0, 0.0]}]}


def default_study() -> dict:
    """The built-in default study of ``gcms run`` (the driven inline-4 crankshaft)."""
    return tomllib.loads((REPO / "gcms_fenicsx" / "data" / "default.toml").read_text())


def without_scene(study: dict) -> dict:
    return {k: v for k, v in study.items() if k != "scene"}


# -- running a command and judging how it ended ------------------------------------------------

def child_env() -> dict:
    env = dict(os.environ)
    env.setdefault("XDG_CACHE_HOME", str(REPO / ".cache"))
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1")
    return env


def snapshot(path: Path) -> dict | None:
    """What is at ``path``: None when nothing, else every file below it with its SHA-256."""
    if not path.exists() and not path.is_symlink():
        return None
    if not path.is_dir():
        return {".": hashlib.sha256(path.read_bytes()).hexdigest()}
    out = {}
    for p in sorted(path.rglob("*")):
        rel = str(p.relative_to(path))
        out[rel] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def error_lines(stderr: str, mpi: bool) -> list[str]:
    """stderr without progress lines ("[   0.1 s] ...") and, under mpirun, its own notices
    (blocks between lines of dashes)."""
    lines, inside = [], False
    for line in stderr.splitlines():
        if mpi and line.strip() and set(line.strip()) == {"-"}:
            inside = not inside
            continue
        if inside or not line.strip() or line.startswith("["):
            continue
        lines.append(line)
    return lines


def last_line(text: str) -> str:
    lines = [line for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


def strict_json(path: Path):
    """The JSON document at ``path``, refusing NaN and ±Infinity (RFC 8259 has none)."""
    def refuse(name: str):
        raise ValueError(f"{path.name}: {name} is not JSON")
    return json.loads(path.read_text(), parse_constant=refuse)


@dataclass
class Run:
    """One finished command and how it ended."""

    command: str
    out: Path
    study: str
    exit_status: int | None
    stderr: str
    wall_s: float
    outcome: str = ""          # ok, incomplete, failed (1), bad input (2) or BROKEN
    problem: str = ""          # why BROKEN

    @property
    def ok(self) -> bool:
        return self.outcome == "ok"

    def row(self) -> dict:
        return {"command": self.command, "exit_status": self.exit_status,
                "last_stderr": last_line(self.stderr), "wall_s": self.wall_s,
                "outcome": self.outcome, "problem": self.problem}


def judge(run: Run, subcommand: str, before: dict | None, after: dict | None,
          mpi: bool) -> tuple[str, str]:
    """(outcome, problem) of a finished command against the contract in the module docstring."""
    status, err = run.exit_status, run.stderr
    staging = sorted(p.name for p in run.out.parent.glob(".gcms-staging-*"))
    if status is None:
        return "BROKEN", f"no exit within {TIMEOUT_S:.0f} s (stopped)"
    if "Traceback" in err:
        return "BROKEN", f"exit status {status} with a traceback: {last_line(err)}"
    if staging:
        return "BROKEN", f"exit status {status}, staging folder left beside --out: {staging[0]}"
    if status == 0:
        missing = [n for n in EXPECTED[subcommand] if not (run.out / n).exists()]
        if missing:
            return "BROKEN", f"exit status 0 but {', '.join(missing)} not written"
        for name in STRICT_JSON:
            if (run.out / name).exists():
                try:
                    strict_json(run.out / name)
                except ValueError as exc:
                    return "BROKEN", f"exit status 0 but {name} is not strict JSON: {exc}"
        return "ok", ""
    if status not in (1, 2):
        return "BROKEN", f"exit status {status}: {last_line(err)}"
    lines = error_lines(err, mpi)
    if status == 1 and subcommand in ("simulate", "run") and before != after \
            and (run.out / "results.h5").exists():
        # the documented exception: a simulation that stopped early keeps its results
        try:
            from gcms_fenicsx.dynamics import read_results
            complete = read_results(run.out / "results.h5").complete
        except Exception as exc:  # noqa: BLE001 - any failure to read it is the finding
            return "BROKEN", f"exit status 1, results.h5 left unreadable: {exc}"
        if complete:
            return "BROKEN", "exit status 1 but --out changed and results.h5 says complete"
        # it prints the run's summary before its last line, so no count of lines here
        return "incomplete", ("" if "incomplete" in last_line(err) else
                              "exit status 1, results kept, but the last line does not say "
                              "they are incomplete")
    if len(lines) != 1:
        return "BROKEN", f"exit status {status} with {len(lines)} error lines, not one"
    if before != after:
        changed = sorted(set(before or {}) ^ set(after or {}) |
                         {k for k in set(before or {}) & set(after or {})
                          if before[k] != after[k]})
        what = "created" if before is None else f"changed: {', '.join(changed[:4])}"
        return "BROKEN", f"exit status {status} and --out {what}"
    return ("failed (1)" if status == 1 else "bad input (2)"), ""


def gcms(subcommand: str, study: dict | None, out: Path, ranks: int = 1,
         timeout: float = TIMEOUT_S) -> Run:
    """Run ``gcms SUBCOMMAND OUT.toml --out OUT`` (the study written beside OUT; no file when
    ``study`` is None: the built-in default) and judge how it ended."""
    out.parent.mkdir(parents=True, exist_ok=True)
    args = [subcommand]
    text = ""
    if study is not None:
        config = out.parent / f"{out.name}.toml"
        text = toml_text(study)
        config.write_text(text)
        args.append(str(config))
    args += ["--out", str(out)]
    cmd = [sys.executable, "-m", "gcms_fenicsx.cli", *args]
    shown = "gcms " + " ".join(args)
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
        shown = f"mpirun -n {ranks} {shown}"
    before = snapshot(out)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=REPO, env=child_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _, stderr = proc.communicate(timeout=timeout)
        status = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGTERM)  # the group of the child started here
        try:
            _, stderr = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            _, stderr = proc.communicate()
        status = None
    run = Run(shown, out, text, status, stderr, time.perf_counter() - t0)
    run.outcome, run.problem = judge(run, subcommand, before, snapshot(out), ranks > 1)
    mark = "" if run.ok else f"  [{run.outcome}{': ' + run.problem if run.problem else ''}]"
    log(f"  {shown}: exit {status}, {run.wall_s:.1f} s{mark}")
    return run


# -- reading what a command wrote --------------------------------------------------------------

def margins(verification: dict, eigenvalues: list[float]) -> dict:
    """limit / measured of every check in modes.json ``verification`` (None when the measured
    value is 0), and the lowest elastic eigenvalue over the zero-energy floor."""
    out = {}
    for name, check in verification.items():
        if not isinstance(check, dict):
            continue
        if "measured" in check and "limit" in check:
            m, lim = check["measured"], check["limit"]
            out[name] = (lim / m) if m and lim is not None else None
        elif name == "zero_energy" and "floor" in check and len(eigenvalues) > 6:
            out[name] = eigenvalues[6] / check["floor"]
        elif name == "sylvester" and "count" in check and "found" in check:
            out[name] = 1.0 if check["count"] == check["found"] else 0.0
    return out


def read_modes(out: Path) -> dict:
    m = strict_json(out / "modes.json")
    mesh = strict_json(out / "mesh.json")
    t = m.get("timings_s", {})
    return {"nodes": mesh["nodes"], "cells": mesh["cells"], "ndofs": m["ndofs"],
            "frequencies_hz": m["elastic_frequencies_hz"],
            "margins": margins(m.get("verification", {}), m.get("eigenvalues_rad2_s2", [])),
            "max_backward_error": m.get("max_backward_error"),
            "max_relative_residual": m.get("max_relative_residual"),
            "missed_eigenvalues": m.get("missed_eigenvalues"),
            "eigensolve_s": t.get("eigensolve"),
            "mesh_sha256": hashlib.sha256((out / "mesh.msh").read_bytes()).hexdigest()
            if (out / "mesh.msh").exists() else None}


def read_selection(out: Path) -> dict:
    s = strict_json(out / "selection.json")
    sv = sorted(s.get("singular_values", []))
    dropped = s.get("fields_dropped", [])
    return {"columns_before": s["columns_before"], "columns_after": s["columns_after"],
            "fields_kept": s["fields_kept"], "fields_kept_count": len(s["fields_kept"]),
            "fields_dropped": [{k: d.get(k) for k in ("field", "stage", "relative_residual",
                                                      "cosine") if k in d} for d in dropped],
            "singular_values": s.get("singular_values"), "sigma_smallest": sv[:3],
            "sigma_min": sv[0] if sv else None,
            "cond_phi_before": s["cond_phi_before"], "cond_phi_after": s["cond_phi_after"],
            "cond_mr_before": s["cond_mr_before"], "cond_mr_after": s["cond_mr_after"],
            "pruning_error": s["max_rel_frequency_error"],
            "reduced_frequencies_hz": s.get("reduced_frequencies_hz"),
            "selection_reduction_s": s.get("timings_s", {}).get("selection_and_reduction")}


def read_summary(out: Path) -> dict:
    s = strict_json(out / "summary.json")
    return {k: s.get(k) for k in ("complete", "steps", "steps_per_second", "reduced_dofs",
                                  "energy_drift_rel", "newton_iterations_mean",
                                  "newton_iterations_max", "wall_time_s", "message")}


def read_trajectory(out: Path):
    from gcms_fenicsx.dynamics import read_results
    return read_results(out / "results.h5")


def balance_history(traj) -> tuple[np.ndarray, np.ndarray]:
    """(t, balance error / max(kinetic + elastic)): the energy balance error over time in the
    scale of ``energy_drift_rel``."""
    e = traj.energy
    scale = float(np.max(np.abs(e["kinetic"] + e["elastic"])))
    return np.asarray(traj.time), np.asarray(e["balance_error"]) / (scale or 1.0)


def growth_fit(t: np.ndarray, err: np.ndarray, windows: int = 10) -> dict:
    """How the balance error evolves over a run cut into ``windows`` equal windows, the first
    of which (the start-up: release, spin-up) is left out of both fits:

    - ``drift_per_s``: the least-squares slope of the signed error in time, and
      ``drift_share`` = |slope| × (the fitted span) / max|err|: about 0 when the error stays
      flat, near 1 when a steady drift makes most of it;
    - ``growth_exponent``: the largest |err| of each window fitted as a t^p (0: flat, 0.5: a
      random walk, 1: linear growth from zero; an offset left by the start-up lowers it);
    - the largest |err| of the first and the last window."""
    t, e = np.asarray(t, float), np.asarray(err, float)
    a = np.abs(e)
    parts = [k for k in np.array_split(np.arange(len(t)), windows) if len(k)]
    peaks = np.array([a[k].max() for k in parts])
    centres = np.array([t[k].mean() for k in parts])
    use = (np.arange(len(parts)) >= 1) & (peaks > 0) & (centres > 0)
    p = float(np.polyfit(np.log(centres[use]), np.log(peaks[use]), 1)[0]) \
        if use.sum() >= 3 else None
    late = t >= t[parts[1][0]] if len(parts) > 1 else np.ones_like(t, bool)
    slope = float(np.polyfit(t[late], e[late], 1)[0]) if late.sum() > 3 else None
    span = float(t[late][-1] - t[late][0]) if late.any() else 0.0
    return {"growth_exponent": p, "drift_per_s": slope,
            "drift_share": (abs(slope) * span / a.max() if slope is not None and a.max() > 0
                            else None),
            "max_first_tenth": float(peaks[0]), "max_last_tenth": float(peaks[-1]),
            "window_maxima": peaks.tolist(), "max": float(a.max()), "end": float(a[-1])}


def downsample(t: np.ndarray, y: np.ndarray, n: int = 400) -> dict:
    idx = np.unique(np.linspace(0, len(t) - 1, min(n, len(t))).round().astype(int))
    return {"t": np.asarray(t)[idx].tolist(), "y": np.asarray(y)[idx].tolist()}


def rel(a: float | None, b: float | None) -> float | None:
    """|a / b − 1| (None when either is missing)."""
    if a is None or b is None:
        return None
    return abs(a / b - 1.0) if b else (0.0 if a == b else math.inf)


def max_rel(a, b) -> float | None:
    if a is None or b is None or len(a) != len(b) or not len(a):
        return None
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


# -- the suite ---------------------------------------------------------------------------------

@dataclass
class Suite:
    quick: bool
    folder: Path
    rows: list[dict] = field(default_factory=list)

    def probe(self, cls: str, case: str, run: Run, read: Callable[[Path], dict] | None = None,
              **extra) -> dict:
        """A row for ``run``: the command's ending, ``extra`` and what ``read`` finds in --out
        (only after a result; a reading failure is kept as ``read_error``)."""
        row = {"class": cls, "case": case, **extra, **run.row(), "study": run.study}
        if run.ok and read is not None:
            try:
                row.update(read(run.out))
            except Exception as exc:  # noqa: BLE001 - recorded, the suite goes on
                row["read_error"] = f"{type(exc).__name__}: {exc}"
                log(f"    reading {run.out.name}: {row['read_error']}")
        self.rows.append(row)
        return row

    def path(self, name: str) -> Path:
        return self.folder / name.replace(" ", "_").replace("/", "_")


def both(*readers: Callable[[Path], dict]) -> Callable[[Path], dict]:
    def read(out: Path) -> dict:
        row: dict = {}
        for r in readers:
            row.update(r(out))
        return row
    return read


# 1. symmetry perturbation ---------------------------------------------------------------------

SIDE_M, BEAM_LENGTH_M, SQUARE_SIZE_M, SQUARE_MODES = 0.03, 0.5, 0.0075, 10
EPSILONS = (0.0, 1e-6, 1e-4, 1e-3, 1e-2, 0.1)
PENDULUM_END_S, PENDULUM_STEP_S = 0.2, 1e-3
CUT_PAIR_MODES = 6


def square_beam(width_factor: float = 1.0, scale: float = 1.0, section: str = "rectangle",
                material: dict | None = None) -> dict:
    """The steel square beam (30 mm, 0.5 m, 7.5 mm P2 mesh, ten modes) as a rectangle of width
    side·width_factor, all lengths times ``scale``."""
    dims = ({"side": SIDE_M * scale} if section == "square" else
            {"width": SIDE_M * width_factor * scale, "height": SIDE_M * scale})
    return beam_study(section, dims, BEAM_LENGTH_M * scale, SQUARE_SIZE_M * scale,
                      SQUARE_MODES, material)


def tip_positions(out: Path) -> np.ndarray:
    return np.asarray(read_trajectory(out).groups["end_xL"]["position"])


def symmetry(suite: Suite) -> None:
    tips: dict[float, np.ndarray] = {}

    def read(out: Path) -> dict:
        row = both(read_modes, read_selection, read_summary)(out)
        f = row["frequencies_hz"]
        row["pair_split"] = (f[1] - f[0]) / f[0]
        return row

    ref = None
    for eps in ((0.0, 1e-6, 0.1) if suite.quick else EPSILONS):
        study = square_beam(1.0 + eps)
        study["scene"] = pendulum_scene(PENDULUM_END_S, PENDULUM_STEP_S)
        run = gcms("run", study, suite.path(f"symmetry_eps{eps:g}"))
        row = suite.probe("symmetry", f"ε = {eps:g}", run, read, epsilon=eps)
        if "read_error" in row or not run.ok:
            continue
        try:
            tips[eps] = tip_positions(run.out)
        except Exception as exc:  # noqa: BLE001
            row["read_error"] = f"results.h5: {type(exc).__name__}: {exc}"
        if eps == 0.0:
            ref = row
        elif ref is not None:
            compare_to(row, ref)
            if eps in tips and 0.0 in tips and tips[eps].shape == tips[0.0].shape:
                row["tip_difference_over_L"] = float(
                    np.linalg.norm(tips[eps] - tips[0.0], axis=1).max() / BEAM_LENGTH_M)
    # Nm = 6 cuts the third bending pair (modes 6 and 7, split by the mesh's asymmetry only):
    # which member the reduced model gets depends on the mesh, and so on ε
    cut: dict[float, np.ndarray] = {}
    for eps in (0.0, 1e-6):
        study = square_beam(1.0 + eps)
        study["modes"] = {"count": CUT_PAIR_MODES}
        study["scene"] = pendulum_scene(PENDULUM_END_S, PENDULUM_STEP_S)
        run = gcms("run", study, suite.path(f"symmetry_cut_eps{eps:g}"))
        row = suite.probe("symmetry", f"Nm = {CUT_PAIR_MODES}: ε = {eps:g}", run, read,
                          epsilon=eps, modes=CUT_PAIR_MODES)
        if run.ok and "read_error" not in row:
            try:
                cut[eps] = tip_positions(run.out)
            except Exception as exc:  # noqa: BLE001
                row["read_error"] = f"results.h5: {type(exc).__name__}: {exc}"
                continue
            if eps and 0.0 in cut:
                row["tip_difference_over_L"] = float(
                    np.linalg.norm(cut[eps] - cut[0.0], axis=1).max() / BEAM_LENGTH_M)
    # the square section itself against the rectangle of equal sides
    run = gcms("reduce", square_beam(section="square"), suite.path("symmetry_square"))
    row = suite.probe("symmetry", "square section", run, both(read_modes, read_selection),
                      epsilon=0.0)
    if ref is not None and run.ok and "read_error" not in row:
        compare_to(row, ref)
        f = row["frequencies_hz"]
        row["pair_split"] = (f[1] - f[0]) / f[0]


def compare_to(row: dict, ref: dict, scale: float = 1.0) -> None:
    """Differences of ``row`` from ``ref`` (frequencies times ``scale``)."""
    row["same_mesh_size"] = (row["nodes"], row["cells"]) == (ref["nodes"], ref["cells"])
    a, b = np.asarray(row["frequencies_hz"], float) * scale, np.asarray(ref["frequencies_hz"])
    if len(a) == len(b):
        d = np.abs(a / b - 1)
        row["frequency_difference"] = float(d.max())
        row["frequency_difference_mode"] = int(d.argmax()) + 1
        row["frequency_differences"] = d.tolist()
    if "fields_kept" in row and "fields_kept" in ref:
        row["same_fields_kept"] = row["fields_kept"] == ref["fields_kept"]
        row["same_fields_kept_count"] = row["fields_kept_count"] == ref["fields_kept_count"]
        for key in ("cond_mr_before", "cond_mr_after", "cond_phi_before", "cond_phi_after",
                    "pruning_error"):
            row[f"{key}_change"] = rel(row[key], ref[key])
        row["sigma_min_change"] = rel(row["sigma_smallest"][0], ref["sigma_smallest"][0]) \
            if row["sigma_smallest"] and ref["sigma_smallest"] else None
        row["singular_values_difference"] = max_rel(row["singular_values"],
                                                    ref["singular_values"])


# 2. units and size ----------------------------------------------------------------------------

def mm_t_s(study: dict) -> dict:
    """The study in mm, t, s: lengths ×1e3, E in MPa, ρ in t/mm³, gravity in mm/s²."""
    s = json.loads(json.dumps(study))
    g = s["geometry"]
    for key in ("side", "width", "height", "length"):
        if key in g:
            g[key] *= 1e3
    s["mesh"]["size"] *= 1e3
    s["material"]["E"] *= 1e-6        # Pa = N/m² → N/mm² = MPa
    s["material"]["rho"] *= 1e-12     # kg/m³ → t/mm³ (1e-3 t / 1e9 mm³)
    if "scene" in s:
        s["scene"]["gravity"] = [1e3 * x for x in s["scene"]["gravity"]]
    return s


def units(suite: Suite) -> None:
    reader = both(read_modes, read_selection)
    si_study = square_beam()
    si_study["scene"] = pendulum_scene(PENDULUM_END_S, PENDULUM_STEP_S)
    si = gcms("run", si_study, suite.path("units_SI"))
    ref = suite.probe("units", "SI", si, both(reader, read_summary), scale=1.0)
    ok = si.ok and "read_error" not in ref
    mm = gcms("run", mm_t_s(si_study), suite.path("units_mm"))
    row = suite.probe("units", "mm-t-s", mm, both(reader, read_summary), scale=1.0)
    if ok and mm.ok and "read_error" not in row:
        compare_to(row, ref)
        try:
            a, b = tip_positions(si.out), tip_positions(mm.out) / 1e3
            row["tip_difference_over_L"] = float(np.linalg.norm(a - b, axis=1).max()
                                                 / BEAM_LENGTH_M)
        except Exception as exc:  # noqa: BLE001
            row["read_error"] = f"results.h5: {type(exc).__name__}: {exc}"
        row["energy_drift_change"] = rel(row["energy_drift_rel"], ref["energy_drift_rel"])
    for scale in (1e-3, 1e3):
        run = gcms("reduce", square_beam(scale=scale), suite.path(f"units_size{scale:g}"))
        row = suite.probe("units", f"size ×{scale:g}", run, reader, scale=scale)
        if ok and run.ok and "read_error" not in row:
            compare_to(row, ref, scale=scale)  # f ∝ 1/size at the same material


# 3. slenderness -------------------------------------------------------------------------------

SLENDERNESS = (10, 30, 100, 200, 500, 1000)
THICK_M = 0.01


def beam_references(E: float, nu: float, rho: float, b: float, h: float, L: float,
                    n: int = 1) -> dict:
    """n-th free-free bending of a b × h rectangle about the axis of h (displacement along h):
    Euler–Bernoulli and Timoshenko (Cowper κ), from tests/beam_theory.py.

    Beyond L/h = 100 the Timoshenko value is f_EB (1 − C (h/L)²) with C from the same section
    at L/h = 100: the correction's leading term, whose next one, O((h/L)⁴), is about 1e-7 at
    L/h = 100 and 1e-11 at 1000. beam_theory's own value degrades there: its shift-invert
    (shift 1e-3 of the first bending eigenvalue) is lost against the shear stiffness
    κGA/Δx of its 4000 elements, so it moves by 1e-7 between calls at L/h = 200 (ARPACK's
    random start), differs from the leading term by 5e-7 at 200 and 1e-6 at 400, and SuperLU
    finds it exactly singular at 300, 500 and 1000."""
    sys.path.insert(0, str(REPO / "tests"))
    from beam_theory import cowper_kappa, euler_bernoulli_hz, timoshenko_hz
    A, I = b * h, b * h ** 3 / 12
    kappa = cowper_kappa("rectangle", nu)
    eb = float(euler_bernoulli_hz(n, E, I, rho, A, L))
    if L / h <= 100:
        return {"euler_bernoulli_hz": eb, "timoshenko_method": "beam_theory.timoshenko_hz",
                "timoshenko_hz": float(timoshenko_hz(n, E, nu, kappa, rho, A, I, L))}
    L100 = 100 * h
    C = (1 - timoshenko_hz(n, E, nu, kappa, rho, A, I, L100)
         / euler_bernoulli_hz(n, E, I, rho, A, L100)) * 100 ** 2
    return {"euler_bernoulli_hz": eb, "timoshenko_method": "f_EB (1 - C (h/L)^2), C at L/h = 100",
            "timoshenko_hz": float(eb * (1 - C * (h / L) ** 2))}


def slenderness(suite: Suite) -> None:
    for lh in ((10, 30) if suite.quick else SLENDERNESS):
        size = THICK_M / 2 if lh <= 200 else THICK_M
        study = beam_study("square", {"side": THICK_M}, THICK_M * lh, size, 4)
        run = gcms("modes", study, suite.path(f"slender_{lh}"))

        def read(out: Path, lh=lh) -> dict:
            row = read_modes(out)
            ref = beam_references(STEEL["E"], STEEL["nu"], STEEL["rho"], THICK_M, THICK_M,
                                  THICK_M * lh)
            f1 = row["frequencies_hz"][0]
            m = [v for v in row["margins"].values() if v is not None]
            return {**row, **ref, "f1_hz": f1,
                    "error_euler_bernoulli": f1 / ref["euler_bernoulli_hz"] - 1,
                    "error_timoshenko": f1 / ref["timoshenko_hz"] - 1,
                    "pair_split": (row["frequencies_hz"][1] - f1) / f1,
                    "smallest_margin": min(m) if m else None}
        suite.probe("slenderness", f"L/h = {lh}", run, read, slenderness=lh, mesh_size_m=size)


# 4. many modes --------------------------------------------------------------------------------

MODE_COUNTS = (10, 20, 50, 100)
SHORT_STEPS = 200


def modes_beam(nm: int) -> dict:
    study = beam_study("rectangle", {"width": 0.05, "height": 0.04}, 1.0, 0.01, nm)
    study["scene"] = pendulum_scene(SHORT_STEPS * 1e-4, 1e-4)
    return study


def modes_crankshaft(nm: int) -> dict:
    study = default_study()
    study["modes"] = {"count": nm}
    study["scene"]["end_time"] = SHORT_STEPS * study["scene"]["time_step"]
    return study


def many_modes(suite: Suite) -> None:
    def read(out: Path) -> dict:
        row = both(read_modes, read_selection, read_summary)(out)
        row["selection_over_eigensolve"] = (row["selection_reduction_s"] / row["eigensolve_s"]
                                            if row["eigensolve_s"] else None)
        return row

    counts = (10,) if suite.quick else MODE_COUNTS
    for body, make in (("beam", modes_beam), ("crankshaft", modes_crankshaft)):
        for nm in counts:
            run = gcms("run", make(nm), suite.path(f"modes_{body}_{nm}"))
            suite.probe("modes", f"{body}, Nm = {nm}", run, read, body=body, modes=nm)


# 5. long runs ---------------------------------------------------------------------------------

#: The flexible pendulum of gcms_fenicsx.pendulum.STUDY (a soft 1 m polymer beam, 20 mm square).
FLEXIBLE = beam_study("square", {"side": 0.02}, 1.0, 0.01, 10,
                      {"E": 1.0e8, "nu": 0.35, "rho": 1150.0})
LONG_STEPS = 20_000
DRIVE_FACTORS = (1, 3, 10)


def rotation_per_step(scene: dict) -> float:
    return scene["joints"][0]["drive"]["angular_velocity"] * scene["time_step"]


def long_runs(suite: Suite) -> None:
    def read(out: Path) -> dict:
        row = read_summary(out)
        t, e = balance_history(read_trajectory(out))
        row.update(growth_fit(t, e), balance=downsample(t, e), end_time_s=float(t[-1]))
        return row

    study = dict(FLEXIBLE, scene=pendulum_scene(LONG_STEPS * 1e-3, 1e-3))
    run = gcms("run", study, suite.path("long_pendulum"))
    suite.probe("long", f"flexible pendulum, {LONG_STEPS} steps", run, read, body="pendulum",
                drive_factor=None)
    # the default crankshaft scene: reduce once, then simulate each drive speed on a copy
    base = default_study()
    reduced = gcms("reduce", without_scene(base), suite.path("long_crank_reduced"))
    suite.probe("long", "crankshaft, reduce", reduced, read_selection, body="crankshaft",
                drive_factor=None)
    if not reduced.ok:
        return
    for factor in ((1,) if suite.quick else DRIVE_FACTORS):
        study = default_study()
        scene = study["scene"]
        if not suite.quick:
            scene["end_time"] = LONG_STEPS * scene["time_step"]
        scene["joints"][0]["drive"]["angular_velocity"] *= factor
        out = suite.path(f"long_crank_x{factor}")
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(reduced.out, out)
        run = gcms("simulate", study, out)
        row = suite.probe("long", f"crankshaft, drive ×{factor}", run, read, body="crankshaft",
                          drive_factor=factor, rotation_per_step_rad=rotation_per_step(scene))
        row["reused_reduced_model"] = "rebuilding" not in run.stderr
    if not suite.quick:
        # the fastest drive again with a quarter of the step: does its error converge (a
        # second-order method: 1/16) or is it something the step does not control?
        study = default_study()
        scene = study["scene"]
        scene["end_time"] = LONG_STEPS * scene["time_step"]
        scene["time_step"] /= 4
        scene["outputs"]["every"] = 4 * scene["outputs"].get("every", 1)
        scene["joints"][0]["drive"]["angular_velocity"] *= DRIVE_FACTORS[-1]
        out = suite.path("long_crank_fine")
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(reduced.out, out)
        run = gcms("simulate", study, out)
        row = suite.probe("long", f"crankshaft, drive ×{DRIVE_FACTORS[-1]}, step / 4", run, read,
                          body="crankshaft", drive_factor=DRIVE_FACTORS[-1], step_factor=0.25,
                          rotation_per_step_rad=rotation_per_step(scene))
        row["reused_reduced_model"] = "rebuilding" not in run.stderr


# 6. material extremes -------------------------------------------------------------------------

NUS = (0.3, 0.45, 0.49, 0.499)
E_VALUES = tuple(10.0 ** k for k in range(5, 16))
E_REFERENCE = 1e10
MAT_B, MAT_H, MAT_L = 0.03, 0.02, 0.5   # width (y), height (z), length


def material_beam(material: dict, size: float) -> dict:
    return beam_study("rectangle", {"width": MAT_B, "height": MAT_H}, MAT_L, size, 6, material)


def material(suite: Suite) -> None:
    size = 0.01 if suite.quick else 0.006
    reader = both(read_modes, read_selection)
    for nu in ((0.3, 0.499) if suite.quick else NUS):
        mat = dict(STEEL, nu=nu)

        def read(out: Path, nu=nu) -> dict:
            row = reader(out)
            f = row["frequencies_hz"]
            weak = beam_references(STEEL["E"], nu, STEEL["rho"], MAT_B, MAT_H, MAT_L)
            strong = beam_references(STEEL["E"], nu, STEEL["rho"], MAT_H, MAT_B, MAT_L)
            return {**row, "f1_hz": f[0], "f2_hz": f[1],
                    "timoshenko_weak_hz": weak["timoshenko_hz"],
                    "timoshenko_strong_hz": strong["timoshenko_hz"],
                    "error_weak": f[0] / weak["timoshenko_hz"] - 1,
                    "error_strong": f[1] / strong["timoshenko_hz"] - 1}
        run = gcms("reduce", material_beam(mat, size), suite.path(f"material_nu{nu:g}"))
        suite.probe("material", f"ν = {nu:g}", run, read, nu=nu, E=STEEL["E"])
    values = (1e5, E_REFERENCE, 1e15) if suite.quick else E_VALUES
    found = {}
    for E in values:
        run = gcms("reduce", material_beam(dict(STEEL, E=E), size), suite.path(f"material_E{E:g}"))
        found[E] = suite.probe("material", f"E = {E:.0e} Pa", run, reader, nu=STEEL["nu"], E=E)
    ref = found.get(E_REFERENCE)
    if ref is None or ref["outcome"] != "ok" or "read_error" in ref:
        return
    for E, row in found.items():
        if row["outcome"] == "ok" and "read_error" not in row:
            compare_to(row, ref, scale=math.sqrt(E_REFERENCE / E))
            row["same_mesh_file"] = row["mesh_sha256"] == ref["mesh_sha256"]


# 7. one and two MPI ranks ---------------------------------------------------------------------

def mpi(suite: Suite) -> None:
    size = 0.012 if suite.quick else 0.008
    study = material_beam(STEEL, size)
    study["modes"] = {"count": 8}
    reader = both(read_modes, read_selection)
    one = gcms("reduce", study, suite.path("mpi_1"))
    ref = suite.probe("mpi", "1 rank", one, reader, ranks=1)
    two = gcms("reduce", study, suite.path("mpi_2"), ranks=2)
    row = suite.probe("mpi", "2 ranks", two, reader, ranks=2)
    if not (one.ok and two.ok) or "read_error" in ref or "read_error" in row:
        return
    compare_to(row, ref)
    try:
        row.update(reduced_difference(one.out / "reduced.h5", two.out / "reduced.h5"))
    except Exception as exc:  # noqa: BLE001
        row["read_error"] = f"reduced.h5: {type(exc).__name__}: {exc}"


def reduced_difference(path_a: Path, path_b: Path) -> dict:
    """Mr, Kr and the fields of two reduced models of the same mesh with nodes in another order
    (another rank count): each field's sign is taken from its overlap with the other's, and
    the coordinates' signs follow their field's (q holds one 3-vector per field)."""
    from scipy.spatial import cKDTree

    from gcms_fenicsx.reduced_model import read_reduced
    a, b = read_reduced(path_a), read_reduced(path_b)
    dist, perm = cKDTree(b.nodes_m).query(a.nodes_m)
    extent = float(np.ptp(a.nodes_m, axis=0).max())
    Fa, Fb = a.fields, b.fields[perm]
    signs = np.sign(np.einsum("ij,ij->j", Fa, Fb))
    signs[signs == 0] = 1.0
    d = np.repeat(signs, 3)
    Mb, Kb = d[:, None] * b.mass * d, d[:, None] * b.stiffness * d
    return {"node_match_m": float(dist.max()), "node_match_over_size": float(dist.max()) / extent,
            "field_names_equal": list(a.field_names) == list(b.field_names),
            "sign_flips": int((signs < 0).sum()),
            "fields_difference": float(np.abs(Fa - signs * Fb).max() / np.abs(Fa).max()),
            "mr_difference": float(np.abs(a.mass - Mb).max() / np.abs(a.mass).max()),
            "kr_difference": float(np.abs(a.stiffness - Kb).max() / np.abs(a.stiffness).max()),
            "reduced_frequency_difference": max_rel(b.reduced_frequencies_hz,
                                                    a.reduced_frequencies_hz)}


PROBES: dict[str, Callable[[Suite], None]] = {
    "symmetry": symmetry, "units": units, "slenderness": slenderness, "modes": many_modes,
    "long": long_runs, "material": material, "mpi": mpi}


# -- tables ------------------------------------------------------------------------------------

def f(v, spec: str = ".2e") -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return format(v, spec)


def ending(r: dict) -> str:
    text = f"{r['exit_status']}" if r["outcome"] == "ok" else f"{r['exit_status']} {r['outcome']}"
    return text + (" (unread)" if "read_error" in r else "")


def dropped(r: dict) -> str:
    return ", ".join(f"{d.get('field')} ({d.get('stage')}, {f(d.get('relative_residual'), '.0e')})"
                     for d in r.get("fields_dropped", [])) or "none"


def smallest_margin(r: dict) -> str:
    m = {k: v for k, v in r.get("margins", {}).items() if v is not None and k != "sylvester"}
    if not m:
        return ""
    k = min(m, key=m.get)
    return f"{m[k]:.1e} ({k})"


COMMON = [("exit", ending), ("wall s", lambda r: f(r["wall_s"], ".1f"))]
COLUMNS: dict[str, list[tuple[str, Callable[[dict], str]]]] = {
    "symmetry": [
        ("case", lambda r: r["case"]), ("nodes", lambda r: f(r.get("nodes"), "d")),
        ("fields kept", lambda r: f(r.get("fields_kept_count"), "d")),
        ("dropped (stage, residual)", lambda r: dropped(r) if "fields_kept" in r else ""),
        ("3 smallest σ", lambda r: ", ".join(f(s, ".1e") for s in r.get("sigma_smallest", []))),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("bending pair split", lambda r: f(r.get("pair_split"), ".1e")),
        ("freq. change vs ε = 0: max (mode), f₁, f₂", lambda r: (
            f"{f(r['frequency_difference'], '.1e')} ({r['frequency_difference_mode']}), "
            f"{f(r['frequency_differences'][0], '.1e')}, {f(r['frequency_differences'][1], '.1e')}"
            if "frequency_differences" in r else "")),
        ("tip difference / L", lambda r: f(r.get("tip_difference_over_L"), ".1e")),
        *COMMON],
    "units": [
        ("case", lambda r: r["case"]), ("nodes", lambda r: f(r.get("nodes"), "d")),
        ("freq. diff. (× size)", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("same fields kept", lambda r: f(r.get("same_fields_kept"))),
        ("cond(Mr) before, after", lambda r: f"{f(r.get('cond_mr_before'), '.3e')}, "
                                             f"{f(r.get('cond_mr_after'), '.4g')}"),
        ("cond changes (Mr b/a, Φ b/a)", lambda r: ", ".join(
            f(r.get(f"{k}_change"), ".0e") for k in ("cond_mr_before", "cond_mr_after",
                                                     "cond_phi_before", "cond_phi_after"))),
        ("σ diff.", lambda r: f(r.get("singular_values_difference"), ".0e")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".2e")),
        ("tip diff. / L", lambda r: f(r.get("tip_difference_over_L"), ".0e")),
        ("Newton it.", lambda r: f(r.get("newton_iterations_mean"), ".2f")),
        *COMMON],
    "slenderness": [
        ("L/h", lambda r: str(r["slenderness"])),
        ("size mm", lambda r: f(1e3 * r["mesh_size_m"], "g")),
        ("DOFs", lambda r: f(r.get("ndofs"), ",")), ("f₁ Hz", lambda r: f(r.get("f1_hz"), ".5g")),
        ("vs Euler–Bernoulli", lambda r: f(r.get("error_euler_bernoulli"), "+.1e")),
        ("vs Timoshenko", lambda r: f(r.get("error_timoshenko"), "+.1e")),
        ("backward error", lambda r: f(r.get("max_backward_error"), ".0e")),
        ("‖Kφ−λMφ‖/‖Kφ‖", lambda r: f(r.get("max_relative_residual"), ".0e")),
        ("smallest margin limit/measured", smallest_margin),
        ("eigen-solve s", lambda r: f(r.get("eigensolve_s"), ".1f")), *COMMON],
    "modes": [
        ("body", lambda r: r["body"]), ("Nm", lambda r: str(r["modes"])),
        ("DOFs", lambda r: f(r.get("ndofs"), ",")),
        ("columns", lambda r: f"{r['columns_before']} → {r['columns_after']}"
         if "columns_after" in r else ""),
        ("cond(Mr) before → after", lambda r: f"{f(r.get('cond_mr_before'), '.1e')} → "
                                             f"{f(r.get('cond_mr_after'), '.1e')}"),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("eigen-solve s", lambda r: f(r.get("eigensolve_s"), ".1f")),
        ("sel. + red. s", lambda r: f(r.get("selection_reduction_s"), ".2f")),
        ("/ eigen-solve", lambda r: f(r.get("selection_over_eigensolve"), ".1%")),
        ("Newton it.", lambda r: f(r.get("newton_iterations_mean"), ".2f")),
        ("steps/s", lambda r: f(r.get("steps_per_second"), ",.0f")),
        ("energy drift", lambda r: f(r.get("energy_drift_rel"), ".1e")), *COMMON],
    "long": [
        ("case", lambda r: r["case"]), ("steps", lambda r: f(r.get("steps"), ",")),
        ("complete", lambda r: f(r.get("complete"))),
        ("energy drift", lambda r: f(r.get("energy_drift_rel"), ".1e")),
        ("max balance error, first → last tenth", lambda r: (
            f"{f(r.get('max_first_tenth'), '.1e')} → {f(r.get('max_last_tenth'), '.1e')}"
            if "max_first_tenth" in r else "")),
        ("drift /s (share of max)", lambda r: (
            f"{f(r.get('drift_per_s'), '+.1e')} ({f(r.get('drift_share'), '.0%')})"
            if "drift_per_s" in r else "")),
        ("window maxima ∝ t^p", lambda r: f(r.get("growth_exponent"), ".2f")),
        ("Newton it. mean/max", lambda r: (f"{f(r.get('newton_iterations_mean'), '.2f')} / "
                                           f"{f(r.get('newton_iterations_max'), 'd')}"
                                           if "newton_iterations_mean" in r else "")),
        ("steps/s", lambda r: f(r.get("steps_per_second"), ",.0f")), *COMMON],
    "material": [
        ("case", lambda r: r["case"]), ("f₁ Hz", lambda r: f(r.get("f1_hz"), ".6g")),
        ("f₁, f₂ vs Timoshenko", lambda r: (f"{f(r.get('error_weak'), '+.1e')}, "
                                            f"{f(r.get('error_strong'), '+.1e')}"
                                            if "error_weak" in r else "")),
        ("f·√(E₀/E) vs E₀", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("same mesh, fields", lambda r: (f"{f(r.get('same_mesh_file'))}, "
                                         f"{f(r.get('same_fields_kept'))}"
                                         if "same_fields_kept" in r else "")),
        ("fields kept", lambda r: f(r.get("fields_kept_count"), "d")),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("smallest margin", smallest_margin), *COMMON],
    "mpi": [
        ("case", lambda r: r["case"]), ("DOFs", lambda r: f(r.get("ndofs"), ",")),
        ("freq. diff.", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("fields kept same", lambda r: f(r.get("same_fields_kept"))),
        ("Mr diff.", lambda r: f(r.get("mr_difference"), ".1e")),
        ("Kr diff.", lambda r: f(r.get("kr_difference"), ".1e")),
        ("F diff.", lambda r: f(r.get("fields_difference"), ".1e")),
        ("sign flips", lambda r: f(r.get("sign_flips"), "d")),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")), *COMMON],
}


def table(cls: str, rows: list[dict]) -> str:
    cols = COLUMNS[cls]
    lines = ["| " + " | ".join(h for h, _ in cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for _, fn in cols:
            try:
                cells.append(fn(r))
            except (KeyError, TypeError, ValueError, IndexError):
                cells.append("?")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


# -- the run -----------------------------------------------------------------------------------

def git_revision() -> str | None:
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, text=True,
                             capture_output=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=REPO, text=True, capture_output=True, timeout=10).stdout
        return rev + ("+changes" if dirty.strip() else "") if rev else None
    except (OSError, subprocess.SubprocessError):
        return None


def finite(value):
    """``value`` with NumPy scalars as Python numbers and NaN, ±inf as None (strict JSON)."""
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


def broken(rows: list[dict]) -> list[dict]:
    return [r for r in rows if r["outcome"] == "BROKEN"]


def merged(path: Path, runs: dict[str, dict]) -> dict:
    """OUT.json with the classes just run replacing theirs (the others kept as they were)."""
    classes: dict = {}
    if path.exists():
        try:
            classes = json.loads(path.read_text()).get("classes", {})
        except (ValueError, AttributeError):
            classes = {}
    classes.update(runs)
    return {"suite": "workflows/stability.py",
            "classes": {c: classes[c] for c in CLASSES if c in classes}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the smallest members of each class (a few minutes)")
    parser.add_argument("--only", action="append", choices=CLASSES, metavar="CLASS",
                        help=f"run only this class (repeatable): {', '.join(CLASSES)}")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "stability",
                        help="OUT.json, OUT.png and OUT.md (default docs/stability)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="work in this folder and keep every study and --out there")
    parser.add_argument("--redraw", action="store_true",
                        help="run nothing: rewrite OUT.md and OUT.png from OUT.json")
    args = parser.parse_args(argv)
    if args.redraw:
        document = json.loads(Path(f"{args.out}.json").read_text())
        Path(f"{args.out}.md").write_text(markdown(document))
        plot(document, Path(f"{args.out}.png"))
        return 0
    chosen = [c for c in CLASSES if c in (args.only or CLASSES)]
    runs: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="gcms-stability-") as tmp:
        folder = Path(tmp) if args.keep is None else args.keep.resolve()
        folder.mkdir(parents=True, exist_ok=True)
        for cls in chosen:
            log(f"[{cls}]")
            suite = Suite(args.quick, folder)
            t0 = time.perf_counter()
            try:
                PROBES[cls](suite)
            except Exception as exc:  # noqa: BLE001 - a fault of the suite: kept, next class
                suite.rows.append({"class": cls, "case": "suite error", "command": "",
                                   "exit_status": None, "last_stderr": "", "wall_s": 0.0,
                                   "outcome": "suite error", "problem": "", "study": "",
                                   "read_error": f"{type(exc).__name__}: {exc}"})
                log(f"  suite error in {cls}: {type(exc).__name__}: {exc}")
            runs[cls] = {"mode": "quick" if args.quick else "full",
                         "date": datetime.datetime.now().isoformat(timespec="seconds"),
                         "git": git_revision(), "wall_s": time.perf_counter() - t0,
                         "rows": suite.rows}
            print(f"\n{cls} ({runs[cls]['mode']}, {runs[cls]['wall_s']:.0f} s)\n")
            print(table(cls, suite.rows), flush=True)
    document = merged(Path(f"{args.out}.json"), runs)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{args.out}.json").write_text(json.dumps(finite(document), indent=1,
                                                   allow_nan=False))
    Path(f"{args.out}.md").write_text(markdown(document))
    try:
        plot(document, Path(f"{args.out}.png"))
    except (KeyError, TypeError, ValueError, IndexError) as exc:  # rows of an older suite
        log(f"{args.out}.png not drawn: {type(exc).__name__}: {exc}")
    bad = broken([r for c in runs.values() for r in c["rows"]])
    unread = [r for c in runs.values() for r in c["rows"] if "read_error" in r]
    for r in bad:
        print(f"\nBROKEN: {r['class']}, {r['case']}: {r['problem']}\n  {r['command']}\n"
              f"  last stderr line: {r['last_stderr']}\n  study:\n{r['study']}")
    for r in unread:
        print(f"\nnot read: {r['class']}, {r['case']}: {r['read_error']}")
    log(f"wrote {args.out}.json, .md, .png; {len(bad)} broken, {len(unread)} unread")
    return 1 if bad else 0


# -- what the rows say (docs/stability.md) -----------------------------------------------------

def good(rows: list[dict]) -> list[dict]:
    return [r for r in rows if r["outcome"] == "ok" and "read_error" not in r]


def g(v, spec: str = ".1e") -> str:
    return "n/a" if v is None else format(v, spec)


def every(rows: list[dict], key: str) -> str:
    return "yes" if rows and all(r.get(key) for r in rows) else "NO"


def changes(rows: list[dict], key: str, x: str = "epsilon") -> list[tuple[float, float, float]]:
    """(x_a, x_b, |v_b / v_a − 1|) for consecutive rows that both have ``key``."""
    pts = [(r[x], r[key]) for r in rows if r.get(key) is not None]
    return [(a, b, rel(vb, va)) for (a, va), (b, vb) in zip(pts, pts[1:])]


def verdict(rows: list[dict], key: str, label: str) -> str:
    """Whether ``key`` is continuous in ε. Every ε is meshed afresh, so each step carries the
    mesh-to-mesh variation (a few %); a step is a jump when it changes the value by more than
    max(10 %, 10 Δε) relative (10 % above that variation, a slope of 10 allowed)."""
    steps = changes(rows, key)
    if not steps:
        return f"{label}: not measured"
    vals = [r[key] for r in rows if r.get(key) is not None]
    jumps = [(a, b, c) for a, b, c in steps if c > max(0.1, 10 * (b - a))]
    rest = [c for a, b, c in steps if (a, b, c) not in jumps]
    span = f"{g(min(vals))} … {g(max(vals))}"
    small = f"steps of at most {max(rest):.1%}" if rest else ""
    if not jumps:
        return f"{label} is continuous ({span}; {small})"
    where = "; ".join(f"by {c:.0%} between ε = {a:g} and {b:g}" for a, b, c in jumps)
    return f"{label} jumps {where} ({span}{'; otherwise ' + small if small else ''})"


def span_text(values: list[float], spec: str = ".3g") -> str:
    lo, hi = min(values), max(values)
    return f"{lo:{spec}} at every Nm" if lo == hi or abs(hi / lo - 1) < 1e-6 else \
        f"{lo:{spec}}–{hi:{spec}}"


def pair_split(freqs: list[float], i: int) -> float | None:
    """(f_{i+1} − f_i) / f_i of 0-based mode i, None when there is no mode i + 1."""
    return freqs[i + 1] / freqs[i] - 1 if len(freqs) > i + 1 else None


def text_symmetry(rows: list[dict]) -> str:
    eps = sorted((r for r in good(rows) if r["case"].startswith("ε")), key=lambda r: r["epsilon"])
    if not eps:
        return "No result."
    counts = [(r["epsilon"], r["fields_kept_count"]) for r in eps]
    count_jumps = [(a, b) for (a, na), (b, nb) in zip(counts, counts[1:]) if na != nb]
    kept = (f"The number of fields kept is {counts[0][1]} at every ε" if not count_jumps else
            "The number of fields kept changes " + ", ".join(
                f"between ε = {a:g} and {b:g}" for a, b in count_jumps) +
            f" ({', '.join(f'{n} at {e:g}' for e, n in counts)})")
    names = [(r["epsilon"], ", ".join(d["field"] for d in r["fields_dropped"]) or "none",
              ", ".join(g(d.get("relative_residual"), ".0e") for d in r["fields_dropped"]))
             for r in eps]
    name_jumps = [(a[0], b[0]) for a, b in zip(names, names[1:]) if a[1] != b[1]]
    groups: list[list] = []
    for e, n, res in names:
        if groups and groups[-1][0] == n:
            groups[-1][2].append(res)
        else:
            groups.append([n, e, [res]])
    which = ("; which fields are dropped does not change" if not name_jumps else
             "; but *which* field is dropped jumps (" + "; ".join(
                 f"{n} from ε = {e:g}, relative residual {' … '.join(dict.fromkeys(rs))}"
                 for n, e, rs in groups) +
             "): the rank comes from the singular values, the choice from a pivoted Cholesky "
             "that breaks the tie of a near-repeated pair either way")
    nodes = [(r["epsilon"], r["nodes"]) for r in eps]
    mesh_jumps = [b for (a, na), (b, nb) in zip(nodes, nodes[1:]) if na != nb]
    first_pair = [(r["epsilon"], r["pair_split"]) for r in eps]
    sym = next((r for r in good(rows) if r["case"] == "square section"), None)
    tip = [(r["epsilon"], r.get("tip_difference_over_L")) for r in eps[1:]]
    parts = [
        f"{kept}{which}.",
        verdict(eps, "sigma_min", "The smallest singular value") + "; " +
        verdict(eps, "cond_mr_after", "cond(Mr) after selection") +
        "; " + verdict(eps, "pruning_error", "the pruning error") + ".",
        "The first bending pair splits by " + ", ".join(f"{s:.1e} at ε = {e:g}"
                                                         for e, s in first_pair) +
        " (the split of a widened square is ε itself in beam theory; at ε = 0 it is the "
        "unstructured mesh's asymmetry).",
        ("Gmsh meshes every width afresh: " + ", ".join(f"{n} nodes at ε = {e:g}"
                                                       for e, n in nodes) +
         (f", so from ε = {mesh_jumps[0]:g} the elastic frequencies differ from ε = 0 by "
          "the mesh's own change (largest " + ", ".join(
              f"{g(r.get('frequency_difference'))} in mode {r.get('frequency_difference_mode')}"
              f" at ε = {r['epsilon']:g}" for r in eps[1:]) + "), not by ε; the first "
          "bending pair moves by " + ", ".join(
              f"{g(r['frequency_differences'][0])} and {g(r['frequency_differences'][1])}"
              f" at ε = {r['epsilon']:g}" for r in eps[1:] if "frequency_differences" in r) +
          "." if mesh_jumps else ".")),
        "The pendulum's tip trajectory (0.2 s) differs from ε = 0 by " +
        ", ".join(f"{g(v)} L at ε = {e:g}" for e, v in tip) +
        (": continuous (the swing is about y, which widening along y does not stiffen)."
         if tip and all(v is not None and v < max(e, 1e-8) for e, v in tip) else "."),
    ]
    cut = {r["epsilon"]: r for r in good(rows) if r["case"].startswith("Nm")}
    if 1e-6 in cut and cut[1e-6].get("tip_difference_over_L") is not None:
        ref = next((r.get("tip_difference_over_L") for r in eps if r["epsilon"] == 1e-6), None)
        parts.append(
            f"A mode count that cuts a near-repeated pair is discontinuous: with Nm = "
            f"{cut[1e-6]['modes']} (the third bending pair's members are modes 6 and 7, "
            f"split {g(pair_split(eps[0]['frequencies_hz'], 5) if eps else None)}"
            f" at ε = 0) the reduced model holds one member, bending in a direction of the y–z "
            f"plane that the mesh's asymmetry picks, and "
            f"the tip trajectory at ε = 1e-6 differs by {g(cut[1e-6]['tip_difference_over_L'])}"
            f" L instead of {g(ref)} L with Nm = {SQUARE_MODES}.")
    if sym is not None:
        parts.append(f"The `square` section gives the rectangle of equal sides exactly "
                     f"(frequencies {g(sym.get('frequency_difference'))}, "
                     f"same mesh: {f(sym.get('same_mesh_size'))}).")
    return " ".join(parts)


def text_units(rows: list[dict]) -> str:
    rs = [r for r in good(rows) if r["case"] != "SI"]
    ref = next((r for r in good(rows) if r["case"] == "SI"), None)
    if not rs or ref is None:
        return "No result."
    cond = max((r.get(f"{k}_change") or 0) for r in rs for k in ("cond_mr_before",))
    after = max((r.get(f"{k}_change") or 0) for r in rs for k in ("cond_mr_after",
                                                                 "cond_phi_after"))
    sv = max((r.get("singular_values_difference") or 0) for r in rs)
    smin = ref["sigma_smallest"][0] if ref.get("sigma_smallest") else None
    mm = next((r for r in rs if r["case"] == "mm-t-s"), None)
    text = (f"Against SI, every variant has the same mesh ({every(rs, 'same_mesh_size')}) "
            f"and the same fields kept ({every(rs, 'same_fields_kept')}); "
            "frequencies (times the size factor) agree to " +
            ", ".join(f"{g(r.get('frequency_difference'))} ({r['case']})" for r in rs) + ". "
            f"cond(Mr) before selection ({g(ref['cond_mr_before'])}) agrees to {g(cond)}, the "
            f"round-off of a Gram matrix of that condition (ε·cond = "
            f"{g(EPS * ref['cond_mr_before'])}); after selection (and cond(Φ) after) to "
            f"{g(after)}. The singular values agree to {g(sv)}: the smallest, {g(smin)}, is "
            f"the root of a Gram eigenvalue known to ε, so to ε/(2σ²) = "
            f"{g(EPS / (2 * smin ** 2) if smin else None)} relative.")
    if mm is not None:
        text += (f" The mm-t-s pendulum's tip trajectory is the SI one ×1e3 to "
                 f"{g(mm.get('tip_difference_over_L'))} L with "
                 f"{g(mm.get('newton_iterations_mean'), '.2f')} Newton iterations per step "
                 f"(SI {g(ref.get('newton_iterations_mean'), '.2f')}), energy drift "
                 f"{g(mm.get('energy_drift_rel'))} against {g(ref.get('energy_drift_rel'))}.")
    return text


def loglog_slope(x, y) -> float | None:
    pts = [(a, b) for a, b in zip(x, y) if a and b and a > 0 and b > 0]
    if len(pts) < 2:
        return None
    a, b = np.log(np.array(pts).T)
    return float(np.polyfit(a, b, 1)[0])


def power(x, y) -> str:
    p = loglog_slope(x, y)
    return "" if p is None else f" (∝ Nm^{p:.1f})"


def text_slenderness(rows: list[dict]) -> str:
    rs = sorted(good(rows), key=lambda r: r["slenderness"])
    failed = [r for r in rows if r["outcome"] != "ok"]
    if not rs:
        return "No result." + (f" {failed[0]['case']}: {failed[0]['last_stderr']}"
                               if failed else "")
    lh = [r["slenderness"] for r in rs]
    res = [r["max_relative_residual"] for r in rs]
    margin = min((v for r in rs for k, v in r["margins"].items() if v is not None
                  and k != "sylvester"), default=None)
    text = (f"The verified solve passes at every L/h from {lh[0]} to {lh[-1]}"
            + (f" except {', '.join(r['case'] for r in failed)} ("
               + "; ".join(f"exit {r['exit_status']}: {r['last_stderr']}" for r in failed) + ")"
               if failed else "") +
            f"; its smallest margin (limit/measured) is {g(margin)}. The backward error stays "
            f"at {g(min(r['max_backward_error'] for r in rs), '.0e')}–"
            f"{g(max(r['max_backward_error'] for r in rs), '.0e')} while ‖Kφ−λMφ‖/‖Kφ‖ grows "
            f"from {g(res[0])} to {g(res[-1])} (∝ (L/h)^{g(loglog_slope(lh, res), '.1f')}). "
            "The first bending frequency is within " +
            ", ".join(f"{r['error_timoshenko']:+.1e}" for r in rs) +
            " of Timoshenko and " + ", ".join(f"{r['error_euler_bernoulli']:+.1e}" for r in rs) +
            " of Euler–Bernoulli (the shear and rotary-inertia correction fades as (h/L)²). "
            "The eigen-solve takes " + ", ".join(f"{g(r['eigensolve_s'], '.1f')} s" for r in rs) +
            " (" + ", ".join(f"{r['ndofs']:,}" for r in rs) + " DOFs).")
    return text


def text_modes(rows: list[dict]) -> str:
    parts = []
    for body in ("beam", "crankshaft"):
        rs = sorted((r for r in good(rows) if r["body"] == body), key=lambda r: r["modes"])
        bad = [r for r in rows if r["body"] == body and r not in rs]
        if not rs:
            if bad:
                parts.append(f"{body}: {bad[0]['case']} ended {bad[0]['outcome']}: "
                             f"{bad[0]['last_stderr']}.")
            continue
        nm = [r["modes"] for r in rs]
        sel = [r["selection_reduction_s"] for r in rs]
        sps = [r["steps_per_second"] for r in rs]
        parts.append(
            f"{body} ({rs[0]['ndofs']:,} DOFs), Nm = {', '.join(map(str, nm))}: columns "
            + ", ".join(f"{r['columns_before']} → {r['columns_after']}" for r in rs) +
            f"; cond(Mr) after {span_text([r['cond_mr_after'] for r in rs])} (before "
            f"{span_text([r['cond_mr_before'] for r in rs], '.1e')}); "
            f"pruning error at most {g(max(r['pruning_error'] for r in rs))}; selection + "
            f"reduction {', '.join(f'{s:.2f}' for s in sel)} s{power(nm, sel)}, "
            + ", ".join(f"{r['selection_over_eigensolve']:.1%}" for r in rs) +
            " of the eigen-solve; Newton " + ", ".join(f"{r['newton_iterations_mean']:.2f}"
                                                      for r in rs) +
            " iterations per step and " + ", ".join(f"{s:,.0f}" for s in sps) +
            f" steps/s{power(nm, sps)}; energy_drift_rel of the short scene "
            + ", ".join(g(r["energy_drift_rel"]) for r in rs)
            + (f"; {', '.join(r['case'] for r in bad)} ended otherwise" if bad else "") + ".")
    return " ".join(parts) or "No result."


def text_long(rows: list[dict]) -> str:
    parts = []
    for r in rows:
        if r["case"].endswith("reduce"):
            continue
        if r["outcome"] != "ok" or "read_error" in r:
            parts.append(f"{r['case']}: exit {r['exit_status']} ({r['outcome']}): "
                         f"{r.get('read_error') or r['last_stderr']}.")
            continue
        share, peaks = r.get("drift_share"), r.get("window_maxima") or [0, 0]
        shape = ("stays flat" if share is not None and share < 0.1 else
                 "was not fitted" if share is None else
                 "drifts steadily away from zero" if peaks[-1] > peaks[min(1, len(peaks) - 1)]
                 else "drifts steadily back towards zero")
        parts.append(
            f"{r['case']} ({r['steps']:,} steps to {g(r.get('end_time_s'), 'g')} s): after the "
            f"first tenth the balance error {shape} ({g(r.get('drift_per_s'), '+.1e')} per s, "
            f"{g(share, '.0%')} of its largest value over the run; window maxima "
            f"{g(r['max_first_tenth'])} in the first tenth, {g(r['max_last_tenth'])} in the "
            f"last, ∝ t^{g(r.get('growth_exponent'), '.2f')}); energy_drift_rel "
            f"{g(r['energy_drift_rel'])}; Newton {g(r['newton_iterations_mean'], '.2f')} per "
            f"step (at most {r['newton_iterations_max']}); "
            f"{g(r['steps_per_second'], ',.0f')} steps/s.")
    ok = {r["case"]: r for r in good(rows)}
    coarse = ok.get(f"crankshaft, drive ×{DRIVE_FACTORS[-1]}")
    fine = ok.get(f"crankshaft, drive ×{DRIVE_FACTORS[-1]}, step / 4")
    if coarse and fine and coarse.get("drift_per_s") and fine.get("drift_per_s"):
        parts.append(
            f"A quarter of the step at ×{DRIVE_FACTORS[-1]} (the shaft turning "
            f"{fine['rotation_per_step_rad']:.3f} instead of {coarse['rotation_per_step_rad']:.3f}"
            f" rad per step) cuts energy_drift_rel by "
            f"{coarse['energy_drift_rel'] / fine['energy_drift_rel']:.0f}×"
            f" and the drift rate by {abs(coarse['drift_per_s'] / fine['drift_per_s']):.0f}× "
            f"(16× for a second-order method in its asymptotic range): the error is the "
            f"step's, not an instability.")
    return " ".join(parts) or "No result."


def text_material(rows: list[dict]) -> str:
    nus = sorted((r for r in good(rows) if r["case"].startswith("ν")), key=lambda r: r["nu"])
    es = sorted((r for r in good(rows) if r["case"].startswith("E")), key=lambda r: r["E"])
    bad = [r for r in rows if r["outcome"] != "ok"]
    parts = []
    if nus:
        parts.append(
            "Poisson's ratio " + ", ".join(f"{r['nu']:g}" for r in nus) +
            ": the first (weak-axis) bending frequency is " +
            ", ".join(f"{r['error_weak']:+.1e}" for r in nus) + " and the strong-axis one " +
            ", ".join(f"{r['error_strong']:+.1e}" for r in nus) + " from Timoshenko (Cowper κ(ν)): "
            f"towards incompressibility the error grows by "
            f"{g(nus[-1]['error_weak'] - nus[0]['error_weak'], '+.1e')} (ν = {nus[-1]['nu']:g} "
            f"against {nus[0]['nu']:g}), the volumetric locking of the P2 tetrahedra in bending "
            f"at this mesh. "
            "Smallest verification margins " +
            ", ".join(smallest_margin(r) for r in nus) + "; pruning error " +
            ", ".join(g(r["pruning_error"]) for r in nus) + ".")
    if es:
        cmp = [r for r in es if r.get("frequency_difference") is not None and r["E"] != E_REFERENCE]
        parts.append(
            f"E from {es[0]['E']:.0e} to {es[-1]['E']:.0e} Pa: f·√(E₀/E) equals f(E₀ = "
            f"{E_REFERENCE:.0e}) to "
            f"{g(max((r['frequency_difference'] for r in cmp), default=None))}"
            f" on the same mesh file ({every(cmp, 'same_mesh_file')}), "
            f"with the same fields kept ({every(cmp, 'same_fields_kept')}) "
            f"and cond(Mr) after within "
            f"{g(max((r.get('cond_mr_after_change') or 0) for r in cmp))}; the pruning error "
            f"moves between {g(min(r['pruning_error'] for r in es))} and "
            f"{g(max(r['pruning_error'] for r in es))} (round-off).")
    if bad:
        parts.append("Ended otherwise: " + "; ".join(f"{r['case']} exit {r['exit_status']}: "
                                                     f"{r['last_stderr']}" for r in bad) + ".")
    return " ".join(parts) or "No result."


def text_mpi(rows: list[dict]) -> str:
    two = next((r for r in good(rows) if r.get("ranks") == 2), None)
    if two is None or "kr_difference" not in two:
        bad = [r for r in rows if r["outcome"] != "ok"]
        return "No comparison." + (f" {bad[0]['case']}: exit {bad[0]['exit_status']}: "
                                   f"{bad[0]['last_stderr']}" if bad else "")
    return (f"`gcms reduce` on 2 ranks against 1 ({two['ndofs']:,} DOFs): frequencies agree to "
            f"{g(two['frequency_difference'])}, the fields kept are the same "
            f"({f(two['same_fields_kept'])}); after matching the nodes by position (to "
            f"{g(two['node_match_over_size'])} of the body) and the signs of the "
            f"{two['sign_flips']} fields that came out flipped, F agrees to "
            f"{g(two['fields_difference'])}, Mr to {g(two['mr_difference'])} and Kr to "
            f"{g(two['kr_difference'])} of their largest entries. The preconditioned basis "
            f"undoes a near-dependency of cond(Mr) = {g(two['cond_mr_before'])} before "
            f"selection, which amplifies round-off by up to its square root, "
            f"{g(math.sqrt(two['cond_mr_before']))}.")


TEXTS = {"symmetry": text_symmetry, "units": text_units, "slenderness": text_slenderness,
         "modes": text_modes, "long": text_long, "material": text_material, "mpi": text_mpi}
TITLES = {
    "symmetry": "Symmetry perturbation: a 30 mm square steel beam (0.5 m, 7.5 mm P2 mesh, "
                "Nm = 10) widened by ε",
    "units": "Units and size: the same beam in SI, in mm-t-s, and scaled by 1e-3 and 1e3",
    "slenderness": "Slenderness: 10 mm square steel beams, mesh h/2 up to L/h = 200, h above",
    "modes": "Many modes: a 50×40 mm × 1 m steel beam and the default crankshaft, 200 steps "
             "of a short scene",
    "long": "Long runs: the flexible pendulum and the default crankshaft scene (drive ×1, ×3, ×10)",
    "material": "Material extremes: a 30×20 mm × 0.5 m steel beam, ν up to 0.499 and E over "
                "ten decades",
    "mpi": "One and two MPI ranks: `gcms reduce` of a 30×20 mm × 0.5 m beam, Nm = 8",
}


def markdown(document: dict) -> str:
    classes = document["classes"]
    rows = [r for c in classes.values() for r in c["rows"]]
    bad = broken(rows)
    minutes = sum(c.get("wall_s", 0.0) for c in classes.values()) / 60
    modes = sorted({c["mode"] for c in classes.values()})
    lines = ["## Numerical stability", "",
             f"`python workflows/stability.py` ({' and '.join(modes)} run here: "
             f"{minutes:.0f} minutes; `--quick` runs the smallest members, `--only CLASS` one "
             "class) drives the `gcms` command on studies chosen to stress it and writes "
             "`docs/stability.json`, `docs/stability.png` ([picture](docs/stability.png)) "
             "and this section. Every command "
             "must end in a result or in one line with exit status 1 or 2 and `--out` as it "
             "was; " + (f"of {len(rows)} commands, all did." if not bad else
                        f"of {len(rows)} commands, {len(bad)} did not: " +
                        "; ".join(f"{r['class']}/{r['case']} ({r['problem']})" for r in bad) +
                        "."), ""]
    for i, cls in enumerate(CLASSES, 1):
        if cls not in classes:
            continue
        c = classes[cls]
        try:
            text = TEXTS[cls](c["rows"])
        except (KeyError, TypeError, ValueError, IndexError, ZeroDivisionError) as exc:
            text = f"(no summary: the rows lack {type(exc).__name__} {exc}; rerun the class)"
        lines += [f"**{i}. {TITLES[cls]}** ({c['mode']} run, {c['date']}, {c['git']}). "
                  + text, "", table(cls, c["rows"]), ""]
    return "\n".join(lines)


# -- the picture (docs/stability.png) ----------------------------------------------------------

def plot(document: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    classes = {k: good(v["rows"]) for k, v in document["classes"].items()}
    fig, axes = plt.subplots(2, 4, figsize=(23, 9.5))

    def empty(ax, title):
        ax.set_title(title)
        ax.text(0.5, 0.5, "not run", ha="center", va="center", transform=ax.transAxes)

    ax = axes[0, 0]
    rs = sorted(classes.get("slenderness", []), key=lambda r: r["slenderness"])
    if rs:
        lh = [r["slenderness"] for r in rs]
        ax.loglog(lh, [abs(r["error_euler_bernoulli"]) for r in rs], "o-",
                  label="|f₁/f_EB − 1|")
        ax.loglog(lh, [abs(r["error_timoshenko"]) for r in rs], "s-", label="|f₁/f_Timoshenko − 1|")
        ax.loglog(lh, [r["max_relative_residual"] for r in rs], "^--",
                  label="‖Kφ−λMφ‖/‖Kφ‖ (reported)")
        ax.loglog(lh, [r["max_backward_error"] for r in rs], "v--",
                  label="backward error (checked)")
        ax.set_xlabel("L/h")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("slenderness: first bending frequency and residuals")
    else:
        empty(ax, "slenderness")

    ax = axes[0, 1]
    if rs:
        for name in sorted({k for r in rs for k in r["margins"]} - {"sylvester"}):
            pts = [(r["slenderness"], r["margins"].get(name)) for r in rs
                   if r["margins"].get(name)]
            if pts:
                ax.loglog(*zip(*pts), "o-", label=name)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xlabel("L/h")
        ax.set_ylabel("limit / measured (fails below 1)")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("slenderness: verification margins")
    else:
        empty(ax, "slenderness: verification margins")

    ax = axes[0, 2]
    eps = sorted((r for r in classes.get("symmetry", []) if r["case"].startswith("ε")),
                 key=lambda r: r["epsilon"])
    cut = [r for r in classes.get("symmetry", []) if r["case"].startswith("Nm")
           and r.get("tip_difference_over_L")]
    if eps:
        x = [r["epsilon"] for r in eps]
        for key, label in (("sigma_min", "σ_min (of per-mode-scaled fields)"),
                           ("pruning_error", "pruning error"),
                           ("pair_split", "first bending pair split"),
                           ("tip_difference_over_L", "pendulum tip vs ε = 0, / L"),
                           ("frequency_difference", "max freq. change vs ε = 0")):
            pts = [(a, r.get(key) if key != "sigma_min" else r["sigma_smallest"][0])
                   for a, r in zip(x, eps)]
            pts = [(a, b) for a, b in pts if b]
            if pts:
                ax.plot(*zip(*pts), "o-", label=label)
        ax.plot([e for e in x if e > 0], [e for e in x if e > 0], "k:", lw=0.8, label="ε")
        for r in cut:
            ax.plot([r["epsilon"]], [r["tip_difference_over_L"]], "rx", ms=8,
                    label=f"tip vs ε = 0 with Nm = {r['modes']} (cuts a pair)")
        ax.set_xscale("symlog", linthresh=1e-7)
        ax.set_xticks(x, [f"{e:g}" for e in x], fontsize=8)
        ax.minorticks_off()
        ax.set_yscale("log")
        ax.set_xlabel("ε (width = side·(1+ε))")
        for a, r in zip(x, eps):
            ax.annotate(f"{r['fields_kept_count']}", (a, r["sigma_smallest"][0]),
                        textcoords="offset points", xytext=(0, 6), fontsize=7, ha="center")
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("symmetry: continuity in ε (numbers: fields kept)")
    else:
        empty(ax, "symmetry")

    ax = axes[1, 0]
    longs = [r for r in classes.get("long", []) if "balance" in r]
    if longs:
        for r in longs:
            t, y = np.array(r["balance"]["t"]), np.abs(r["balance"]["y"])
            ax.semilogy(t / t[-1], np.maximum(y, 1e-18), lw=0.9,
                        label=f"{r['case']} ({t[-1]:g} s, p = {g(r['growth_exponent'], '.2f')})")
        ax.set_xlabel("t / end time")
        ax.set_ylabel("|balance error| / max(kinetic + elastic)")
        ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("long runs: energy balance over time")
    else:
        empty(ax, "long runs")

    ax = axes[1, 1]
    ms = classes.get("modes", [])
    if ms:
        twin = ax.twinx()
        for i, body in enumerate(("beam", "crankshaft")):
            rb = sorted((r for r in ms if r["body"] == body), key=lambda r: r["modes"])
            if not rb:
                continue
            nm = [r["modes"] for r in rb]
            ax.loglog(nm, [r["selection_reduction_s"] for r in rb], "o-", color=f"C{i}",
                      label=f"{body}: selection + reduction s")
            ax.loglog(nm, [r["eigensolve_s"] for r in rb], "s:", color=f"C{i}",
                      label=f"{body}: eigen-solve s")
            twin.loglog(nm, [r["steps_per_second"] for r in rb], "^--", color=f"C{i + 2}",
                        label=f"{body}: steps/s")
        ax.set_xlabel("Nm")
        ax.set_ylabel("s")
        twin.set_ylabel("steps/s")
        ax.legend(fontsize=7, loc="upper left")
        twin.legend(fontsize=7, loc="lower right")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("many modes: cost against Nm")
    else:
        empty(ax, "many modes")

    ax = axes[0, 3]
    mat = classes.get("material", [])
    nus = sorted((r for r in mat if r["case"].startswith("ν")), key=lambda r: r["nu"])
    if nus:
        x = [0.5 - r["nu"] for r in nus]
        ax.semilogx(x, [r["error_weak"] for r in nus], "o-", label="f₁ (weak axis)")
        ax.semilogx(x, [r["error_strong"] for r in nus], "s-", label="f₂ (strong axis)")
        for a, r in zip(x, nus):
            ax.annotate(f"ν = {r['nu']:g}", (a, r["error_weak"]), textcoords="offset points",
                        xytext=(0, 6), fontsize=7, ha="center")
        ax.invert_xaxis()
        ax.set_xlabel("0.5 − ν")
        ax.set_ylabel("f / f_Timoshenko(κ(ν)) − 1")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("material: bending frequencies towards incompressibility")
    else:
        empty(ax, "material: ν")

    ax = axes[1, 2]
    es = sorted((r for r in mat if r["case"].startswith("E") and r["E"] != E_REFERENCE
                 and r.get("frequency_difference") is not None), key=lambda r: r["E"])
    if es:
        E = [r["E"] for r in es]
        ax.loglog(E, [max(r["frequency_difference"], 1e-17) for r in es], "o-",
                  label="max |f·√(E₀/E) / f(E₀) − 1|")
        ax.loglog(E, [max(r.get("cond_mr_after_change") or 0, 1e-17) for r in es], "s-",
                  label="|cond(Mr) after / at E₀ − 1|")
        ax.loglog(E, [max(r.get("pruning_error") or 0, 1e-17) for r in es], "^:",
                  label="pruning error")
        ax.axvline(E_REFERENCE, color="k", lw=0.6)
        ax.set_xlabel("E Pa (E₀ = 1e10)")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title("material: E over ten decades, same mesh")
    else:
        empty(ax, "material: E")

    ax = axes[1, 3]
    bars = []
    for r in classes.get("units", []):
        if r["case"] != "SI":
            bars.append((f"{r['case']}: frequencies", r.get("frequency_difference")))
            bars.append((f"{r['case']}: cond(Mr) after", r.get("cond_mr_after_change")))
            if r.get("tip_difference_over_L") is not None:
                bars.append((f"{r['case']}: tip / L", r["tip_difference_over_L"]))
    for r in classes.get("mpi", []):
        if r.get("ranks") == 2:
            for key, label in (("frequency_difference", "frequencies"), ("mr_difference", "Mr"),
                               ("kr_difference", "Kr"), ("fields_difference", "F")):
                bars.append((f"2 ranks: {label}", r.get(key)))
    bars = [(k, v) for k, v in bars if v is not None]
    if bars:
        ax.barh(range(len(bars)), [max(v, 1e-17) for _, v in bars], color="C0")
        ax.set_yticks(range(len(bars)), [k for k, _ in bars], fontsize=7)
        ax.set_xscale("log")
        ax.invert_yaxis()
        ax.grid(True, which="both", axis="x", alpha=0.3)
        ax.set_xlabel("relative difference from SI / 1 rank")
        ax.set_title("units, size and MPI ranks: what differs")
    else:
        empty(ax, "units and MPI")

    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
