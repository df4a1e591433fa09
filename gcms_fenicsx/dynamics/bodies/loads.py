"""External forces on the body: gravity and forces on node groups, all dead loads.

A force F on a group acts on its weighted mean position x_G = Qᵀ h, so its generalized
force is (∂x_G/∂q)ᵀ F = kron(h, F) — the same as spreading F over the group's nodes with
their weights. Gravity is Φᵀ M (1 ⊗ g) = ``body.gravity @ g`` (docs/design.md §5), with potential
−q · (body.gravity @ g). Neither depends on q or q̇, so the Newton tangent has no load term:

    f_ext(t) = f_g + Σ_j s_j(t) b_j,    b_j = kron(h_j, F_j).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.config.scene import Load


@dataclass(frozen=True)
class ExternalForces:
    gravity_force: np.ndarray   # f_g (n,)
    load_vectors: np.ndarray    # b_j as columns (n, loads)
    loads: tuple[Load, ...]

    def __call__(self, t: float) -> np.ndarray:
        """f_ext(t)."""
        if not self.loads:
            return self.gravity_force
        factors = np.array([load.factor(t) for load in self.loads])
        return self.gravity_force + self.load_vectors @ factors

    def gravity_potential(self, q: np.ndarray) -> np.ndarray:
        """V_g = −q · f_g (zero at q = 0), for q or for rows of them (k, n)."""
        return -q.dot(self.gravity_force)


def external_forces(body: Body, gravity: tuple[float, float, float],
                    loads: tuple[Load, ...]) -> ExternalForces:
    vectors = np.column_stack([np.kron(body.groups[load.group].position, load.force_n)
                               for load in loads]) if loads else np.zeros((body.dofs, 0))
    return ExternalForces(gravity_force=body.gravity @ np.asarray(gravity, float),
                          load_vectors=vectors, loads=loads)
