"""What the workflow scripts share: their common options, progress lines, temporary folders,
Markdown tables, matplotlib figures, and the records they write with their provenance.

The scripts run as ``python workflows/NAME.py`` and import this package as a sibling
(``from common import ...``: the script's folder is first on ``sys.path``). Nothing here
imports NumPy or the ``gcms_fenicsx`` package at import time, so a script may still pin its
BLAS threads (``OPENBLAS_NUM_THREADS``) after importing it. The crankshaft scene's outputs
and the sweep chain are in :mod:`common.crankshaft`, the rotor-basis benchmark's runs and
tables in :mod:`common.rotor`.

Options (:func:`parser`): ``--out`` (a path), ``--quick`` (the smoke run) and ``--repeat``
(at least one: :func:`repeat_count`, a bad value is one argparse line and exit status 2).

Records (:func:`write_record`, :func:`write_markdown`): every JSON record begins with
``"record": {"command", "commit", "date", "machine"}`` (:func:`record_header`), every
Markdown record with a paragraph saying the same (:func:`markdown_header`).
"""
from __future__ import annotations

import argparse
import contextlib
import datetime
import json
import logging
import os
import platform
import shlex
import subprocess
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

#: The checkout the workflows belong to.
REPO = Path(__file__).resolve().parents[2]


# --- options -------------------------------------------------------------------------------

def repeat_count(text: str) -> int:
    """``--repeat``: how many runs the best is taken of, at least one."""
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"needs a whole number of runs, not {text!r}") from None
    if count < 1:
        raise argparse.ArgumentTypeError(f"needs at least one run, not {count}")
    return count


def parser(doc: str | None, *, out: Path | str | None = None, out_help: str | None = None,
           quick: str | None = None, repeat: int | None = None) -> argparse.ArgumentParser:
    """An argument parser described by the first line of the script's docstring ``doc``, with
    the common options asked for: ``--out`` (default ``out``), ``--quick`` (its help
    ``quick``), ``--repeat`` (default ``repeat``, validated by :func:`repeat_count`)."""
    p = argparse.ArgumentParser(description=(doc or "").splitlines()[0] if doc else None)
    if quick is not None:
        p.add_argument("--quick", action="store_true", help=quick or None)
    if out is not None:
        p.add_argument("--out", type=Path, default=Path(out), help=out_help)
    if repeat is not None:
        p.add_argument("--repeat", type=repeat_count, default=repeat,
                       help="the best of this many runs is kept (at least 1)")
    return p


def worker_options(p: argparse.ArgumentParser, *names: str) -> None:
    """Hidden options of a script's own child processes (``--worker`` and the like)."""
    for name in names:
        p.add_argument(name, default=None, help=argparse.SUPPRESS)


def checkout(p: argparse.ArgumentParser, before: Path | None) -> None:
    """``--before DIR`` must be a checkout of the package (else one argparse line, exit 2)."""
    if before is not None and not (before / "gcms_fenicsx").is_dir():
        p.error(f"--before {before}: no gcms_fenicsx package there (make one with "
                "git worktree add DIR <commit>)")


# --- progress ------------------------------------------------------------------------------

def log(message: str) -> None:
    """A progress line on stderr."""
    print(message, file=sys.stderr, flush=True)


def quiet() -> None:
    """Silence the package's INFO logging (the progress lines are the script's own)."""
    logging.disable(logging.INFO)


# --- folders -------------------------------------------------------------------------------

@contextlib.contextmanager
def temporary_folder(prefix: str | None = None) -> Iterator[Path]:
    """A temporary folder as a Path, removed afterwards."""
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
        yield Path(tmp)


def run_interruptibly(main: Any, out: str) -> None:
    """``main()`` with SIGINT and SIGTERM raised as the package's ``Interrupted`` (so every
    temporary folder is removed on the way out); an interrupt ends in one line naming what is
    left as it was (``out``) and exit status 130 or 143, as the ``gcms`` command's."""
    from gcms_fenicsx.runtime.interrupts import Interrupted, interruptible

    try:
        with interruptible():
            main()
    except Interrupted as exc:
        print(f"interrupted ({exc}); {out} is as it was", file=sys.stderr)
        sys.exit(exc.exit_status)


# --- tables --------------------------------------------------------------------------------

def table_head(*columns: str) -> list[str]:
    """The first two lines of a Markdown table of ``columns``."""
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]


def table_row(*cells: Any) -> str:
    """One line of a Markdown table."""
    return "| " + " | ".join(str(c) for c in cells) + " |"


def fmt(value: float | None, spec: str = ".2%") -> str:
    """``value`` formatted by ``spec``, empty for None."""
    return "" if value is None else format(value, spec)


# --- figures -------------------------------------------------------------------------------

def pyplot():
    """matplotlib.pyplot on the Agg backend (no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path, dpi: int = 110, tight: bool = True) -> None:
    """Lay ``fig`` out (``tight``), write it to ``path`` and close it."""
    import matplotlib.pyplot as plt

    if tight:
        fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


# --- records -------------------------------------------------------------------------------

def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=REPO, text=True, capture_output=True,
                          timeout=10, check=False).stdout.strip()


def commit(short: bool = False) -> str | None:
    """The checkout's commit (``short``: abbreviated), with "+changes" when tracked files
    outside docs/ differ from it (the records and pages there are what workflows write, not
    what they run); None outside a git checkout."""
    try:
        rev = _git("rev-parse", *(["--short"] if short else []), "HEAD")
        dirty = _git("status", "--porcelain", "--untracked-files=no", "--", ".",
                     ":(exclude)docs")
    except (OSError, subprocess.SubprocessError):
        return None
    return rev + ("+changes" if dirty else "") if rev else None


def machine() -> str:
    """Host name, CPU model and core count."""
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return f"{platform.node()}: {cpu}, {os.cpu_count()} cores"


def command(argv: Sequence[str] | None = None) -> str:
    """The command line that runs this script, as typed in the checkout:
    ``python workflows/NAME.py ARGS``."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve()
    with contextlib.suppress(ValueError):
        script = script.relative_to(REPO)
    return shlex.join(["python", str(script), *argv[1:]])


def record_header(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """The provenance of a record: the command that made it, the commit, the date (ISO 8601,
    UTC) and the machine."""
    return {"command": command(argv), "commit": commit(),
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "machine": machine()}


def with_record(document: dict, record: dict | None = None) -> dict:
    """``document`` with the provenance ``record`` (a new one if None) as its first key."""
    body = {k: v for k, v in document.items() if k != "record"}
    return {"record": record_header() if record is None else record, **body}


def write_record(path: Path, document: dict, *, indent: int = 1, newline: bool = False,
                 **dump: Any) -> dict:
    """Write ``document`` as JSON to ``path`` with its provenance header first (its folder
    made): the document as written."""
    out = with_record(document)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=indent, **dump) + ("\n" if newline else ""))
    return out


def markdown_header(record: dict) -> str:
    """The provenance paragraph of a Markdown record."""
    return (f"*Record written by `{record['command']}` at commit {record['commit']}, "
            f"{record['date']}, on {record['machine']}.*")


def write_markdown(path: Path, text: str, record: dict | None = None) -> None:
    """Write the Markdown ``text`` to ``path`` under its provenance paragraph."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    header = markdown_header(record_header() if record is None else record)
    path.write_text(header + "\n\n" + text)
