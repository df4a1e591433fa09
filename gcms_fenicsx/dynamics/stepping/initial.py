"""The initial state of a scene: q0 plus, on request, one elastic mode shape with a defined
orientation (``[scene.initial]``; the rule below), the velocity the
joints allow, and q̈ and λ consistent with them (:func:`consistent_state`).

An eigenvector of (Kr, Mr) is defined up to its sign, and within a repeated eigenvalue up to
a rotation of the cluster's basis: the eigen-solver of two near-identical bodies returns
different bases of a square beam's bending pair, so "mode 1" would start the one bending
along y and the other at 150° from it. Here the shape is made a function of the cluster's
subspace and of the requested direction only (without one, of the global axis the cluster
reaches farthest along), and :class:`ModeStart` says which rule chose it, along what, and
whether the cluster is near the split at which its grouping changes.

The rule: ``mode = N`` is the N-th elastic eigenvector of
(Kr, Mr), scaled so that its largest nodal displacement is ``amplitude``. An eigenvector has no
sign, and within a repeated eigenvalue (a square beam's bending pair) no direction either: the
solver returns any basis of the pair. So:

- with ``direction = [x, y, z]`` the shape is the combination of the mode's cluster — the
  elastic eigenvalues within a relative split of ``CLUSTER_SPLIT`` = 1e-3 of each other,
  chained, the bound ``modes.json`` uses for near-repeated clusters — that moves farthest along
  the direction: a ∝ D_iᵀ d at the node i = argmax_i ‖D_iᵀ d‖ (D_i the 3 × k displacement of the
  cluster's k eigenvectors at node i, d the unit direction), so the displacement there, D_i a,
  has the largest component along d any node and any unit combination reach, and it is
  positive, whatever basis the solver returned for the cluster.
- without it, a cluster of two or more modes is oriented as above along the global axis e_a
  (x, y or z) it reaches farthest along — the largest max_i ‖D_iᵀ e_a‖, which no basis of the
  cluster changes; axes within 1 % of it tie and the lowest index wins (a square beam's
  bending pair: y) — and a single mode's sign is fixed so that its largest nodal
  displacement's largest-magnitude component is positive.

The run prints the rule and the direction taken (``summary.json``: ``initial_mode``), and
warns when the mode's cluster is within a factor of ten of ``CLUSTER_SPLIT`` — a split inside
it above 1e-4, or a gap to the nearest elastic eigenvalue outside it below 1e-2
(``spectrum.near_split_edge``): a small change of the body can then change which modes are
grouped, and so the start (a square beam widened by 1e-3 splits its pair by 2e-3: mode 1
starts alone, bending along z, not along y).

Ties: nodal values within 1 % (``initial.TIE``) of the largest count as equal (a symmetric
body's mirror nodes differ only by its mesh) and the node first in (x, y, z) order is taken
(likewise the first of tied components), so near-identical bodies get the same shape and sign.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body, elastic_modes
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.constraints.factorization import Solve
from gcms_fenicsx.dynamics.constraints.joints import Constraints
from gcms_fenicsx.dynamics.bodies.loads import ExternalForces
from gcms_fenicsx.config.scene import Initial, SceneError
from gcms_fenicsx.dynamics.stepping.state import Elastic, State, StepInfo
from gcms_fenicsx.numerics.spectrum import (CLUSTER_SPLIT, NEAR_SPLIT_FACTOR, cluster_of,
                                             cluster_splits, near_split_edge)

#: A direction along which the cluster's largest reach is below this fraction of its largest
#: nodal displacement is one the mode does not move along: refused.
MIN_REACH = 1e-6
#: Nodal values within this fraction of the largest count as tied: the mirror nodes of a
#: symmetric body (the two ends of a beam's antisymmetric mode) differ only by mesh asymmetry,
#: 1e-5..1e-3 on the square beams, and the tie goes to the node first in (x, y, z) order.
TIE = 1e-2
#: Coordinates are compared in that order to this fraction of the body's size (round-off in
#: the mesh's coordinates does not decide).
POSITION_RESOLUTION = 1e-6
RIGID_MODES = 6
AXES = "xyz"


def mode_cluster(lam: np.ndarray, index: int) -> range:
    """The indices of the elastic eigenvalues chained to ``lam[index]``, as ``modes.json``
    groups them (``numerics.spectrum``; ``lam`` ascending, the first six rigid)."""
    return cluster_of(lam, index, first=RIGID_MODES)


def nodal_displacements(body: Body, shapes: np.ndarray) -> np.ndarray:
    """D (N × 3 × k): the nodal displacement F Ψ_j of each coordinate direction ψ_j (n × k)."""
    k = shapes.shape[1]
    Psi = shapes.reshape(body.field_count, 3 * k)
    return np.asarray(body.node_fields @ Psi).reshape(-1, 3, k)


def first_of_largest(values: np.ndarray, body: Body) -> int:
    """The node of the largest of ``values`` (one per node); nodes within ``TIE`` of it are
    tied, and the first of them in (x, y, z) order wins."""
    tied = np.flatnonzero(values >= (1.0 - TIE) * values.max())
    key = np.round(body.nodes_m[tied] / (POSITION_RESOLUTION * body.size_m))
    return int(tied[np.lexsort(key.T[::-1])[0]])


def first_of_largest_component(vector: np.ndarray) -> int:
    """The component of largest magnitude; within ``TIE`` of it, the first (x, y, z)."""
    size = np.abs(vector)
    return int(np.flatnonzero(size >= (1.0 - TIE) * size.max())[0])


def oriented_shape(body: Body, shapes: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Ψ a with a ∝ D_iᵀ d at i = argmax_i ‖D_iᵀ d‖ (module docstring; ties:
    :func:`first_of_largest`): the unit combination of the Mr-orthonormal ``shapes`` (n × k)
    whose displacement at some node reaches farthest along the unit ``direction``;
    SceneError if no node moves along it."""
    D = nodal_displacements(body, shapes)
    reach = np.einsum("nik,i->nk", D, direction)          # D_iᵀ d for every node
    lengths = np.linalg.norm(reach, axis=1)
    node = first_of_largest(lengths, body)
    largest = float(np.linalg.norm(D, axis=1).max(initial=0.0))  # any unit a moves ≤ ‖D_i‖₂
    if not lengths[node] > MIN_REACH * largest:
        raise SceneError(
            f"[scene.initial] direction = {np.round(direction, 4).tolist()}: the mode does not "
            f"move along it (largest reach {lengths[node]:.1e} m against nodal displacements "
            f"up to {largest:.1e} m per unit coordinate); give a direction it moves in")
    return shapes @ (reach[node] / lengths[node])


def signed_shape(body: Body, shape: np.ndarray) -> np.ndarray:
    """``shape`` or −``shape``: the one whose largest nodal displacement's largest-magnitude
    component is positive (ties: :func:`first_of_largest`, :func:`first_of_largest_component`)."""
    D = nodal_displacements(body, shape[:, None])[:, :, 0]
    displacement = D[first_of_largest(np.linalg.norm(D, axis=1), body)]
    return shape if displacement[first_of_largest_component(displacement)] >= 0.0 else -shape


def farthest_axis(body: Body, shapes: np.ndarray) -> int:
    """The global axis a (0, 1, 2: x, y, z) the cluster ``shapes`` (n × k, Mr-orthonormal)
    reaches farthest along: the largest max_i ‖D_iᵀ e_a‖, the farthest any node moves along e_a
    in any unit combination (module docstring); within ``TIE`` of it the lowest index
    (:func:`first_of_largest_component`). A function of the cluster's subspace only: another
    orthonormal basis D_i R has the same row norms."""
    D = nodal_displacements(body, shapes)
    return first_of_largest_component(np.linalg.norm(D, axis=2).max(axis=0))


@dataclass(frozen=True)
class ModeStart:
    """How ``[scene.initial] mode`` was shaped (the module docstring's rule): the elastic
    modes (1-based) of its cluster, the cluster's largest relative split inside and its
    smallest to an elastic eigenvalue outside (None without one; ``spectrum.cluster_splits``),
    the rule that fixed the shape — "direction" (given), "farthest axis" (a cluster of several
    modes without a direction) or "sign" (a single mode without one) — and the unit
    direction it was oriented along (None under "sign")."""

    mode: int
    cluster: tuple[int, ...]
    split: float
    gap: float | None
    rule: str
    direction: tuple[float, ...] | None

    def line(self) -> str:
        """The progress line: which direction the start took, and by which rule."""
        modes = f"mode {self.mode}" + (f" (cluster of modes {', '.join(map(str, self.cluster))})"
                                       if len(self.cluster) > 1 else "")
        if self.rule == "sign":
            return f"initial state: {modes}, its sign by the largest nodal displacement"
        along = np.round(self.direction, 4).tolist()
        if self.rule == "direction":
            return f"initial state: {modes} along the given direction {along}"
        axis = AXES[int(np.argmax(self.direction))]
        return (f"initial state: {modes} along {axis} {along}, the global axis the cluster "
                "reaches farthest along (no direction given)")

    def warning(self) -> str | None:
        """Why a small change of the body could change the start: the cluster's splits within
        NEAR_SPLIT_FACTOR of CLUSTER_SPLIT (``spectrum.near_split_edge``); else None."""
        if not near_split_edge(self.split, self.gap):
            return None
        gap = "none" if self.gap is None else f"{self.gap:.2g}"
        return (f"[scene.initial] mode {self.mode}: its cluster of modes "
                f"{', '.join(map(str, self.cluster))} has relative splits {self.split:.2g} "
                f"inside and {gap} to the nearest mode outside, within a factor of "
                f"{NEAR_SPLIT_FACTOR:g} of the {CLUSTER_SPLIT:g} that groups modes: a small "
                "change of the body can change which modes are grouped, and so the start")

    def summary(self) -> dict:
        """``summary.json``'s ``initial_mode``."""
        return asdict(self)


def start_shape(body: Body, initial: Initial, lam: np.ndarray, psi: np.ndarray,
                index: int) -> tuple[np.ndarray, ModeStart]:
    """The unscaled shape of elastic eigenvector ``index`` (of ``lam``, ``psi``) by the module
    docstring's rule: along ``initial.direction``; without it, a cluster along its
    :func:`farthest_axis`, a single mode with :func:`signed_shape`'s sign."""
    cluster = mode_cluster(lam, index)
    shapes = psi[:, cluster.start:cluster.stop]
    if initial.direction is not None:
        rule, direction = "direction", np.asarray(initial.direction, float)
    elif len(cluster) > 1:
        rule, direction = "farthest axis", np.eye(3)[farthest_axis(body, shapes)]
    else:
        rule, direction = "sign", None
    shape = (signed_shape(body, psi[:, index]) if direction is None
             else oriented_shape(body, shapes, direction))
    split, gap = cluster_splits(lam, cluster, RIGID_MODES)
    start = ModeStart(mode=index - RIGID_MODES + 1,
                      cluster=tuple(k - RIGID_MODES + 1 for k in cluster), split=split,
                      gap=gap, rule=rule,
                      direction=None if direction is None else tuple(direction.tolist()))
    return shape, start


def initial_start(body: Body, initial: Initial) -> tuple[np.ndarray, ModeStart | None]:
    """q0, plus the requested elastic mode (oriented as the module docstring says) scaled to a
    largest nodal displacement of ``amplitude``; and how it was oriented (None without a
    mode)."""
    if initial.mode is None:
        return body.q0.copy(), None
    lam, psi = elastic_modes(body)
    index = RIGID_MODES - 1 + initial.mode
    if index >= len(lam):
        raise SceneError(f"[scene.initial] mode = {initial.mode}: the reduced model has "
                         f"{len(lam) - RIGID_MODES} elastic modes")
    shape, start = start_shape(body, initial, lam, psi, index)
    largest = float(np.max(np.linalg.norm(body.displacement(body.q0 + shape), axis=1)))
    return body.q0 + initial.amplitude_m / largest * shape, start


def initial_coordinates(body: Body, initial: Initial) -> np.ndarray:
    """The coordinates of :func:`initial_start`."""
    return initial_start(body, initial)[0]


def consistent_velocity(body: Body, constraints: Constraints, mass_solve: Solve, t: float,
                        q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The initial q̇: v corrected by the rigid velocity nearest it (kinetic-energy norm)
    that makes ġ = C q̇ + Ċ q = 0.

    Correcting within the rigid velocities the body has (``Body.rigid_velocities`` at q) turns, say,
    a spin the joints forbid into the rotation about the joint they allow, instead of
    putting the difference into the stiffest elastic coordinates; only what no rigid
    velocity can satisfy (a joint that constrains deformation rates) is corrected in
    the Mr-norm over all coordinates.
    """
    c = constraints
    if not c.count:
        return v
    U, dU = c.directions_at(t), c.directions_at(t, 1)
    C = c.jacobian(U)
    violation = C @ v + c.values(q, dU)
    rigid = body.rigid_velocities(q)
    # min |W a|²_M  subject to  C W a = −violation  (minimum-norm if C W is rank-deficient)
    CW = C @ rigid
    weight = rigid.T @ np.asarray(body.mass @ rigid)
    L_inv = np.linalg.inv(np.linalg.cholesky(weight))
    a = -L_inv.T @ (np.linalg.pinv(CW @ L_inv.T, rcond=1e-10) @ violation)
    v = v + rigid @ a
    rest = C @ v + c.values(q, dU)
    if np.linalg.norm(rest) > 1e-12 * max(np.linalg.norm(violation), 1e-300):
        MinvCt = mass_solve(C.T)
        v = v - MinvCt @ np.linalg.solve(C @ MinvCt, rest)
    return v


def consistent_state(body: Body, constraints: Constraints, forces: ExternalForces,
                     elastic: Elastic, damping: RayleighDamping, mass_solve: Solve,
                     q: np.ndarray, v: np.ndarray, t: float = 0.0) -> tuple[State, StepInfo]:
    """The state at t with consistent q̈ and λ: [Mr Cᵀ; C 0] [q̈; λ] = [f; −(2Ċq̇ + C̈q)]."""
    c = constraints
    U = c.directions_at(t)
    es = elastic(q)
    f_ext = forces(t)
    gradient = es.local_gradient
    dissipation = 0.0
    if damping.active:
        fd, dissipation = damping.on(body).local_force(v, es)
        gradient = gradient + fd
    f = f_ext - body.frame.to_global(gradient, es.rotation)
    lam = np.zeros(c.count)
    if c.count:
        C = c.jacobian(U)
        MinvCt = mass_solve(C.T)
        rhs = -(2.0 * c.values(v, c.directions_at(t, 1)) + c.values(q, c.directions_at(t, 2)))
        lam = np.linalg.solve(C @ MinvCt, C @ mass_solve(f) - rhs)
        f = f - C.T @ lam
    acc = mass_solve(f)
    state = State.of(t, q, v, acc, acc, lam)
    return state, StepInfo(es, dissipation, U, 0, f_ext, c.jacobian(U) if c.count else None)
