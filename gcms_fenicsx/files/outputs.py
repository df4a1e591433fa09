"""Writing results so that a failure or an interrupt never leaves a half-written file behind.

A command's files are written into a private staging folder and moved into the output
folder only when every stage has succeeded; single files are written to a temporary name
and renamed. The staging folder sits in the output folder's nearest existing ancestor, so a
failed command creates nothing: not even an empty ``--out``. A staging folder whose process
died without cleaning up (SIGKILL, power loss) is removed by the next command that stages
there. Under MPI, rank 0 owns the file system; without a communicator nothing here imports
MPI (the standalone integrator writes through it).

JSON is written strictly (RFC 8259: no NaN or Infinity); a number that is not finite is
written as null.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import socket
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, TypeVar

from gcms_fenicsx.runtime.interrupts import deferred
from gcms_fenicsx.config.table import ConfigError

T = TypeVar("T")
#: Staging folders are named ``.gcms-staging-<host>-<pid>-<random>``.
STAGING_PREFIX = ".gcms-staging-"
#: What an earlier version named its staging folders inside ``--out``.
LEGACY_STAGING_PREFIX = ".staging-"


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write; rename it to ``path`` when the block
    succeeds, delete it on any failure (an interrupt too): ``path`` is either the old file
    or the whole new one, never half of it."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o644)
        os.close(fd)
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def finite_json(data: Any) -> Any:
    """``data`` with every non-finite float replaced by None (and tuples by lists)."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {key: finite_json(value) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [finite_json(value) for value in data]
    return data


def json_text(data: Any, indent: int | None = None) -> str:
    """Strict JSON of ``data`` (:func:`finite_json` first); TypeError for what JSON cannot hold."""
    return json.dumps(finite_json(data), indent=indent, allow_nan=False)


def write_json(path: Path, data: Any) -> None:
    """Write strict JSON atomically (:func:`atomic_file`, :func:`json_text`)."""
    with atomic_file(path) as tmp:
        tmp.write_text(json_text(data, indent=2) + "\n")


def _staging_home(out_dir: Path) -> Path:
    """Where the staging folder goes: the nearest existing ancestor of ``out_dir`` (beside it
    when it exists). ConfigError if ``out_dir`` or an ancestor is a file, or ``out_dir``
    exists but cannot be written."""
    for candidate in (out_dir, *out_dir.parents):
        if candidate.exists() and not candidate.is_dir():
            where = "is an existing file" if candidate == out_dir else \
                f"lies below {candidate}, which is a file"
            raise ConfigError("--out", str(out_dir), f"{where}: give a folder")
        if candidate.exists() and candidate != out_dir:
            break
    if out_dir.is_dir() and not os.access(out_dir, os.W_OK):
        raise ConfigError("--out", str(out_dir), f"cannot be written: {_not_writable(out_dir)}")
    return next(c for c in out_dir.parents if c.exists()) if out_dir.parents else Path(".")


def check_out(out_dir: Path) -> None:
    """ConfigError if ``out_dir`` is a file, lies below a file or exists but cannot be
    written: what :func:`staged_output` refuses, said before a command plans or reads
    anything in it."""
    _staging_home(Path(out_dir))


def _not_writable(folder: Path) -> str:
    """Why the folder ``folder``, which ``os.access`` says cannot be written, cannot: its file
    system is mounted read-only (as root too: EROFS), or its permissions."""
    if os.statvfs(folder).f_flag & os.ST_RDONLY:
        return "Read-only file system (mounted read-only)"
    return "Permission denied"


def _stale_staging(folder: Path) -> Iterable[Path]:
    """Staging folders in ``folder`` left by processes of this host that no longer run."""
    host = socket.gethostname()
    for item in folder.glob(f"{STAGING_PREFIX}{host}-*"):
        pid = item.name[len(f"{STAGING_PREFIX}{host}-"):].split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            yield item


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _make_staging(out_dir: Path) -> Path:
    """A new staging folder beside where ``out_dir`` will be; stale ones removed first."""
    home = _staging_home(out_dir)
    for stale in _stale_staging(home):
        shutil.rmtree(stale, ignore_errors=True)
    if out_dir.is_dir():  # an earlier version staged inside --out
        for stale in out_dir.glob(f"{LEGACY_STAGING_PREFIX}*"):
            shutil.rmtree(stale, ignore_errors=True)
    try:
        return Path(tempfile.mkdtemp(dir=home, prefix=f"{STAGING_PREFIX}{socket.gethostname()}-"
                                                      f"{os.getpid()}-"))
    except OSError as exc:
        raise ConfigError("--out", str(out_dir), f"cannot be written: {exc.strerror} in "
                                                 f"{home}") from exc


def _publish(staging: Path, out_dir: Path, owns: Iterable[str]) -> None:
    """Move the staged files into ``out_dir`` (created with its parents), replacing the files
    there; remove the files of ``owns`` that this command did not produce this time. A folder
    under one of those names is refused before anything moves (:func:`_refuse_folders`)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    produced = {item.name for item in staging.iterdir()}
    _refuse_folders(out_dir, produced | set(owns))
    for name in sorted(set(owns) - produced):
        (out_dir / name).unlink(missing_ok=True)
    for item in sorted(staging.iterdir()):
        os.replace(item, out_dir / item.name)


def _refuse_folders(out_dir: Path, names: Iterable[str]) -> None:
    """ConfigError if ``out_dir`` holds a folder under a name the command writes a file to:
    a folder there is the user's, never replaced."""
    for name in sorted(names):
        if (out_dir / name).is_dir():
            raise ConfigError("--out", str(out_dir), f"holds a folder {name!r} where this "
                              "command writes a file: move or rename the folder")


@contextmanager
def staged_output(out_dir: Path, comm: Any = None, owns: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a staging folder; on success move its files into ``out_dir``, on any failure or
    interrupt delete it, leaving ``out_dir`` exactly as it was (or absent, if it was).

    Files in ``out_dir`` that the command did not produce are left untouched, except those
    named in ``owns`` (what this command writes when it runs fully): a file of ``owns`` it did
    not write this time (a plot a stopped simulation could not draw) would describe an
    earlier run, so it is removed. ``--out`` that is a file, lies below a file, cannot be
    written or holds a folder under a name of ``owns`` is a ConfigError before anything
    runs. ``comm``: an mpi4py communicator whose ranks all write through rank 0, or None
    (serial).
    """
    out_dir = Path(out_dir)
    rank = 0 if comm is None else comm.rank
    staging, error = None, None
    if rank == 0:
        try:
            _refuse_folders(out_dir, owns)
            staging = _make_staging(out_dir)
        except ConfigError as exc:
            error = exc
    if comm is not None:
        staging, error = comm.bcast((staging, error), root=0)
    if error is not None:
        raise error
    ok = False
    try:
        yield Path(staging)
        ok = True
    finally:
        if comm is not None:
            from mpi4py import MPI
            ok = comm.allreduce(ok, op=MPI.LAND)
        if rank == 0:
            try:
                if ok:
                    with deferred():
                        _publish(Path(staging), out_dir, owns)
            finally:
                shutil.rmtree(staging, ignore_errors=True)
        if comm is not None:
            comm.barrier()


def on_rank0(comm: Any, fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` on rank 0 only; its result, or the exception it raised, on every rank."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn(*args)
        except Exception as exc:  # re-raised on every rank below
            error = exc
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result
