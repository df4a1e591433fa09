"""Issue 27, item 4: the small ones. One test each, every one failing on the code before it.

- a feature exactly at the mesh-size limit is accepted (not refused by round-off), and a
  refusal suggests a mesh size that is then accepted;
- a crankshaft stroke too small for the (default) pin is blamed on ``stroke``, the key set;
- a mesh size the user never set is called derived, and from what, when it is blamed;
- a body at rest has a small relative energy drift (the scale has a floor), and the
  absolute drift is reported;
- an ``end_time`` whose steps would run for days is refused in one line before stepping;
- a large field selection says what it will cost before it starts;
- a read-only ``--out`` is reported as a read-only file system;
- damaged results files leave no HDF5 handle open, however many are read.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from gcms_fenicsx.config.table import ConfigError
from geometry.features import MIN_FEATURE_PER_SIZE

I_BEAM = {"kind": "beam", "section": "I", "length": 1.0, "width": 0.05, "height": 0.05,
          "web_thickness": 0.003}


def refusal(raw_geometry: dict, raw_mesh: dict | None = None) -> ConfigError:
    """The one-line ConfigError that parsing ``[geometry]`` and ``[mesh]`` raises."""
    with pytest.raises(ConfigError) as caught:
        parse_mesh(raw_mesh, parse_geometry(raw_geometry))
    assert "\n" not in str(caught.value)
    return caught.value


def test_a_feature_at_the_mesh_size_limit_is_accepted_and_a_refusal_suggests_a_size_that_is():
    """Order 2 needs features >= 0.2 h: a flange of 0.0025 m at h = 0.0125 m is exactly at the
    limit (0.2 · 0.0125 = 0.0025000000000000005 in binary) and must mesh; a flange 1 % thinner
    is refused, and the [mesh] size its message suggests is then accepted and below h."""
    size = 0.0125
    flange = MIN_FEATURE_PER_SIZE[2] * size
    assert flange == pytest.approx(0.0025, rel=1e-15)
    geom = parse_geometry(dict(I_BEAM, flange_thickness=0.0025))
    assert parse_mesh({"size": size}, geom).size == size
    thin = dict(I_BEAM, flange_thickness=0.99 * 0.0025)
    error = refusal(thin, {"size": size})
    assert error.key == "[geometry] flange_thickness"
    suggested = float(re.search(r"\[mesh\] size \(<= ([0-9.e+-]+) m\)", error.allowed).group(1))
    assert suggested < size
    assert parse_mesh({"size": suggested}, parse_geometry(thin)).size == suggested


def test_a_stroke_too_small_for_the_default_pin_is_blamed_on_stroke():
    """Only ``stroke`` is set (1e-9 m), the default pin (0.048 m) no longer fits the throw:
    the message names stroke, its value and the default pin_diameter it must exceed; with
    both set, the pin is blamed as before."""
    error = refusal({"kind": "crankshaft", "stroke": 1e-9})
    assert error.key == "[geometry] stroke" and error.value == 1e-9
    assert "pin_diameter" in error.allowed and "0.048" in error.allowed
    both = refusal({"kind": "crankshaft", "stroke": 0.04, "pin_diameter": 0.05})
    assert both.key == "[geometry] pin_diameter" and both.value == 0.05


def test_a_derived_mesh_size_is_called_derived_when_it_is_blamed():
    """A tube of 1.2 µm wall, 0.1 m long, without [mesh] size: the default size (2A/P ≈ the
    wall) would give ~1e10 cells, refused before meshing. The refusal names [mesh] size and
    says it was not set but derived, and from what; a size the user set is shown as given."""
    from gcms_fenicsx.fe.memory import check_meshing
    from geometry.estimate import estimate_mesh

    geom = parse_geometry({"kind": "beam", "section": "tube", "radius": 0.01,
                           "thickness": 1.2e-6, "length": 0.1})
    for raw, derived in ((None, True), ({"size": 1.2e-6}, False)):
        mesh = parse_mesh(raw, geom)
        with pytest.raises(ConfigError) as caught:
            check_meshing(estimate_mesh(geom, mesh).cells, mesh.size, available=2.0**30)
        text = str(caught.value)
        assert text.startswith("[mesh] size = ") and "\n" not in text
        assert ("not set" in text and "derived" in text and "2·area/perimeter" in text) == \
            derived, text


@pytest.fixture
def read_only_folder(tmp_path):
    """A folder holding ``out/`` on a tmpfs remounted read-only (needs root: skipped
    otherwise); unmounted afterwards."""
    mount = tmp_path / "ro"
    mount.mkdir()
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if made.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.strip()}")
    try:
        (mount / "out").mkdir()
        subprocess.run(["mount", "-o", "remount,ro", str(mount)], check=True)
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=True)


def test_a_read_only_out_is_reported_as_a_read_only_file_system(read_only_folder):
    """``--out`` on a read-only file system, existing or to be created there: one ConfigError
    naming --out and the read-only file system, not "Permission denied"."""
    from gcms_fenicsx.files.outputs import staged_output

    for out in (read_only_folder / "out", read_only_folder / "new"):
        with pytest.raises(ConfigError) as caught:
            with staged_output(out):
                pass
        assert caught.value.key == "--out" and caught.value.value == str(out)
        assert "read-only file system" in caught.value.allowed.lower(), caught.value
        assert "Permission denied" not in caught.value.allowed


def test_a_large_selection_announces_its_estimate_and_reports_its_pivots(monkeypatch):
    """The selection says how many fields it works on and its estimated time before it
    starts (1700 modes: 5104 fields, ~2 min, and it used to run silently), then one line per
    PROGRESS_INTERVAL_S while it pivots: with the interval at 0, a line per pivot. On 64
    fields of rank 30 (random, so no two are proportional): 30 pivots, 34 dropped fields."""
    import numpy as np

    from gcms_fenicsx.config.selection import SelectionConfig
    from gcms_fenicsx.reduction import selection

    rng = np.random.default_rng(27)
    fields = rng.standard_normal((30, 64))
    fields[:, 0] = 1.0
    gram = fields.T @ fields
    names = tuple(f"f{i}" for i in range(64))
    lines: list[str] = []
    monkeypatch.setattr(selection, "PROGRESS_INTERVAL_S", 0.0)
    chosen = selection.select_fields(gram, SelectionConfig(), names, progress=lines.append)
    assert len(chosen.kept) == 30 and len(chosen.dropped) == 34
    assert lines[0] == ("selection: 64 fields, estimated under a second (the eigenvalues "
                        "of their 64 × 64 Gram matrix and up to 64 pivots)")
    pivots = [line for line in lines[1:] if line.startswith("selection: pivot ")]
    assert len(pivots) == 30 and pivots[-1].startswith("selection: pivot 30 of at most 30")
    assert selection.estimate_text(selection.estimated_seconds(4 + 3 * 1700)).endswith("min")


#: Writes a results file of the test beam, damages copies of it and reads each in one
#: process: the string heap's first object claiming a terabyte (HDF5 itself crashes on
#: it), a dataset whose extent is 1e10 rows in a file of kilobytes (its checksum would read
#: 80 GB), then RANDOM_DAMAGES random truncations and bit flips. Prints one word per file
#: and the HDF5 objects left open.
DAMAGE_SCRIPT = r"""
import random, struct, sys
from pathlib import Path
import h5py
from beams import BEAM6
from gcms_fenicsx.config.scene import parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_to_file
from gcms_fenicsx.files.reduced_model import read_reduced
from gcms_fenicsx.files.results import ResultsError, read_results
from gcms_fenicsx.files.versioned import ATTRIBUTES_CHECKSUM, attributes_digest

folder = Path(sys.argv[1])
good = folder / "results.h5"
simulate_to_file(read_reduced(BEAM6), parse_scene({
    "end_time": 0.01, "time_step": 1e-3, "joints": [{"type": "fixed", "group": "end_x0"}],
    "outputs": {"groups": ["end_xL"]}}), good)
damaged = []
data = bytearray(good.read_bytes())
heap = data.find(b"GCOL") + 16                   # the global heap's first object
struct.pack_into("<Q", data, heap + 8, 2 ** 40)  # its size
damaged.append(bytes(data))
with h5py.File(folder / "extent.h5", "w") as f:
    f.attrs["schema_version"] = 2
    f.create_dataset("time", shape=(10 ** 10,), chunks=(64,), dtype="<f8")
    f.attrs[ATTRIBUTES_CHECKSUM] = attributes_digest(f.attrs)
damaged.append((folder / "extent.h5").read_bytes())
rng = random.Random(27)
for k in range(int(sys.argv[2])):
    data = bytearray(good.read_bytes())
    if k % 3 == 0:
        data = data[:rng.randrange(len(data))]
    for _ in range(rng.randrange(1, 20) if k % 3 else 0):
        i = rng.randrange(len(data))
        data[i] ^= 1 << rng.randrange(8)
    damaged.append(bytes(data))
baseline = h5py.h5f.get_obj_count(h5py.h5f.OBJ_ALL, h5py.h5f.OBJ_ALL)
for k, data in enumerate(damaged):
    path = folder / f"damaged{k}.h5"
    path.write_bytes(data)
    try:
        read_results(path)
        print("read", flush=True)
    except ResultsError as exc:
        print("refused" if "\n" not in str(exc) else "multi-line", flush=True)
print("open", h5py.h5f.get_obj_count(h5py.h5f.OBJ_ALL, h5py.h5f.OBJ_ALL) - baseline)
"""
RANDOM_DAMAGES = 12


def test_damaged_results_files_are_refused_one_by_one_and_never_crash_the_reader(tmp_path):
    """Many damaged results files read in one process: each is read or refused with one
    ResultsError line, the process survives (HDF5 crashed on the string heap's damage:
    SIGSEGV) and finishes (the huge extent is refused before it is read), and no HDF5
    object is left open."""
    tests = str(Path(__file__).resolve().parent)
    path = os.pathsep.join(filter(None, (tests, os.environ.get("PYTHONPATH"))))
    run = subprocess.run([sys.executable, "-c", DAMAGE_SCRIPT, str(tmp_path),
                          str(RANDOM_DAMAGES)], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": path})
    assert run.returncode == 0, (run.returncode, run.stderr[-2000:])
    words = run.stdout.split()
    assert words[:2] == ["refused", "refused"], run.stdout
    assert len(words) == 2 + RANDOM_DAMAGES + 2 and words[-2:] == ["open", "0"], run.stdout
    assert set(words[2:-2]) <= {"read", "refused"}, run.stdout
