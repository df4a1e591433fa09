"""Running ``gcms`` as a user does (a study file, ``--out``, a child process, under ``mpirun``
for several ranks) and judging how it ended against the command's contract (README, "Using
it"): a result (exit status 0, its files written, strict JSON) or one line with exit status 1
or 2 and ``--out`` exactly as it was and no staging folder left behind; the one documented
exception, a simulation that stops early, keeps ``results.h5`` marked incomplete (a system
study: ``system.h5``, its ``summary.json`` saying so). Anything else is BROKEN."""
from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from stress import REPO, log
from stress.readers import read_trajectory, strict_json
from stress.studies import toml_text

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
    "system": ("system.h5", "summary.json"),    # `gcms run` of a system study
}
#: The file a simulation that stops early keeps, by the command's kind.
RESULTS = {"simulate": "results.h5", "run": "results.h5", "system": "system.h5"}
STRICT_JSON = ("mesh.json", "modes.json", "selection.json", "summary.json")


def child_env() -> dict:
    """The environment of a command: mpirun as root, one BLAS and OpenMP thread."""
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
    """The last line of ``text`` that is not blank ("" when none)."""
    lines = [line for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


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
        """Whether the command ended in a result."""
        return self.outcome == "ok"

    def row(self) -> dict:
        """The row entries of how the command ended."""
        return {"command": self.command, "exit_status": self.exit_status,
                "last_stderr": last_line(self.stderr), "wall_s": self.wall_s,
                "outcome": self.outcome, "problem": self.problem}


def judge_result(out: Path, subcommand: str) -> tuple[str, str]:
    """(outcome, problem) of exit status 0: every expected file written, the JSON strict."""
    missing = [n for n in EXPECTED[subcommand] if not (out / n).exists()]
    if missing:
        return "BROKEN", f"exit status 0 but {', '.join(missing)} not written"
    for name in STRICT_JSON:
        if (out / name).exists():
            try:
                strict_json(out / name)
            except ValueError as exc:
                return "BROKEN", f"exit status 0 but {name} is not strict JSON: {exc}"
    return "ok", ""


def judge_stopped(out: Path, stderr: str, kind: str) -> tuple[str, str]:
    """(outcome, problem) of a simulation that ended with exit status 1 and changed --out:
    the documented exception when its results (results.h5; a system's summary.json) say
    incomplete and the last line says so."""
    said = RESULTS[kind] if kind != "system" else "summary.json"
    try:
        complete = (strict_json(out / said)["complete"] if kind == "system" else
                    read_trajectory(out).complete)
    except Exception as exc:  # noqa: BLE001 - any failure to read it is the finding
        return "BROKEN", f"exit status 1, {said} left unreadable: {exc}"
    if complete:
        return "BROKEN", f"exit status 1 but --out changed and {said} says complete"
    # it prints the run's summary before its last line, so no count of lines here
    return "incomplete", ("" if "incomplete" in last_line(stderr) else
                          "exit status 1, results kept, but the last line does not say "
                          "they are incomplete")


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
        return judge_result(run.out, subcommand)
    if status not in (1, 2):
        return "BROKEN", f"exit status {status}: {last_line(err)}"
    if status == 1 and subcommand in RESULTS and before != after \
            and (run.out / RESULTS[subcommand]).exists():
        return judge_stopped(run.out, err, subcommand)
    lines = error_lines(err, mpi)
    if len(lines) != 1:
        return "BROKEN", f"exit status {status} with {len(lines)} error lines, not one"
    if before != after:
        changed = sorted(set(before or {}) ^ set(after or {}) |
                         {k for k in set(before or {}) & set(after or {})
                          if before[k] != after[k]})
        what = "created" if before is None else f"changed: {', '.join(changed[:4])}"
        return "BROKEN", f"exit status {status} and --out {what}"
    return ("failed (1)" if status == 1 else "bad input (2)"), ""


def finish(proc: subprocess.Popen, timeout: float) -> tuple[int | None, str]:
    """(exit status, stderr) of ``proc``; after ``timeout`` its process group is stopped
    (SIGTERM, a minute later SIGKILL) and the exit status is None."""
    try:
        _, stderr = proc.communicate(timeout=timeout)
        return proc.returncode, stderr
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGTERM)  # the group of the child started here
        try:
            _, stderr = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            _, stderr = proc.communicate()
        return None, stderr


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
    status, stderr = finish(proc, timeout)
    run = Run(shown, out, text, status, stderr, time.perf_counter() - t0)
    # the built-in default study (no file) is the crank train, a system study
    kind = "system" if subcommand == "run" and (study is None or "system" in study) \
        else subcommand
    run.outcome, run.problem = judge(run, kind, before, snapshot(out), ranks > 1)
    mark = "" if run.ok else f"  [{run.outcome}{': ' + run.problem if run.problem else ''}]"
    log(f"  {shown}: exit {status}, {run.wall_s:.1f} s{mark}")
    return run
