"""The process ``tests/dynamics`` runs in, and the commands its tests start, cannot import the
finite-element stack (``no_fe_stack/sitecustomize.py``), and the committed model they read
are current."""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
import tomllib

import pytest

from beams import BEAM6, BEAM6_SVK, beam_study, beam_svk_study
from gcms_fenicsx.config.study import parse_config
from gcms_fenicsx.files.reduced_model import read_reduced, schema_for
from simulate_runs import FE_STACK, REPO

#: What to do about a failure here.
RUN_BLOCKED = ("tests/dynamics must run where the finite-element stack cannot be imported: "
               "through tests/test_standalone_dynamics.py, or "
               "PYTHONPATH=tests/dynamics/no_fe_stack python -m pytest tests/dynamics")
REGENERATE = "stale: regenerate it with python tests/data/make_reduced_models.py"


def test_the_finite_element_stack_cannot_be_imported():
    """Every module of FE_STACK raises ImportError on import, none of them was imported before
    the blocker, and a Python process a test starts is blocked too."""
    assert os.environ.get("GCMS_NO_FE_STACK", "").split(",") == list(FE_STACK), RUN_BLOCKED
    with pytest.raises(ImportError, match="mpi4py is not installed here"):
        import mpi4py  # noqa: F401
    for name in FE_STACK:
        with pytest.raises(ImportError):
            importlib.import_module(name)
    assert [m for m in sys.modules if m.partition(".")[0] in FE_STACK] == []
    child = subprocess.run([sys.executable, "-c", "import scipy"], cwd=REPO,
                           capture_output=True, text=True, timeout=60)
    assert child.returncode == 1 and "scipy is not installed here" in child.stderr, child.stderr


@pytest.mark.parametrize("path, study", [(BEAM6, beam_study(6)),
                                         (BEAM6_SVK, beam_svk_study(6))])
def test_the_committed_beams_were_made_from_the_current_study_and_schema(path, study):
    """tests/data/beam6.h5 and beam6_svk.h5 are of the schema their contents are written with
    (2 without, 3 with the SVK coefficients) and their input hashes are those of their
    studies with this package version (what ``gcms reduce`` would record); the main suite
    also compares beam6.h5 with a fresh ``gcms reduce``."""
    model = read_reduced(path)
    config = parse_config(tomllib.loads(study))
    assert model.schema_version == schema_for(model), REGENERATE
    assert (model.svk is not None) == config.plan.body.svk, REGENERATE
    assert model.input_hash == config.plan.body.keys.reduced, REGENERATE

