"""Build the committed reduced models of ``tests/dynamics`` with the project's own ``gcms reduce``.

``tests/dynamics`` runs the standalone integrator in a process where the finite-element
stack cannot be imported, so its bodies cannot come from ``gcms reduce`` at test time: they
come from the files here, which this script makes::

    source scripts/env.sh
    python tests/data/make_reduced_models.py          # rewrites only what changed
    python tests/data/make_reduced_models.py --force  # rewrites every file

Each file is the ``reduced.h5`` that ``python -m gcms_fenicsx.cli reduce`` writes for its
study, with the same datasets (bit for bit), attributes and checksums; only the storage is
compacted: every dataset is one gzip-9 chunk (byte-shuffled where that is smaller) in the
HDF5 1.10 file format. gzip is in every HDF5 build and ``read_reduced`` reads it without
being told; the checksums are of the contents, so they hold. The script reads each file
back with ``read_reduced`` and compares it with the command's own before it replaces the
committed one.

| file | study | fields | coordinates | nodes | size |
|---|---|---|---|---|---|
| ``beam6.h5`` | ``beams.beam_study(6)`` | 22 | 66 | 2447 | 0.42 MB (0.58 MB as written) |
| ``beam6_svk.h5`` | ``beams.beam_svk_study(6)`` (with the SVK coefficients, schema 3) | 22 | 66 | 2447 | 0.66 MB (0.84 MB as written) |

The thirty-mode beam of the cantilever statics test (282 coordinates) is not committed: 3.2
MB as written, 2.3 MB compacted (Kr and the node fields are dense doubles and do not
compress), and fewer modes do not reach Timoshenko's deflection within the 5 % that test
asserts. That test stays in the main suite (``tests/test_cantilever_statics.py``) and
reduces its beam there.

Regenerate (and commit the result) when ``tests/test_standalone_dynamics.py`` says a file
is stale, i.e. when

- the schema of reduced.h5 changes (``files.reduced_model.SCHEMA_VERSION``, or the SVK
  coefficients' layout, ``files.svk_data``),
- the package version changes (the input hash includes it),
- the test beam changes (``tests/beams.py``), or
- ``gcms reduce`` writes a different model for the same study (meshing, eigen-solve, mode
  selection, preconditioning, node groups).

Identical datasets and input hash leave a file as it is (its attributes still hold the
timings of the run that wrote it), so rerunning the script does not churn the repository.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(HERE.parent))  # tests/: beams

from beams import beam_study, beam_svk_study  # noqa: E402
from gcms_fenicsx.files.reduced_model import read_reduced  # noqa: E402

#: Committed file name -> study text.
MODELS = {"beam6.h5": beam_study(6), "beam6_svk.h5": beam_svk_study(6)}


def reduce(study: str, folder: Path) -> Path:
    """reduced.h5 of ``study`` made by ``gcms reduce`` in ``folder``."""
    config = folder / "study.toml"
    config.write_text(study)
    run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "reduce", str(config),
                          "--out", str(folder / "out")], cwd=REPO, capture_output=True,
                         text=True)
    if run.returncode != 0:
        sys.exit(f"gcms reduce failed:\n{run.stderr}")
    return folder / "out" / "reduced.h5"


def compact_copy(source: Path, target: Path) -> None:
    """``source`` rewritten to ``target``: same groups, datasets and attributes, every
    dataset stored as one gzip-9 chunk (shuffled where that is smaller), in the HDF5 1.10
    file format (smaller object headers: beam6.h5 is 422 kB in it, 450 kB in the 1.8 one;
    the HDF5 of any h5py >= 3.7 reads it)."""
    with h5py.File(source, "r") as src, h5py.File(target, "w", libver="v110") as dst:
        def copy(name: str, obj) -> None:
            if isinstance(obj, h5py.Group):
                group = dst.require_group(name)
                group.attrs.update(obj.attrs)
                return
            data = obj[()]
            ds = dst.create_dataset(name, data=data, chunks=data.shape or None,
                                    compression="gzip", compression_opts=9,
                                    shuffle=shuffles(data))
            ds.attrs.update(obj.attrs)
        src.visititems(copy)
        dst.attrs.update(src.attrs)


def shuffles(data: np.ndarray) -> bool:
    """Whether byte shuffling makes ``data`` smaller under gzip (it does for smooth fields,
    not for matrices with many zeros or for repeated coordinates)."""
    raw = np.ascontiguousarray(data)
    shuffled = raw.view(np.uint8).reshape(-1, raw.dtype.itemsize).T
    return len(zlib.compress(shuffled.tobytes(), 9)) < len(zlib.compress(raw.tobytes(), 9))


def datasets(path: Path) -> dict[str, tuple[np.ndarray, dict]]:
    """Every dataset of the file at ``path`` with its attributes, by path."""
    found = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: found.__setitem__(name, (obj[()], dict(obj.attrs)))
                     if isinstance(obj, h5py.Dataset) else None)
    return found


def same_datasets(a: Path, b: Path) -> bool:
    """Whether the two files hold the same datasets, bit for bit, with the same attributes."""
    da, db = datasets(a), datasets(b)
    return da.keys() == db.keys() and all(
        da[k][0].dtype == db[k][0].dtype and np.array_equal(da[k][0], db[k][0])
        and da[k][1] == db[k][1] for k in da)


def same_root_attributes(a: Path, b: Path) -> bool:
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        return dict(fa.attrs) == dict(fb.attrs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true",
                        help="rewrite every file, also those whose datasets did not change")
    args = parser.parse_args()
    for name, study in MODELS.items():
        target = HERE / name
        compact = HERE / f".{name}.partial"  # beside the target: the rename is atomic
        with tempfile.TemporaryDirectory() as tmp:
            written = reduce(study, Path(tmp))
            size = written.stat().st_size
            try:
                compact_copy(written, compact)
                model = read_reduced(compact)  # schema, checksums and every value
                assert same_datasets(written, compact) and same_root_attributes(written, compact)
                unchanged = (not args.force and target.exists()
                             and same_datasets(written, target)
                             and read_reduced(target).input_hash == model.input_hash)
                if not unchanged:
                    compact.replace(target)
            finally:
                compact.unlink(missing_ok=True)
        state = "unchanged" if unchanged else "written"
        print(f"{target.relative_to(REPO)}: {state}, {model.dofs} coordinates, "
              f"{len(model.nodes_m)} nodes; {target.stat().st_size:,} bytes "
              f"(gcms reduce wrote {size:,})")

if __name__ == "__main__":
    main()
