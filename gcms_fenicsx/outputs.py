"""Writing results so that a failure never leaves a half-written file behind.

A command's files are written into a private staging folder beside the output folder
and moved into place only when every stage has succeeded; single files are written
to a temporary name and renamed. Under MPI, rank 0 owns the file system.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from mpi4py import MPI


def write_json(path: Path, data: Any) -> None:
    """Write JSON atomically (temporary file in the same folder, then rename)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o644)
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=2)
            f.write("\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def staged_output(out_dir: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> Iterator[Path]:
    """Yield a staging folder; on success move its files into ``out_dir``, on failure delete it.

    Files already in ``out_dir`` that the command did not produce are left untouched.
    """
    out_dir = Path(out_dir)
    staging = None
    if comm.rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
        staging = tempfile.mkdtemp(dir=out_dir, prefix=".staging-")
    staging = Path(comm.bcast(staging, root=0))
    ok = False
    try:
        yield staging
        ok = True
    finally:
        ok = comm.allreduce(ok, op=MPI.LAND)
        if comm.rank == 0:
            if ok:
                for item in sorted(staging.iterdir()):
                    target = out_dir / item.name
                    if target.is_dir():
                        shutil.rmtree(target)
                    os.replace(item, target)
            shutil.rmtree(staging, ignore_errors=True)
        comm.barrier()
