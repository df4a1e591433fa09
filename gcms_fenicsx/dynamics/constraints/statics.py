"""The linear static response of a body held by a scene's joints: the check that a basis holds
what the joints and loads do to the body (attachment modes, docs/design.md §3.7), and the
static deformation a scene with ``[scene.initial] equilibrium = true`` starts from.

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

import math
from typing import Any, Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body, Coordinates
from gcms_fenicsx.dynamics.constraints.joints import Constraints, MassSolve, build_constraints
from gcms_fenicsx.dynamics.bodies.loads import ExternalForces, external_forces
from gcms_fenicsx.numerics.rotation import InvertedBodyError
from gcms_fenicsx.config.scene import Scene, SceneError

#: The rows C leave a rigid motion free when they move it by less than this fraction of the
#: largest singular value of C W (W: the body's six rigid velocities; round-off: the rows'
#: own singular values are of order one).
FREE_MOTION = 1e-8
#: Newton steps the static equilibrium of a start at rest may take (it gains a factor δ/L per
#: step: four for the test beam under gravity, δ/L = 1e-4).
EQUILIBRIUM_ITERATIONS = 20

#: (K, C, right-hand side [f; 0]) ↦ [u; λ]
KKTSolve = Callable[[Any, np.ndarray, np.ndarray], np.ndarray]


def dense_kkt_solve(K: Any, C: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """[u; λ] by one dense LU of the bordered matrix (K dense: a sparse full-order K needs
    ``references.full_order.sparse_kkt_solve``)."""
    if not isinstance(K, np.ndarray):
        raise TypeError(f"dense_kkt_solve needs a dense stiffness, not {type(K).__name__}: pass "
                        "kkt_solve=references.full_order.sparse_kkt_solve for a sparse body")
    m = C.shape[0]
    return np.linalg.solve(np.block([[np.asarray(K), C.T], [C, np.zeros((m, m))]]), rhs)


class HeldStatic(NamedTuple):
    """The displacement and the reactions of a held body."""

    displacement: np.ndarray    # u (n,)
    reactions: np.ndarray       # λ (m,), the rows' multipliers

    def group_displacement(self, body: Body, group: str) -> np.ndarray:
        """The displacement of a group's mean position (3,)."""
        return self.displacement.reshape(-1, 3).T @ body.groups[group].position


def free_rigid_motions(C: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """The rigid motions the rows C (m × n) leave free, as velocities (n × f, combinations of
    the six rigid velocities ``rigid``): the right singular vectors of C W whose singular
    values are below ``FREE_MOTION`` of the largest (all six without rows)."""
    if not len(C):
        return rigid
    _, s, Vt = np.linalg.svd(C @ rigid)
    held = int(np.sum(s > FREE_MOTION * s[0])) if s[0] > 0.0 else 0
    return rigid @ Vt[held:].T


def held_response(stiffness: Any, C: np.ndarray, load: np.ndarray,
                  kkt_solve: KKTSolve = dense_kkt_solve) -> HeldStatic:
    """u and λ of [K Cᵀ; C 0] [u; λ] = [f; 0] (module docstring)."""
    n = len(load)
    sol = kkt_solve(stiffness, C, np.concatenate([load, np.zeros(len(C))]))
    return HeldStatic(sol[:n], sol[n:])


def held_static(body: Body, scene: Scene, load: np.ndarray | None = None,
                mass_solve: MassSolve | None = None,
                kkt_solve: KKTSolve = dense_kkt_solve, time_s: float = 0.0) -> HeldStatic:
    """The static response of ``body`` held by ``scene``'s joints under ``load`` (n,), by
    default the scene's gravity and loads at ``time_s`` (module docstring). ``mass_solve``: as
    in ``joints.build_constraints`` (which rows are independent)."""
    c = build_constraints(body, scene.joints, body.q0, mass_solve)
    f = external_forces(body, scene.gravity, scene.loads)(time_s) if load is None else load
    return held_response(body.stiffness, c.jacobian(c.directions), f, kkt_solve)


def static_equilibrium(body: Coordinates, constraints: Constraints, forces: ExternalForces,
                       elastic: Callable[[np.ndarray], Any], q: np.ndarray, tolerance_m: float,
                       kkt_solve: KKTSolve = dense_kkt_solve) -> tuple[np.ndarray, int]:
    """(q_rest, Newton steps): the coordinates of the body at rest under f_ext(0), every joint
    row holding (a drive's too, so the body cannot turn), from the undeformed state q, in
    ``body``'s coordinates (either basis), for the run's own elastic law ``elastic`` (q ↦ its
    state: the integrator's).

    Newton with the stiffness at rest: u_{k+1} = u_k + ΔU, ΔU the held response (module
    docstring) to the residual f_ext(0) − ∂V/∂q(q + u_k). The first step is the linear
    statics; a co-rotated law differs from it at O(δ/L) (δ the deflection, L the body's size),
    so each further step gains that factor, until the increment (mass-weighted RMS, as the
    integrator's Newton measures it) is below ``tolerance_m``. SceneError when the rows leave
    a rigid motion free (an undriven pendulum, a free body: their equilibria, where the loads
    do no work on the free motion, are not what is solved here), or when Newton does not converge in ``EQUILIBRIUM_ITERATIONS`` or reaches a state
    without a rotation (loads so large that the body is far from linear)."""
    if not constraints.count:
        raise SceneError("[scene.initial] equilibrium = true: the body has no joints to rest "
                         "in, so it has no static equilibrium under gravity and loads")
    C = constraints.jacobian(constraints.directions_at(0.0))
    free = free_rigid_motions(C, body.rigid_velocities(q)).shape[1]
    if free:
        raise SceneError(f"[scene.initial] equilibrium = true: the joints leave {free} of the "
                         "body's six rigid motions free (an undriven revolute joint lets it "
                         "turn), and a start at rest is solved for a body they hold; drive or "
                         "fix the joint, or start without equilibrium")
    f, u = forces(0.0), np.zeros_like(q)
    increments = []
    for _ in range(EQUILIBRIUM_ITERATIONS):
        try:
            es = elastic(q + u)
        except InvertedBodyError as exc:
            raise _unsettled(increments, tolerance_m, f"reached a state that inverts the body "
                             f"({exc})") from exc
        residual = f - body.frame.to_global(es.local_gradient, es.rotation)
        du = held_response(body.stiffness, C, residual, kkt_solve).displacement
        u += du
        increments.append(math.sqrt(abs(du.dot(body.mass_product.dot(du))) / body.total_mass_kg))
        if increments[-1] <= tolerance_m:
            return q + u, len(increments)
    raise _unsettled(increments, tolerance_m,
                     f"did not converge in {EQUILIBRIUM_ITERATIONS} Newton steps")


def _unsettled(increments: list[float], tolerance_m: float, what: str) -> SceneError:
    """Why the static equilibrium was not found, with its Newton increments."""
    shown = ", ".join(f"{d:.2e}" for d in increments[-4:]) or "none"
    return SceneError(f"[scene.initial] equilibrium = true: Newton from the undeformed body "
                      f"{what} (last increments {shown} m, tolerance {tolerance_m:.1e} m): the "
                      "loads at t = 0 deform it too far for a start at rest; start without "
                      "equilibrium or with smaller loads")
