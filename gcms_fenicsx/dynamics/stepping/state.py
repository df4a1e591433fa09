"""The integrator's state at a time, and what a converged step leaves for the recorder."""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.corotated import ElasticState

#: q ↦ an object with ``force`` (∂V/∂q), ``energy`` (V) and ``rotation`` (R of the frame):
#: co-rotated linear elasticity (``corotated.elastic_state``) or a reference's law.
Elastic = Callable[[np.ndarray], Any]


class State(NamedTuple):
    """The integrator's state at time t: q, q̇, q̈ and a (generalized-α) as the rows of one
    (4, n) array ``Z`` (the predictor is one product with it), and λ."""

    t: float
    Z: np.ndarray
    lam: np.ndarray

    @classmethod
    def of(cls, t: float, q: np.ndarray, v: np.ndarray, acc: np.ndarray, a: np.ndarray,
           lam: np.ndarray) -> State:
        return cls(t, np.array([q, v, acc, a]), lam)

    @property
    def q(self) -> np.ndarray:
        return self.Z[0]

    @property
    def v(self) -> np.ndarray:
        return self.Z[1]

    @property
    def acc(self) -> np.ndarray:
        return self.Z[2]

    @property
    def a(self) -> np.ndarray:
        return self.Z[3]


class StepInfo(NamedTuple):
    """What a converged step leaves for the recorder: the elastic state of its last residual,
    the damping's power, the constraint directions u(t) and matrix C(t), its Newton
    iterations and f_ext(t)."""

    elastic: ElasticState
    dissipation_w: float
    directions: np.ndarray
    iterations: int
    external_force: np.ndarray
    jacobian: np.ndarray | None = None
