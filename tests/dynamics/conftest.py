"""``tests/dynamics``: the standalone integrator on committed reduced models, in a process where
the finite-element stack cannot be imported.

``tests/test_standalone_dynamics.py`` runs this folder in such a process (the blocker in
``no_fe_stack/``; by hand: ``PYTHONPATH=tests/dynamics/no_fe_stack python -m pytest
tests/dynamics``). The bodies come from ``tests/data/*.h5`` through ``read_reduced``, as a
user's exported model would; ``tests/data/make_reduced_models.py`` makes them with
``gcms reduce``.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from beams import BEAM6
from gcms_fenicsx.dynamics.bodies.body import Body, body_from_reduced
from gcms_fenicsx.files.reduced_model import ReducedModel, read_reduced


@pytest.fixture(scope="session")
def beam6_file() -> Path:
    """The committed reduced.h5 of the six-mode test beam: tests only read or copy it."""
    return BEAM6


@pytest.fixture(scope="session")
def beam6_model(beam6_file) -> ReducedModel:
    """The six-mode test beam as ``read_reduced`` gives it (66 coordinates)."""
    return read_reduced(beam6_file)


@pytest.fixture(scope="session")
def beam6_body(beam6_model) -> Body:
    """The integrator's body of :func:`beam6_model`."""
    return body_from_reduced(beam6_model)
