"""The linear static response of a body held by a scene's joints: the check that a basis holds
what the joints and loads do to the body (attachment modes, docs/design.md §3.7).

At the undeformed state, with every joint row (drive rows included, so the body cannot
turn) and the load f,

    [K  Cᵀ] [u]   [f]
    [C  0 ] [λ] = [0],

u the displacement in the body's coordinates and λ the reactions of the rows (in the rows'
order, ``joints.Constraints.rows``). A reduced body gives the Galerkin approximation of the
full model's u; when the full model's u lies in its span (the reactions and loads are
combinations of its attachment loads), the two agree to round-off. The solve goes through a
``kkt_solve`` callable: dense here (NumPy), sparse for the full model
(``references.full_order.full_held_static``).
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.joints import MassSolve, build_constraints
from gcms_fenicsx.dynamics.loads import external_forces
from gcms_fenicsx.dynamics.scene import Scene

#: (K, C, right-hand side [f; 0]) ↦ [u; λ]
KKTSolve = Callable[[Any, np.ndarray, np.ndarray], np.ndarray]


def dense_kkt_solve(K: Any, C: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """[u; λ] by one dense LU of the bordered matrix."""
    m = C.shape[0]
    return np.linalg.solve(np.block([[np.asarray(K), C.T], [C, np.zeros((m, m))]]), rhs)


class HeldStatic(NamedTuple):
    """The displacement and the reactions of a held body."""

    displacement: np.ndarray    # u (n,)
    reactions: np.ndarray       # λ (m,), the rows' multipliers

    def group_displacement(self, body: Body, group: str) -> np.ndarray:
        """The displacement of a group's mean position (3,)."""
        return self.displacement.reshape(-1, 3).T @ body.groups[group].position


def held_static(body: Body, scene: Scene, load: np.ndarray | None = None,
                mass_solve: MassSolve | None = None,
                kkt_solve: KKTSolve = dense_kkt_solve) -> HeldStatic:
    """The static response of ``body`` held by ``scene``'s joints under ``load`` (n,), by
    default the scene's gravity and loads at t = 0 (module docstring). ``mass_solve``: as in
    ``joints.build_constraints`` (which rows are independent)."""
    c = build_constraints(body, scene.joints, body.q0, mass_solve)
    f = external_forces(body, scene.gravity, scene.loads)(0.0) if load is None else load
    sol = kkt_solve(body.stiffness, c.jacobian(c.directions),
                    np.concatenate([f, np.zeros(c.count)]))
    return HeldStatic(sol[:body.dofs], sol[body.dofs:])
