"""Opening a versioned gcms-fenicsx HDF5 file for reading: the checks every reader starts with.

A reader names its error class, what the file should be and the newest schema it
understands. It gets the open file and its schema version. A missing file, a file that is
not HDF5 (or is truncated), a missing, non-integer or newer ``schema_version``, and any h5py
or decoding error while the reader works inside the block all end as that error class,
with the path first. NumPy and h5py only: the standalone integrator reads through it.
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

#: What h5py and the decoding of its contents raise for a damaged file.
H5PY_ERRORS = (OSError, KeyError, RuntimeError, ValueError, TypeError)


@contextmanager
def open_versioned(path: Path, error: type[Exception], kind: str, schema: str,
                   newest: int) -> Iterator[tuple[h5py.File, int]]:
    """``(file, schema_version)`` of the ``kind`` file at ``path`` (e.g. "reduced model"),
    whose versions are called ``schema`` in messages; ``error`` for anything wrong."""
    where = str(path)
    if not path.is_file():
        raise error(f"{where}: " + ("not a file" if path.exists() else "no such file"))
    try:
        f = h5py.File(path, "r")
    except H5PY_ERRORS as exc:
        raise error(f"{where}: not a readable HDF5 file (not HDF5, or truncated): "
                    f"{exc}") from exc
    with f:
        try:
            yield f, _schema_version(f, error, where, kind, schema, newest)
        except error:
            raise
        except H5PY_ERRORS as exc:
            raise error(f"{where}: damaged HDF5 content: {exc}") from exc


def _schema_version(f: h5py.File, error: type[Exception], where: str, kind: str, schema: str,
                    newest: int) -> int:
    if "schema_version" not in f.attrs:
        raise error(f"{where}: no schema_version attribute: not a gcms-fenicsx {kind}")
    version = np.asarray(f.attrs["schema_version"])
    if version.shape != () or version.dtype.kind not in "iu":
        raise error(f"{where}: schema_version is {version!r}, expected an integer")
    version = int(version)
    if version > newest:
        raise error(f"{where}: written by a newer gcms-fenicsx: {schema} {version}, this reader "
                    f"understands up to {newest}")
    if version < 1:
        raise error(f"{where}: unknown schema_version {version}")
    return version
