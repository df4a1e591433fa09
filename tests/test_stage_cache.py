"""The stage cache of ``--out``: every stage reused while its inputs are unchanged and its
product intact, recomputed otherwise, nothing else run; ``--fresh``; a damaged, stale or
interrupted entry never used; one and two ranks give the same cache."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from beams import beam_study
from conftest import REPO, gcms, mpirun
from gcms_fenicsx.files.modes_file import read_modes
from gcms_fenicsx.files.reduced_model import read_reduced
from test_interrupts import SLOW, snapshot


def stages(out: Path, report: str = "selection.json") -> dict[str, str]:
    return {name: s["status"] for name, s in json.loads((out / report).read_text())["stages"].items()}


def stamps(out: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in out.iterdir() if p.is_file()}


@pytest.fixture
def cached(tmp_path):
    """A study of the test beam with 6 modes, reduced once into ``out``."""
    config, out = tmp_path / "study.toml", tmp_path / "out"
    config.write_text(beam_study(6))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out) == {"mesh": "computed", "modes": "computed", "reduction": "computed"}
    return config, out


@pytest.mark.slow
def test_each_change_reruns_only_the_stages_below_it(cached):
    """[selection] alone: no mesh, no solve, mesh.msh and modes.h5 untouched; fewer modes:
    the cached solve restricted, the same frequencies; more modes: solved again on the
    cached mesh; [material]: solved again, the mesh reused."""
    config, out = cached
    text = config.read_text()
    before = stamps(out)
    full = read_modes(out / "modes.h5").basis

    config.write_text(text.replace("[selection]", "[selection]\nsvd_tolerance = 1e-5"))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out) == {"mesh": "reused", "modes": "reused", "reduction": "computed"}
    assert "eigen-solve" not in run.stderr and "geometry and mesh" not in run.stderr
    after = stamps(out)
    assert after["mesh.msh"] == before["mesh.msh"] and after["modes.h5"] == before["modes.h5"]
    assert after["reduced.h5"] != before["reduced.h5"]

    config.write_text(text.replace("count = 6", "count = 4"))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out)["modes"] == "reused" and "4 of its 6 elastic modes" in run.stderr
    modes = json.loads((out / "modes.json").read_text())
    np.testing.assert_array_equal(modes["elastic_frequencies_hz"], full.elastic_frequencies_hz[:4])
    assert read_reduced(out / "reduced.h5").frequencies_hz.size == 4

    config.write_text(text.replace("count = 6", "count = 8"))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out) == {"mesh": "reused", "modes": "computed", "reduction": "computed"}
    assert "holds 6 elastic modes, 8 asked" in run.stderr
    more = read_modes(out / "modes.h5").basis
    np.testing.assert_allclose(more.elastic_frequencies_hz[:6], full.elastic_frequencies_hz,
                               rtol=1e-9)  # two solves, each to the Krylov tolerance 1e-10

    config.write_text(text.replace("[modes]", "[material]\nE = 105e9\n\n[modes]"))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out) == {"mesh": "reused", "modes": "computed", "reduction": "computed"}


@pytest.mark.slow
def test_fresh_recomputes_every_stage_with_the_same_result(cached):
    config, out = cached
    first = read_reduced(out / "reduced.h5")
    run = gcms("reduce", str(config), "--out", str(out), "--fresh")
    assert run.returncode == 0, run.stderr
    assert "--fresh" in run.stderr
    assert stages(out) == {"mesh": "computed", "modes": "computed", "reduction": "computed"}
    again = read_reduced(out / "reduced.h5")
    np.testing.assert_allclose(again.reduced_frequencies_hz, first.reduced_frequencies_hz,
                               rtol=1e-9)


def _flip_a_byte(path: Path, dataset: str) -> None:
    import h5py
    with h5py.File(path, "r") as f:
        offset = f[dataset].id.get_offset()
    with open(path, "r+b") as f:
        f.seek(offset + 8)
        byte = f.read(1)
        f.seek(offset + 8)
        f.write(bytes([byte[0] ^ 0x01]))


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["modes.h5 bit", "modes.h5 group renamed", "mesh.msh bit",
                                    "mesh.json edited", "other [mesh]"])
def test_a_damaged_or_stale_entry_is_never_used(cached, damage):
    """A flipped bit in modes.h5 (which can crash HDF5 itself) or in mesh.msh, a node group
    renamed inside modes.h5 (not covered by its own dataset checksums), an edited mesh.json,
    or a mesh from other [mesh] values: the entry is refused with the reason before it is
    parsed (cache.json holds every cached file's SHA-256), and recomputed."""
    config, out = cached
    if damage == "other [mesh]":
        config.write_text(config.read_text().replace("size = 0.012", "size = 0.013"))
    else:
        (out / "reduced.h5").unlink()  # else the intact reduced model spares the stages above
        if _damage(out, damage) != "modes.h5":
            (out / "modes.h5").unlink()
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    expected = {"modes.h5 bit": "modes.h5 does not match its checksum in cache.json",
                "modes.h5 group renamed": "modes.h5 does not match its checksum in cache.json",
                "mesh.msh bit": "mesh.msh does not match its checksum in cache.json",
                "mesh.json edited": "mesh.json does not match its checksum in cache.json",
                "other [mesh]": "was made from other [geometry] or [mesh] values"}[damage]
    assert expected in run.stderr, run.stderr
    computed = stages(out)
    assert computed["modes"] == "computed"
    assert computed["mesh"] == ("reused" if damage.startswith("modes.h5") else "computed")
    read_modes(out / "modes.h5")  # the new entry is intact
    manifest = json.loads((out / "cache.json").read_text())["files"]
    assert set(manifest) == {"mesh.msh", "mesh.json", "modes.h5", "reduced.h5"}


@pytest.mark.slow
def test_an_interrupted_solve_leaves_the_cache_valid(tmp_path):
    """SIGINT during the eigen-solve of ``gcms modes`` (its mesh reused): --out as it was, and
    the next command still reuses the cached mesh."""
    config, out = tmp_path / "slow.toml", tmp_path / "out"
    config.write_text(SLOW)
    assert gcms("mesh", str(config), "--out", str(out)).returncode == 0
    before = snapshot(out)
    child = subprocess.Popen([sys.executable, "-m", "gcms_fenicsx.cli", "modes", str(config),
                              "--out", str(out)], cwd=REPO, stderr=subprocess.PIPE, text=True)
    for line in child.stderr:
        if "eigen-solve:" in line:
            time.sleep(1.0)
            child.send_signal(signal.SIGINT)
            break
    child.communicate(timeout=120)
    assert child.returncode == 128 + signal.SIGINT
    assert snapshot(out) == before
    again = gcms("mesh", str(config), "--out", str(out))
    assert again.returncode == 0 and "mesh: reusing" in again.stderr, again.stderr
    assert snapshot(out) == before


#: A driven pin and a tip load: attachment modes of every kind (forces, moments whose levers
#: are blind to the turning, the drive's moment, the centrifugal load).
DRIVEN_PIN = """
[scene]
end_time = 0.01
time_step = 1e-3

[[scene.joints]]
type = "revolute"
group = "end_x0"
axis = [0.0, 1.0, 0.0]
drive = { angular_velocity = 10.0, ramp_time = 0.005 }

[[scene.loads]]
group = "end_xL"
force = [0.0, 0.0, -1.0]

[basis]
attachment = "scene"
"""


@pytest.mark.slow
@pytest.mark.mpi
def test_two_ranks_give_the_same_cache_as_one(tmp_path):
    """modes.h5 solved on two ranks holds the serial one's basis (rows in the mesh file's
    order, each mode and attachment mode up to its sign, to the solver's accuracy), and a
    serial command reuses it. The attachment modes (``fe.attachment``, ``fe.static_response``:
    group sums, levers and the preconditioned iteration across ranks) agree as the modes do."""
    config = tmp_path / "study.toml"
    config.write_text(beam_study(6) + DRIVEN_PIN)
    one, two = tmp_path / "one", tmp_path / "two"
    assert gcms("modes", str(config), "--out", str(one)).returncode == 0
    run = mpirun(["-m", "gcms_fenicsx.cli", "modes", str(config), "--out", str(two)])
    assert run.returncode == 0, run.stderr
    a, b = read_modes(one / "modes.h5"), read_modes(two / "modes.h5")
    assert a.key == b.key
    A, B = a.basis, b.basis
    # the same nodes in the same order; their coordinates evaluated per rank: 8e-16 m apart
    np.testing.assert_allclose(B.nodes_m, A.nodes_m, rtol=0, atol=1e-14)
    np.testing.assert_allclose(B.eigenvalues[6:], A.eigenvalues[6:], rtol=1e-9)
    for name, g in A.groups.items():
        np.testing.assert_array_equal(B.groups[name].nodes, g.nodes)
        np.testing.assert_allclose(B.groups[name].weights, g.weights, rtol=1e-12)
    # 3 forces at end_x0, 2 at end_xL (the tip load turns in the x-z plane ⊥ the pin), the
    # pin's two moments and the drive's, the spin
    assert len(A.attachment) == 9 and A.attachment == B.attachment
    shapes_a = A.fields[:, 4:].reshape(len(A.nodes_m), -1, 3)     # (node, mode, direction)
    shapes_b = B.fields[:, 4:].reshape(len(B.nodes_m), -1, 3)
    for j in range(shapes_a.shape[1]):
        sign = np.sign(np.sum(shapes_a[:, j] * shapes_b[:, j]))
        np.testing.assert_allclose(sign * shapes_b[:, j], shapes_a[:, j], rtol=0,
                                   atol=1e-6 * np.abs(shapes_a[:, j]).max())
    run = gcms("reduce", str(config), "--out", str(two))
    assert run.returncode == 0, run.stderr
    assert stages(two) == {"mesh": "reused", "modes": "reused", "reduction": "computed"}


@pytest.mark.slow
def test_auto_count_reports_its_band_and_reuses_a_larger_solve(tmp_path):
    """count = "auto" on the cantilever scene (no excitation: the band is what its 1 ms step
    resolves, 100 Hz, below the beam's first mode): one mode, the band in modes.json; the
    modes come from the cached solve of six."""
    from simulate_runs import SCENE

    config, out = tmp_path / "study.toml", tmp_path / "out"
    config.write_text(beam_study(6) + SCENE)
    assert gcms("reduce", str(config), "--out", str(out)).returncode == 0
    config.write_text(beam_study(6).replace("count = 6", 'count = "auto"') + SCENE)
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    modes = json.loads((out / "modes.json").read_text())
    assert modes["band"]["set_by"] == "time step"
    assert modes["band"]["max_frequency_hz"] == pytest.approx(100.0)
    assert modes["band"]["modes"] == modes["elastic_mode_count"] == 1
    assert modes["elastic_frequencies_hz"][0] > 100.0
    assert stages(out)["modes"] == "reused"


@pytest.mark.slow
def test_attachment_modes_are_fields_of_the_cached_basis(tmp_path):
    """[basis] attachment = "scene" on the cantilever (a fixed joint: 3 forces, 3 moments):
    modes.json lists them, their fields enter the selection, and switching attachment on
    solves again (the modes' key includes them) while a changed [selection] still reuses."""
    from simulate_runs import SCENE

    config, out = tmp_path / "study.toml", tmp_path / "out"
    config.write_text(beam_study(6) + SCENE)
    assert gcms("reduce", str(config), "--out", str(out)).returncode == 0
    config.write_text(beam_study(6) + SCENE.replace('"none"', '"scene"'))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out)["modes"] == "computed"
    modes = json.loads((out / "modes.json").read_text())
    assert len(modes["attachment_modes"]) == 6
    assert all(label.endswith("at end_x0") for label in modes["attachment_modes"])
    selection = json.loads((out / "selection.json").read_text())
    assert selection["fields_before"] == 4 + 3 * 6 + 3 * 6
    assert any(name.startswith("att") for name in selection["fields_kept"])
    assert read_modes(out / "modes.h5").basis.attachment == tuple(modes["attachment_modes"])
    config.write_text(config.read_text().replace("[selection]",
                                                 "[selection]\nsvd_tolerance = 1e-5"))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert stages(out)["modes"] == "reused"


def _move_a_node(path: Path) -> None:
    """The lowest bit of a byte halfway through mesh.msh's node block flipped: in the binary
    block three doubles per node dominate, so a coordinate moves by round-off — a change no
    reader of the file notices (it meshed and solved silently before)."""
    data = bytearray(path.read_bytes())
    start, end = data.index(b"$Nodes"), data.index(b"$EndNodes")
    data[(start + end) // 2] ^= 0x01
    path.write_bytes(bytes(data))


def _damage(out: Path, what: str) -> str:
    """Damage one cached file of ``out`` as ``what`` says; the file's name."""
    import h5py
    if what == "mesh.msh bit":
        with open(out / "mesh.msh", "r+b") as f:
            f.seek(2000)
            byte = f.read(1)
            f.seek(2000)
            f.write(bytes([byte[0] ^ 0x04]))
    elif what == "mesh.msh node moved":
        _move_a_node(out / "mesh.msh")
    elif what == "mesh.json edited":
        record = json.loads((out / "mesh.json").read_text())
        record["geometry"]["groups"]["end_xL"] = [2, 2]
        (out / "mesh.json").write_text(json.dumps(record))
    elif what == "modes.h5 bit":
        _flip_a_byte(out / "modes.h5", "stiffness")
    elif what == "modes.h5 group renamed":
        with h5py.File(out / "modes.h5", "r+") as f:
            f.move("groups/end_xL", "groups/end_xQ")
    elif what == "reduced.h5 bit":
        _flip_a_byte(out / "reduced.h5", "stiffness")
    return what.split()[0]


#: Each cached file damaged in turn, and the stage whose product it is.
DAMAGES = {"mesh.msh bit": "mesh", "mesh.msh node moved": "mesh", "mesh.json edited": "mesh",
           "modes.h5 bit": "modes", "modes.h5 group renamed": "modes",
           "reduced.h5 bit": "reduced"}


@pytest.fixture(scope="module")
def reduced_once(tmp_path_factory) -> tuple[Path, Path]:
    """The six-mode test beam reduced once for the module: (study, --out)."""
    folder = tmp_path_factory.mktemp("cache")
    config, out = folder / "study.toml", folder / "out"
    config.write_text(beam_study(6))
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    return config, out


@pytest.mark.slow
@pytest.mark.parametrize("manifest", ["damaged", "missing", "empty"])
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_without_the_manifest_every_cached_file_guards_itself(reduced_once, tmp_path,
                                                              manifest, damage):
    """cache.json damaged (not JSON), missing or listing nothing, and one cached file damaged
    in turn — a flipped byte or a moved node in mesh.msh, an edited mesh.json, a flipped byte
    or a renamed group in modes.h5, a flipped byte in reduced.h5: the plan does not reuse
    that stage's product, says so in one line naming the file, and reuses the intact
    products below it (mesh.json records mesh.msh's SHA-256 and its own; the HDF5 files
    carry their content and layout checksums). Before, a file the manifest did not list was
    trusted: a flipped byte in mesh.msh ended in a Gmsh traceback, a moved node was meshed
    and solved silently."""
    import shutil

    from gcms_fenicsx.app import stage_cache
    from gcms_fenicsx.config.study import load_config

    config, source = reduced_once
    out = tmp_path / "out"
    shutil.copytree(source, out)
    if manifest == "damaged":
        (out / "cache.json").write_text('{"files": {"mesh.msh": ')
    elif manifest == "missing":
        (out / "cache.json").unlink()
    else:
        (out / "cache.json").write_text('{"files": {}}')
    name = _damage(out, damage)
    stage = DAMAGES[damage]
    if stage != "reduced":            # an intact reduced model spares the stages above it
        (out / "reduced.h5").unlink()
    if stage == "mesh":
        (out / "modes.h5").unlink()
    lines: list[str] = []
    plan = stage_cache.reuse(load_config(config).plan.body, out, "reduced", False,
                             lines.append)
    refused = [line for line in lines if name in line]
    assert len(refused) == 1, lines
    assert "again" in refused[0] or "rebuilding" in refused[0], refused
    assert (manifest == "empty") != any("cache.json is" in line for line in lines), lines
    product = {"mesh": plan.mesh, "modes": plan.modes, "reduced": plan.reduced}
    assert product[stage] is None
    assert (plan.mesh is not None) == (stage == "modes"), lines


@pytest.mark.slow
def test_a_damaged_manifest_is_written_anew_and_protects_again(reduced_once, tmp_path):
    """The issue's sequence on the command line: cache.json damaged, ``gcms reduce`` reuses
    the reduced model, which verifies itself, and writes the manifest anew listing it (before:
    ``{"files": {}}``; the files it did not read are not listed on their own word); then a
    node moved in mesh.msh with a study that needs the mesh (more modes) is caught by
    mesh.json's record in one line, and the command meshes again, exit 0."""
    import shutil

    config, source = reduced_once
    out = tmp_path / "out"
    shutil.copytree(source, out)
    (out / "cache.json").write_text("{damaged")
    run = gcms("reduce", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "cache.json is damaged" in run.stderr and "reusing" in run.stderr, run.stderr
    assert set(json.loads((out / "cache.json").read_text())["files"]) == {"reduced.h5"}
    _move_a_node(out / "mesh.msh")
    more = tmp_path / "more.toml"
    more.write_text(beam_study(8))
    run = gcms("reduce", str(more), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "mesh.msh does not match its checksum" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr
    assert stages(out)["mesh"] == "computed"


def test_the_manifest_lists_only_what_was_checked(reduced_once, tmp_path):
    """cache.json lost, mesh.json of an earlier version (no checksums) and a damaged mesh.msh
    beside an intact reduced.h5: the command reuses reduced.h5 and writes the manifest anew
    with reduced.h5 only — mesh.msh, which nothing read, is not listed on its own word (it
    was hashed into the manifest before, and then trusted by the next command)."""
    import shutil

    from gcms_fenicsx.app import stage_cache
    from gcms_fenicsx.config.study import load_config

    config, source = reduced_once
    out = tmp_path / "out"
    shutil.copytree(source, out)
    (out / "cache.json").unlink()
    record = json.loads((out / "mesh.json").read_text())
    for key in ("mesh_sha256", "document_sha256"):
        record.pop(key)
    (out / "mesh.json").write_text(json.dumps(record))
    _damage(out, "mesh.msh bit")
    reuse = stage_cache.reuse(load_config(config).plan.body, out, "reduced", False,
                              lambda line: None)
    assert reuse.reduced is not None and reuse.mesh is None
    folder = tmp_path / "staged"
    folder.mkdir()
    stage_cache.write_manifest(out, folder, (), reuse)
    assert set(json.loads((folder / "cache.json").read_text())["files"]) == {"reduced.h5"}
