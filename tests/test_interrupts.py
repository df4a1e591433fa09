"""SIGINT and SIGTERM at any stage, failed commands and unusable --out: ``--out`` is left exactly
as it was (or absent), with one line and exit status 2, 1 or 128 + signal."""
from __future__ import annotations

import hashlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import REPO, gcms

#: A 10 m × 10 mm beam: meshing takes seconds (the child process) and so does the solve.
SLOW = """
[geometry]
kind = "beam"
section = "square"
side = 0.01
length = 10.0

[mesh]
size = 0.006

[modes]
count = 6
"""

SMALL = """
[geometry]
kind = "beam"
section = "square"
side = 0.02
length = 0.3

[mesh]
size = 0.01

[modes]
count = 2
"""


def snapshot(folder: Path) -> dict[str, str]:
    """Every file below ``folder`` (hidden ones too) and the SHA-256 of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def earlier_run(folder: Path) -> dict[str, str]:
    """An output folder as an earlier run left it; its snapshot."""
    folder.mkdir()
    (folder / "mesh.json").write_text('{"nodes": 1}\n')
    (folder / "notes.txt").write_text("mine\n")
    return snapshot(folder)


def leftovers(parent: Path) -> list[str]:
    return [p.name for p in parent.iterdir() if p.name.startswith((".gcms-staging", ".meshing"))]


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("stage", ["geometry and mesh:", "eigen-solve:"])
def test_signal_at_a_stage_leaves_out_as_it_was(tmp_path, signum, stage):
    config = tmp_path / "slow.toml"
    config.write_text(SLOW)
    out = tmp_path / "out"
    before = earlier_run(out)
    child = subprocess.Popen([sys.executable, "-m", "gcms_fenicsx.cli", "modes", str(config),
                              "--out", str(out)], cwd=REPO, stderr=subprocess.PIPE, text=True)
    lines = []
    for line in child.stderr:
        lines.append(line)
        if stage in line:
            time.sleep(1.0)  # inside the stage: meshing takes 4 s, the solve 10 s
            child.send_signal(signum)
            break
    rest = child.communicate(timeout=120)[1]
    assert child.returncode == 128 + signum, "".join(lines) + rest
    assert rest.strip().splitlines()[-1] == (
        f"gcms modes: interrupted ({signum.name}); {out} is as it was")
    assert snapshot(out) == before
    assert leftovers(tmp_path) == []
    if stage.startswith("geometry"):  # the mesher child is gone too
        time.sleep(0.5)
        ps = subprocess.run(["pgrep", "-f", f"geometry build.*{tmp_path}"], capture_output=True)
        assert ps.returncode == 1, ps.stdout


@pytest.mark.slow
def test_failed_command_creates_no_out(tmp_path):
    """An eigen-solve that cannot converge fails after the staging folder exists: neither --out
    nor its missing parents appear."""
    config = tmp_path / "study.toml"
    config.write_text(SMALL.replace("count = 2", "count = 30\nmax_iterations = 1\n"
                                                 "tolerance = 1e-15"))
    out = tmp_path / "new" / "out"
    run = gcms("modes", str(config), "--out", str(out))
    assert run.returncode == 1 and "failed" in run.stderr, run.stderr
    assert not (tmp_path / "new").exists()
    assert leftovers(tmp_path) == []


@pytest.mark.slow
def test_stale_staging_folders_are_removed_by_the_next_run(tmp_path):
    """Folders of a killed run (a dead process of this host, or an older version's staging
    inside --out) are removed; a live process's staging folder is not touched."""
    config = tmp_path / "study.toml"
    config.write_text(SMALL)
    out = tmp_path / "out"
    out.mkdir()
    dead = _dead_pid()
    host = socket.gethostname()
    stale = tmp_path / f".gcms-staging-{host}-{dead}-abc123"
    live = tmp_path / f".gcms-staging-{host}-{os.getpid()}-def456"
    legacy = out / ".staging-xyz"
    for folder in (stale, live, legacy):
        folder.mkdir()
        (folder / "mesh.msh").write_text("half")
    run = gcms("mesh", str(config), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert not stale.exists() and not legacy.exists() and live.exists()


def _dead_pid() -> int:
    """The pid of a process that has ended."""
    child = subprocess.Popen(["true"])
    child.wait()
    return child.pid


@pytest.mark.parametrize("make, message", [
    (lambda tmp: (tmp / "file").write_text("x") and tmp / "file", "is an existing file"),
    (lambda tmp: (tmp / "file").write_text("x") and tmp / "file" / "sub",
     "lies below .*file, which is a file"),
])
def test_out_that_cannot_be_a_folder_is_one_line(tmp_path, make, message):
    config = tmp_path / "study.toml"
    config.write_text(SMALL)
    out = make(tmp_path)
    run = gcms("mesh", str(config), "--out", str(out))
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1, run.stderr
    assert "--out" in run.stderr and __import__("re").search(message, run.stderr), run.stderr


def test_read_only_out_is_one_line():
    """A folder this user cannot write to (as root: run the command as nobody, in a folder
    nobody can read: pytest's own temporary folders are private)."""
    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        base = Path(tmp)
        base.chmod(0o755)
        config = base / "study.toml"
        config.write_text(SMALL)
        out = base / "out"
        before = earlier_run(out)
        out.chmod(0o555)
        user = "nobody" if os.geteuid() == 0 else None
        run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "mesh", str(config),
                              "--out", str(out)], cwd=REPO, capture_output=True, text=True,
                             user=user, timeout=300)
        assert run.returncode == 2, run.stderr
        assert run.stderr.count("\n") == 1, run.stderr
        assert "cannot be written: Permission denied" in run.stderr, run.stderr
        assert snapshot(out) == before
        assert leftovers(base) == []
