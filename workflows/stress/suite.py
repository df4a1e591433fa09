"""A probe class's rows (:class:`Suite`) and the run of one class: its rows with the mode,
date, revision and wall time, a fault of the suite itself kept as a row."""
from __future__ import annotations

import datetime
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from common import commit
from stress import log
from stress.readers import Reader
from stress.runner import Run


@dataclass
class Suite:
    """The rows of one probe class, its size (``quick``) and its working folder."""

    quick: bool
    folder: Path
    rows: list[dict] = field(default_factory=list)

    def probe(self, cls: str, case: str, run: Run, read: Reader | None = None,
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
        """The --out of the command called ``name`` in the working folder."""
        return self.folder / name.replace(" ", "_").replace("/", "_")


Probe = Callable[[Suite], None]


def run_class(cls: str, probe: Probe, quick: bool, folder: Path) -> dict:
    """Run one probe class in ``folder``: its record in OUT.json (mode, date, revision, wall
    time and rows; a fault of the suite is a row of outcome "suite error" and ends the class)."""
    log(f"[{cls}]")
    suite = Suite(quick, folder)
    t0 = time.perf_counter()
    try:
        probe(suite)
    except Exception as exc:  # noqa: BLE001 - a fault of the suite: kept, next class
        suite.rows.append({"class": cls, "case": "suite error", "command": "",
                           "exit_status": None, "last_stderr": "", "wall_s": 0.0,
                           "outcome": "suite error", "problem": "", "study": "",
                           "read_error": f"{type(exc).__name__}: {exc}"})
        log(f"  suite error in {cls}: {type(exc).__name__}: {exc}")
    return {"mode": "quick" if quick else "full",
            "date": datetime.datetime.now().isoformat(timespec="seconds"),
            "git": commit(short=True), "wall_s": time.perf_counter() - t0, "rows": suite.rows}
