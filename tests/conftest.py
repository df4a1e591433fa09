"""Shared test set-up: the FFCx JIT cache inside the repository, and an mpirun helper."""
from __future__ import annotations

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
