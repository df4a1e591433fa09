"""The standalone package tested standalone: ``tests/dynamics`` runs in a child pytest where
dolfinx, ufl, basix, ffcx, petsc4py, slepc4py, mpi4py, gmsh and scipy cannot be imported (the
blocker ``tests/dynamics/no_fe_stack/sitecustomize.py``, on PYTHONPATH, is installed at
interpreter start-up, before pytest collects anything), and the committed model its tests
read is the one ``gcms reduce`` makes today.

The child starts with the session (``conftest.standalone_dynamics``), so it runs on the
second core while the other tests run, and the test below waits for it: the suite takes no
longer than when these tests ran in the main process.
"""
from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

from beams import BEAM6
from conftest import NO_FE_STACK, REPO
from gcms_fenicsx.files.reduced_model import read_reduced, schema_for

DYNAMICS = REPO / "tests" / "dynamics"
BLOCKER = DYNAMICS / "no_fe_stack"
#: The test inside that asserts the blocker was active.
BLOCKER_TEST = ("tests.dynamics.test_no_fe_stack",
                "test_the_finite_element_stack_cannot_be_imported")
REGENERATE = "stale: regenerate it with python tests/data/make_reduced_models.py"
TIMEOUT_S = 900


@dataclass
class ChildRun:
    """``python -m pytest tests/dynamics`` with the blocker, running in ``folder``: its output
    (stdout and stderr) in ``output.txt``, its JUnit report in ``report.xml``."""

    process: subprocess.Popen
    folder: Path

    def wait(self) -> tuple[int, str]:
        """The exit status and the output, once the child has finished."""
        status = self.process.wait(timeout=TIMEOUT_S)
        return status, (self.folder / "output.txt").read_text()

    def stop(self) -> None:
        """Kill the child if it still runs (the session ended or was interrupted first)."""
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


def start_dynamics_tests(folder: Path) -> ChildRun:
    """Start the child pytest of ``tests/dynamics`` with the blocker first on PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if k != NO_FE_STACK}
    env["PYTHONPATH"] = os.pathsep.join([str(BLOCKER),
                                         *filter(None, [os.environ.get("PYTHONPATH")])])
    with open(folder / "output.txt", "w") as output:
        process = subprocess.Popen(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
             f"--basetemp={folder / 'basetemp'}", f"--junitxml={folder / 'report.xml'}",
             str(DYNAMICS)],
            cwd=REPO, env=env, stdout=output, stderr=subprocess.STDOUT)
    return ChildRun(process, folder)


def test_dynamics_tests_pass_without_the_finite_element_stack(standalone_dynamics, tmp_path):
    """``python -m pytest tests/dynamics`` with the blocker passes: no failure, error or skip,
    every module of the folder ran tests, and the one asserting that ``import mpi4py`` (and
    every other blocked module) raises ImportError — there and in a child process — passed."""
    run = standalone_dynamics or start_dynamics_tests(tmp_path)  # started with the session
    try:
        status, output = run.wait()
    finally:
        run.stop()
    assert status == 0, output[-10000:]
    report = run.folder / "report.xml"
    suite = ElementTree.parse(report).getroot().find("testsuite")
    assert [int(suite.get(k)) for k in ("failures", "errors", "skipped")] == [0, 0, 0]
    cases = {(c.get("classname"), c.get("name")): c for c in suite.iter("testcase")}
    assert len(cases) == int(suite.get("tests")) > 40
    modules = {f"tests.dynamics.{p.stem}" for p in DYNAMICS.glob("test_*.py")}
    assert {module for module, _ in cases} == modules
    assert BLOCKER_TEST in cases
    assert not [e.tag for e in cases[BLOCKER_TEST] if e.tag in ("failure", "error", "skipped")]


def test_the_committed_beam_is_the_one_gcms_reduce_makes(beam6_reduced):
    """tests/data/beam6.h5 against the session's fresh ``gcms reduce`` of the same study: same
    schema, input hash, fields, mesh and node groups; the full and reduced frequencies and the
    spectrum of Mr to 1e-9 (quantities neither a mode's sign nor a machine's round-off
    changes). A difference means the reduction changed under the committed file."""
    committed, fresh = read_reduced(BEAM6), read_reduced(beam6_reduced)
    assert committed.schema_version == fresh.schema_version == schema_for(fresh), REGENERATE
    assert committed.input_hash == fresh.input_hash, REGENERATE
    assert committed.field_names == fresh.field_names, REGENERATE
    assert committed.selection["fields_kept"] == fresh.selection["fields_kept"], REGENERATE
    assert committed.mesh == pytest.approx(fresh.mesh, rel=1e-9), REGENERATE
    assert committed.groups.keys() == fresh.groups.keys(), REGENERATE
    for name, group in committed.groups.items():
        assert np.array_equal(group.nodes, fresh.groups[name].nodes), (name, REGENERATE)
        np.testing.assert_allclose(group.weights, fresh.groups[name].weights, rtol=1e-9,
                                   err_msg=REGENERATE)
    np.testing.assert_allclose(committed.nodes_m, fresh.nodes_m, rtol=0, atol=1e-12,
                               err_msg=REGENERATE)
    for name in ("frequencies_hz", "reduced_frequencies_hz"):
        np.testing.assert_allclose(getattr(committed, name), getattr(fresh, name), rtol=1e-9,
                                   err_msg=f"{name}: {REGENERATE}")
    mass = [np.linalg.eigvalsh(m.mass) for m in (committed, fresh)]
    np.testing.assert_allclose(*mass, rtol=0, atol=1e-9 * mass[1].max(), err_msg=REGENERATE)
