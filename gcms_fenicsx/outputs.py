"""Writing results so that a failure never leaves a half-written file behind.

A command's files are written into a private staging folder beside the output folder
and moved into place only when every stage has succeeded; single files are written
to a temporary name and renamed. Under MPI, rank 0 owns the file system; without a
communicator nothing here imports MPI (the standalone integrator writes through it).
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, TypeVar

T = TypeVar("T")


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


def write_json(path: Path, data: Any) -> None:
    """Write JSON atomically (:func:`atomic_file`)."""
    with atomic_file(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2) + "\n")


@contextmanager
def staged_output(out_dir: Path, comm: Any = None) -> Iterator[Path]:
    """Yield a staging folder; on success move its files into ``out_dir``, on failure delete it.

    Files already in ``out_dir`` that the command did not produce are left untouched.
    ``comm``: an mpi4py communicator whose ranks all write through rank 0, or None (serial).
    """
    out_dir = Path(out_dir)
    rank = 0 if comm is None else comm.rank
    staging = None
    if rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
        staging = tempfile.mkdtemp(dir=out_dir, prefix=".staging-")
    staging = Path(staging if comm is None else comm.bcast(staging, root=0))
    ok = False
    try:
        yield staging
        ok = True
    finally:
        if comm is not None:
            from mpi4py import MPI
            ok = comm.allreduce(ok, op=MPI.LAND)
        if rank == 0:
            if ok:
                for item in sorted(staging.iterdir()):
                    target = out_dir / item.name
                    if target.is_dir():
                        shutil.rmtree(target)
                    os.replace(item, target)
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
