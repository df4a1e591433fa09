"""The integrator's state at a time, and what a converged step leaves for the recorder."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.corotated import ElasticState

#: q ↦ an object with ``force`` (∂V/∂q), ``energy`` (V) and ``rotation`` (R of the frame):
#: co-rotated linear elasticity (``corotated.elastic_state``) or a reference's law.
Elastic = Callable[[np.ndarray], Any]

@dataclass
class State:
    """The integrator's state at time t: q, q̇, q̈, a (generalized-α) and λ."""

    t: float
    q: np.ndarray
    v: np.ndarray
    acc: np.ndarray
    a: np.ndarray
    lam: np.ndarray


@dataclass(frozen=True)
class StepInfo:
    """What a converged step leaves for the recorder."""

    elastic: ElasticState
    dissipation_w: float
    directions: np.ndarray   # constraint directions u(t)
    iterations: int
    external_force: np.ndarray  # f_ext(t)
