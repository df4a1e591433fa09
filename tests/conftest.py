"""Shared test set-up: the FFCx JIT cache inside the repository, and an mpirun helper."""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# before anything imports dolfinx: compiled forms go to the repo's ignored .cache/
os.environ.setdefault("XDG_CACHE_HOME", str(REPO / ".cache"))
logging.disable(logging.INFO)  # the JIT's C build logs every compiler call at INFO
sys.path.insert(0, str(Path(__file__).parent))  # test helper modules (beam_theory, ...)


def mpirun(args: list[str], n: int = 2, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run ``python ARGS`` under ``mpirun -n N`` (as root too) and return the finished process."""
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    cmd = ["mpirun", "-n", str(n), sys.executable, *args]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, cwd=REPO)


@pytest.fixture
def run_mpi():
    return mpirun


def strict_json(path: Path):
    """The JSON document at ``path``, refusing NaN and ±Infinity (RFC 8259 has none)."""
    def refuse(name: str):
        raise ValueError(f"{path}: {name} is not JSON")
    return json.loads(path.read_text(), parse_constant=refuse)


def gcms(*args: str) -> subprocess.CompletedProcess:
    """``python -m gcms_fenicsx.cli ARGS`` from the repository root, finished."""
    return subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=600)


def gcms_reduce(text: str, config: Path, out: Path, ranks: int = 1) -> Path:
    """``gcms reduce`` of the study ``text`` (written to ``config``) into ``out``, on ``ranks``."""
    config.write_text(text)
    args = ["reduce", str(config), "--out", str(out)]
    run = gcms(*args) if ranks == 1 else mpirun(["-m", "gcms_fenicsx.cli", *args], n=ranks)
    assert run.returncode == 0, run.stderr
    return out


@pytest.fixture(scope="session")
def beam6_reduced(tmp_path_factory) -> Path:
    """reduced.h5 of the six-mode test beam of ``test_dynamics``, reduced once per session."""
    from test_dynamics import beam_study
    folder = tmp_path_factory.mktemp("beam6")
    return gcms_reduce(beam_study(6), folder / "study.toml", folder) / "reduced.h5"
