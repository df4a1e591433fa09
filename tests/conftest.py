"""Shared test set-up: the FFCx JIT cache inside the repository, and an mpirun helper.

``tests/dynamics`` (the standalone integrator on committed reduced models) is collected only
in a process where the finite-element stack cannot be imported: the one
``tests/test_standalone_dynamics.py`` starts, whose blocker (``tests/dynamics/no_fe_stack``)
sets GCMS_NO_FE_STACK.
"""
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
sys.path.insert(0, str(Path(__file__).parent))  # test helper modules (beams, simulate_runs, ...)

#: Set by tests/dynamics/no_fe_stack/sitecustomize.py: the modules it makes unimportable.
NO_FE_STACK = "GCMS_NO_FE_STACK"
collect_ignore = [] if os.environ.get(NO_FE_STACK) else ["dynamics"]
#: The test that runs tests/dynamics in a child pytest without the finite-element stack.
STANDALONE_DYNAMICS = ("tests/test_standalone_dynamics.py::"
                       "test_dynamics_tests_pass_without_the_finite_element_stack")


#: Compiles the step kernel into the shared cache while the test processes start
#: (``pytest_configure``): they wait for it (``kernel.compile_lock``) instead of each compiling
#: it at once (4 minutes of both cores on a machine whose LLVM is slow).
WARM_KERNEL = ("from gcms_fenicsx.dynamics import parse_scene, read_reduced, simulate; "
               "import sys; simulate(read_reduced(sys.argv[1]), parse_scene({'end_time': 2e-4, "
               "'time_step': 1e-4, 'solver': {'kernel': 'numba'}}))")


def pytest_configure(config) -> None:
    """In the session's first process (not an xdist worker, not the blocked child of
    tests/dynamics), compile the kernel in the background where Numba is there."""
    if hasattr(config, "workerinput") or os.environ.get(NO_FE_STACK):
        return
    try:
        import numba  # noqa: F401
    except ImportError:
        return
    config._warm_kernel = subprocess.Popen(
        [sys.executable, "-c", WARM_KERNEL, str(REPO / "tests" / "data" / "beam6.h5")],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO)


def pytest_unconfigure(config) -> None:
    warm = getattr(config, "_warm_kernel", None)
    if warm is not None and warm.poll() is None:
        warm.kill()
        warm.wait()


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
    """reduced.h5 of the six-mode test beam of ``beams``, reduced once per session."""
    from beams import beam_study
    folder = tmp_path_factory.mktemp("beam6")
    return gcms_reduce(beam_study(6), folder / "study.toml", folder) / "reduced.h5"


@pytest.fixture(scope="session", autouse=True)
def standalone_dynamics(request, tmp_path_factory):
    """The child pytest of ``tests/dynamics`` (``test_standalone_dynamics.ChildRun``), started
    with the session when that test is selected, so that it runs beside the other tests on
    the second core; None otherwise. Killed at the end of the session if still running."""
    if not any(item.nodeid == STANDALONE_DYNAMICS for item in request.session.items):
        yield None
        return
    from test_standalone_dynamics import start_dynamics_tests
    run = start_dynamics_tests(tmp_path_factory.mktemp("dynamics"))
    yield run
    run.stop()


def full_and_reduced(cfg, folder: Path):
    """(the free-free chain, the full-order body, the reduced body) of a parsed study: its
    mesh, modes and reduction through the pipeline's stages into ``folder``, and the full
    model on the same mesh with the same node groups (reference (a))."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references.full_order import full_order_body

    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes,
                               folder)
    model = chain.assembly.model
    full = full_order_body(model, group_weights(chain.body, model.Vs))
    reduced = body_from_reduced(pipeline.reduction_stage(
        pipeline.basis_stage(model, chain.modes, chain.body), cfg.selection))
    return chain, full, reduced
