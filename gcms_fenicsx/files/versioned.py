"""Versioned gcms-fenicsx HDF5 files: the checks every reader starts with, and content checksums.

A reader names its error class, what the file should be and the newest schema it
understands. It gets the open file and its schema version. A missing file, a file that is
not HDF5 (or is truncated), a missing, non-integer or newer ``schema_version``, and any h5py
or decoding error while the reader works inside the block all end as that error class,
with the path first.

Content checksums: a writer calls :func:`seal` on the finished file. Every dataset then
carries the SHA-256 of its contents (``sha256`` attribute; :func:`dataset_digest` says what
is hashed), the root the SHA-256 of its layout, the sorted paths of its datasets
(``layout_sha256``, among the attributes: a renamed group is caught), and of its other
attributes (``attributes_sha256``). Files sealed before the layout was (no
``layout_sha256``) are verified without it. From ``checksums_since`` on, :func:`open_versioned` verifies all of
them before the reader sees the file, so a changed or damaged value — one flipped bit in a
matrix that still looks valid — is an error naming the dataset, not silently read.
NumPy and h5py only: the standalone integrator reads through it.

A damaged file must not reach the HDF5 library unguarded: a flipped bit in a string
attribute's length crashes it (SIGSEGV, about one in 200 random damages of a results file)
and one in a dataset's extent makes the checksum read terabytes. So a file written through
:func:`created` carries the SHA-256 of all its bytes in its first ``USER_BLOCK`` bytes (the
HDF5 "user block", which the library leaves alone), checked in Python before HDF5 opens it;
a file whose bytes do not match is opened and verified in a child process first
(:func:`_check_in_child`), so a crash ends that process, not the reader's, and what the
child finds wrong is the error. A dataset whose extent is larger than its file could hold
is refused before it is read. Files written before the stamp are opened as they were.
"""
from __future__ import annotations

import hashlib
import json
import signal
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

#: What h5py and the decoding of its contents raise for a damaged file.
H5PY_ERRORS = (OSError, KeyError, RuntimeError, ValueError, TypeError)
#: Attribute holding a dataset's checksum, and the root's checksum of its other attributes.
DATASET_CHECKSUM = "sha256"
ATTRIBUTES_CHECKSUM = "attributes_sha256"
LAYOUT_CHECKSUM = "layout_sha256"


#: Bytes at the start of a file written through :func:`created` that HDF5 leaves to its
#: user: STAMP and the SHA-256 of every byte after them.
USER_BLOCK = 512
STAMP = b"gcms-fenicsx sha256 "
#: The largest ratio of a dataset's bytes to its file's (gzip's limit is about 1032:1): a
#: larger extent is damage, refused before the checksum would read it.
MAX_EXPANSION = 1100
#: Seconds a child process may take to verify a file, per MB of it and at least.
CHILD_S_PER_MB, CHILD_MIN_S = 2.0, 60.0


@contextmanager
def created(path: Path) -> Iterator[h5py.File]:
    """A new HDF5 file at ``path`` (a temporary name, ``outputs.atomic_file``) to write; when
    the block ends it is closed and stamped with the SHA-256 of its contents."""
    with h5py.File(path, "w", userblock_size=USER_BLOCK) as f:
        yield f
    with open(path, "r+b") as raw:
        raw.write(STAMP + _contents_digest(path).encode("ascii") + b"\n")


def _contents_digest(path: Path) -> str:
    """SHA-256 of the bytes of ``path`` after its user block."""
    digest = hashlib.sha256()
    with open(path, "rb") as raw:
        raw.seek(USER_BLOCK)
        for block in iter(lambda: raw.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def stamp_holds(path: Path) -> bool | None:
    """Whether the file's stamp matches its bytes; None for a file without one (written
    before the stamp, or by another program)."""
    with open(path, "rb") as raw:
        head = raw.read(len(STAMP) + 64)
    if not head.startswith(STAMP):
        return None
    return head[len(STAMP):].decode("ascii", "replace") == _contents_digest(path)


class DigestBuilder:
    """SHA-256 of an array fed in row blocks: its bytes (C order) then its dtype and shape.

    Appending rows in order gives the digest of the whole array, so a writer that streams a
    series to disk can checksum it without reading it back.
    """

    def __init__(self) -> None:
        self._hash = hashlib.sha256()

    def update(self, rows: np.ndarray) -> None:
        self._hash.update(np.ascontiguousarray(rows).tobytes())

    def hexdigest(self, dtype: np.dtype, shape: tuple[int, ...]) -> str:
        final = self._hash.copy()
        final.update(f"|{np.dtype(dtype).str}|{tuple(int(n) for n in shape)}".encode())
        return final.hexdigest()


def dataset_digest(data: np.ndarray) -> str:
    """SHA-256 of an array's bytes in C order, followed by its dtype and shape."""
    data = np.asarray(data)
    builder = DigestBuilder()
    builder.update(data)
    return builder.hexdigest(data.dtype, data.shape)


def attributes_digest(attrs: h5py.AttributeManager) -> str:
    """SHA-256 of a group's attributes (names and values), its own checksum left out."""
    items = {name: _plain(attrs[name]) for name in sorted(attrs) if name != ATTRIBUTES_CHECKSUM}
    return hashlib.sha256(json.dumps(items, sort_keys=True).encode()).hexdigest()


def _plain(value) -> object:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return {"dtype": value.dtype.str, "values": value.tolist()}
    if isinstance(value, np.generic):
        return value.item()
    return value


#: Bytes of a dataset read at once while its checksum is verified.
VERIFY_BLOCK_BYTES = 1 << 24


def stored_digest(ds: h5py.Dataset) -> str:
    """:func:`dataset_digest` of a dataset on disk, read in blocks of rows (bounded memory)."""
    if ds.ndim == 0 or ds.shape[0] == 0:
        return dataset_digest(ds[()])
    row_bytes = max(1, ds.dtype.itemsize * int(np.prod(ds.shape[1:])))
    rows = max(1, VERIFY_BLOCK_BYTES // row_bytes)
    builder = DigestBuilder()
    for start in range(0, ds.shape[0], rows):
        builder.update(ds[start:start + rows])
    return builder.hexdigest(ds.dtype, ds.shape)


def _datasets(f: h5py.File) -> list[h5py.Dataset]:
    found: list[h5py.Dataset] = []
    f.visititems(lambda _, obj: found.append(obj) if isinstance(obj, h5py.Dataset) else None)
    return found


def layout_digest(f: h5py.File) -> str:
    """SHA-256 of the sorted paths of the datasets of ``f``."""
    paths = sorted(ds.name for ds in _datasets(f))
    return hashlib.sha256("\n".join(paths).encode()).hexdigest()


def seal(f: h5py.File, digests: dict[str, str] | None = None) -> None:
    """Write the checksum of every dataset of the open file ``f`` and of its root attributes.

    ``digests`` maps dataset paths to checksums a streaming writer computed on the way
    (:class:`DigestBuilder`); the other datasets are read back and hashed here.
    """
    digests = digests or {}
    for ds in _datasets(f):
        ds.attrs[DATASET_CHECKSUM] = digests.get(ds.name) or stored_digest(ds)
    f.attrs[LAYOUT_CHECKSUM] = layout_digest(f)
    f.attrs[ATTRIBUTES_CHECKSUM] = attributes_digest(f.attrs)


def verify(f: h5py.File, error: type[Exception], where: str) -> None:
    """Raise ``error`` naming the first dataset (or the root attributes) whose content does not
    match the checksum written with it, or that has none."""
    damaged = "changed or damaged after it was written"
    if f.attrs.get(ATTRIBUTES_CHECKSUM) != attributes_digest(f.attrs):
        raise error(f"{where}: the root attributes do not match their checksum: the file was "
                    f"{damaged}" if ATTRIBUTES_CHECKSUM in f.attrs
                    else f"{where}: no content checksum ({ATTRIBUTES_CHECKSUM}): the file was "
                         "not written (or not finished) by gcms-fenicsx")
    if LAYOUT_CHECKSUM in f.attrs and f.attrs[LAYOUT_CHECKSUM] != layout_digest(f):
        raise error(f"{where}: its datasets' paths do not match their checksum (a group or "
                    f"dataset renamed, added or removed): the file was {damaged}")
    size = max(Path(f.filename).stat().st_size, 1)
    for ds in _datasets(f):
        if ds.nbytes > MAX_EXPANSION * size:
            raise error(f"{where}: dataset {ds.name} has shape {ds.shape}, {ds.nbytes:.3g} bytes "
                        f"in a file of {size} bytes: the file was {damaged}")
        stored = ds.attrs.get(DATASET_CHECKSUM)
        if stored is None:
            raise error(f"{where}: dataset {ds.name} has no content checksum: the file was "
                        f"{damaged}")
        if stored != stored_digest(ds):
            raise error(f"{where}: dataset {ds.name} does not match its checksum: the file was "
                        f"{damaged}")


@contextmanager
def open_versioned(path: Path, error: type[Exception], kind: str, schema: str, newest: int,
                   checksums_since: int | None = None) -> Iterator[tuple[h5py.File, int]]:
    """``(file, schema_version)`` of the ``kind`` file at ``path`` (e.g. "reduced model"),
    whose versions are called ``schema`` in messages; ``error`` for anything wrong.

    Files of schema ``checksums_since`` or newer have their checksums verified first.
    """
    where = str(path)
    if not path.is_file():
        raise error(f"{where}: " + ("not a file" if path.exists() else "no such file"))
    if stamp_holds(path) is False:
        _check_in_child(path, error, (kind, schema, str(newest), str(checksums_since)))
    with _opened(path, error, kind, schema, newest, checksums_since) as opened:
        yield opened


@contextmanager
def _opened(path: Path, error: type[Exception], kind: str, schema: str, newest: int,
            checksums_since: int | None) -> Iterator[tuple[h5py.File, int]]:
    """:func:`open_versioned` of an existing file, without the stamp's guard; the file is
    closed on every path out."""
    where = str(path)
    try:
        f = h5py.File(path, "r")
    except H5PY_ERRORS as exc:
        raise error(f"{where}: not a readable HDF5 file (not HDF5, or truncated): "
                    f"{exc}") from exc
    with f:
        try:
            version = _schema_version(f, error, where, kind, schema, newest)
            if checksums_since is not None and version >= checksums_since:
                verify(f, error, where)
            yield f, version
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


class _Damaged(Exception):
    """What a child process found wrong with a file (:func:`_check_in_child`)."""


def _check_in_child(path: Path, error: type[Exception], args: tuple[str, ...]) -> None:
    """Open and verify ``path`` as :func:`open_versioned` would with ``args`` (kind, schema,
    newest, checksums_since) in a child process: ``error`` with what it found wrong, or with
    how it ended if the HDF5 library crashed or it did not finish; nothing if it holds."""
    where = str(path)
    limit = max(CHILD_MIN_S, CHILD_S_PER_MB * path.stat().st_size / 1e6)
    try:
        child = subprocess.run([sys.executable, "-m", __name__, str(path), *args],
                               capture_output=True, text=True, timeout=limit)
    except subprocess.TimeoutExpired as exc:
        raise error(f"{where}: damaged: its bytes do not match the checksum written with them "
                    f"and reading it did not finish in {limit:.0f} s") from exc
    if child.returncode < 0:
        raise error(f"{where}: damaged: its bytes do not match the checksum written with them "
                    f"and the HDF5 library crashed reading it "
                    f"({signal.Signals(-child.returncode).name})")
    if child.returncode:
        found = child.stdout.strip() or child.stderr.strip()[-300:]
        raise error(found or f"{where}: damaged (exit status {child.returncode})")


def _main(argv: list[str]) -> int:
    """``python -m gcms_fenicsx.files.versioned PATH KIND SCHEMA NEWEST CHECKSUMS_SINCE``:
    open and verify PATH; what is wrong on stdout and exit status 1, or exit status 0."""
    path, kind, schema, newest, since = argv
    try:
        with _opened(Path(path), _Damaged, kind, schema, int(newest),
                     None if since == "None" else int(since)):
            pass
    except _Damaged as exc:
        print(exc)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
