"""Joints to the ground as constraints that are linear in q (docs/design.md §5, §6).

Every constraint row has the form  g_i(q, t) = u_i(t) · (Qᵀ v_i) − d_i,  i.e. the row
kron(v_i, u_i) of C = ∂g/∂q, with v_i one of a group's linear functions of q
(``body.GroupRows``) and u_i a direction:

- position (3 rows per joint): v = h_G, u = e_x, e_y, e_z — the group's mean position stays
  where it starts;
- rotation about an axis c: with a direction d the group extends in, d ⊥ c, and u = c × d,
  the row u · L(q) d measures a small rotation δθ about c as δθ (so its multiplier is the
  moment about c, N·m); v = H_G d. Where the group may turn about an axis e (revolute,
  driven), a row must not change under R_e(φ): u · R_e(φ) d is constant in φ only for
  u = e or d = e, so the tilt rows use d = e × c (then u = e) or d = e;
- a drive turns the row about the joint axis e with the prescribed angle: u(t) = R_e(θ(t)) u,
  so u(t) · L d = sin(φ − θ) for a rotation φ about e.

A spherical joint has the 3 position rows; a revolute joint adds rotations about two axes
⊥ e (e free, or driven); a fixed joint rotations about all three. d_i are the rows' values
in the initial state, so every joint holds its group where it starts.

Rows sharing a v (a joint's position rows, say) are computed together: the integrator's
solves depend on the rows only through the few distinct v.

In rotor coordinates p (q = B p, ``rotor``) the rows are c_i B: still linear in u_i,
Σ_l u_il (kron(v, e_l) B), and independence is decided in the metric of Mp; a row the rotor
basis cannot move at all (its columns give it no component) is implied by the basis.

Redundant joints (two spherical joints on one group, a revolute and a spherical one, two
fixed joints, a fixed and a revolute one) repeat rows, and the constraint block of the
Newton matrix is then singular. The rows are linear in q, so whether a row is implied by the
others is decided once, at t = 0, in the kinetic metric: the Gram matrix Ĝ = D^-1/2 C Mr⁻¹ Cᵀ
D^-1/2 (D its diagonal) holds the cosines between the rows as forces acting on the body's
inertia, independent of their units (force or moment rows) and of the coordinates
(:func:`independent_rows`). A row already implied by the rows of earlier joints is dropped
and reported; a drive's row so implied means that another joint holds the rotation the drive
prescribes, which is a contradiction (SceneError naming both).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property, partial
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body, Coordinates
from gcms_fenicsx.config.scene import Drive, Joint, SceneError
from gcms_fenicsx.numerics.group_geometry import lever

EPS = float(np.finfo(float).eps)
#: A row in subspace coordinates that keeps less than this fraction of its squared reach is
#: implied by the subspace (``independent_rows``).
UNMOVED = 1e-12
#: Contributions below this fraction of the largest are not named when a drive's row is
#: found implied by other joints' rows (only the message uses it).
_NAMED_SHARE = 1e-6
MassSolve = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class RowInfo:
    """What one constraint row is, for reports: its joint, what its multiplier is, about or
    along which global axis (at the start), and its unit."""

    joint: str
    kind: str      # "force", "moment" or "drive_moment"
    axis: tuple[float, float, float]
    unit: str      # "N" or "N*m"


@dataclass(frozen=True)
class Constraints:
    """m rows g_i = u_i(t) · (Qᵀ v_{k_i}) − d_i over nv distinct vectors v (module docstring).

    ``vectors`` (nv, nf); ``index`` (m,) maps rows to vectors and ``row_vectors`` (m, nf) is
    ``vectors[index]``; ``directions`` (m, 3) are the u_i at θ = 0; ``drives`` maps a row to
    (Drive, axis) for the rotating rows. ``coordinates``: B when the run's coordinates are
    p with q = B p (the rotor basis), None for the body's own.
    """

    vectors: np.ndarray
    index: np.ndarray
    row_vectors: np.ndarray
    directions: np.ndarray
    targets: np.ndarray
    drives: dict[int, tuple[Drive, np.ndarray]]
    rows: tuple[RowInfo, ...]
    dropped: tuple[RowInfo, ...] = ()   # redundant rows left out (module docstring)
    coordinates: np.ndarray | None = None

    @property
    def count(self) -> int:
        return len(self.index)

    @cached_property
    def turning(self) -> tuple[tuple[int, Drive, np.ndarray, np.ndarray, np.ndarray], ...]:
        """(row, drive, u, e × u, e (e · u)) of every driven row, u at θ = 0."""
        return tuple((i, drive, u, np.cross(axis, u), axis * float(axis @ u))
                     for i, (drive, axis) in self.drives.items()
                     for u in (self.directions[i],))

    def directions_at(self, t: float, derivative: int = 0) -> np.ndarray:
        """u_i(t) (m, 3), or its first or second time derivative.

        A driven row turns about e as u(t) = R_e(θ) u = cos θ u + sin θ (e × u) + (1 − cos θ)
        e (e · u) (Rodrigues), so u̇ = θ̇ e × u(t) and ü = θ̈ e × u(t) + θ̇² (e (e · u) − u(t)),
        with e × u(t) = cos θ (e × u) + sin θ (e (e · u) − u).
        """
        U = self.directions if derivative == 0 else np.zeros_like(self.directions)
        if not self.drives:
            return U
        U = U.copy()
        for i, drive, u, e_u, along in self.turning:
            U[i] = turned(u, e_u, along, drive.angle(t))[derivative]
        return U

    def unit_rows(self) -> np.ndarray:
        """c_k(e_l) (nv, 3, n): the row of vector k for the direction e_l, kron(v_k, e_l) (times
        B). Made when asked, except in subspace coordinates, whose rows every step needs."""
        if self.coordinates is not None:
            return self._subspace_rows
        return self._kron_rows()

    def _kron_rows(self) -> np.ndarray:
        nv, nf = self.vectors.shape
        rows = np.zeros((nv, 3, nf, 3))
        for l in range(3):
            rows[:, l, :, l] = self.vectors
        return rows.reshape(nv, 3, 3 * nf)

    @cached_property
    def _subspace_rows(self) -> np.ndarray:
        """kron(v_k, e_l) B for every vector k and direction l (nv, 3, n)."""
        assert self.coordinates is not None
        return self._kron_rows().dot(self.coordinates)

    @cached_property
    def _row_units(self) -> np.ndarray:
        """The rows' own c(e_l) (m, 3, n), contiguous (subspace coordinates)."""
        return np.ascontiguousarray(self._subspace_rows[self.index])

    def values(self, q: np.ndarray, U: np.ndarray) -> np.ndarray:
        """C q = [u_i · (Qᵀ v_{k_i})]_i for the directions U (without the targets); for q of
        shape (n, k), C applied to each column (m, k)."""
        if self.coordinates is not None:
            q = self.coordinates.dot(q)
        if q.ndim == 1:
            return (U * (self.row_vectors @ q.reshape(-1, 3))).sum(axis=1)
        X = self.row_vectors @ q.reshape(self.row_vectors.shape[1], 3 * q.shape[1])
        return (U[:, :, None] * X.reshape(len(U), 3, q.shape[1])).sum(axis=1)

    def residual(self, q: np.ndarray, U: np.ndarray) -> np.ndarray:
        """g(q, t) = values − d for the directions U = u(t)."""
        return self.values(q, U) - self.targets

    def jacobian(self, U: np.ndarray) -> np.ndarray:
        """C (m × n), dense: row i is kron(v_{k_i}, u_i) (times B)."""
        if self.coordinates is not None:
            return np.einsum("il,ilj->ij", U, self._row_units)
        return (self.row_vectors[:, :, None] * U[:, None, :]).reshape(self.count,
                                                                      3 * self.vectors.shape[1])


def turned(u: np.ndarray, e_u: np.ndarray, along: np.ndarray,
           angle: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u(t), u̇, ü) of directions u (3,) or (m, 3) turned about e by θ(t) (``angle``: θ, θ̇,
    θ̈), given e × u and e (e · u): Rodrigues' u(t) = cos θ u + sin θ (e × u) + (1 − cos θ)
    e (e · u), u̇ = θ̇ e × u(t), ü = θ̈ e × u(t) + θ̇² (e (e · u) − u(t)), with e × u(t) =
    cos θ (e × u) + sin θ (e (e · u) − u) (``Constraints.directions_at``)."""
    theta, rate, accel = angle
    c, s = math.cos(theta), math.sin(theta)
    now = c * u + s * e_u + (1.0 - c) * along
    turned_e_u = c * e_u + s * (along - u)
    return now, rate * turned_e_u, accel * turned_e_u + rate * rate * (along - now)


def plane_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors b1, b2 with (b1, b2, axis) right-handed and orthonormal (axis a unit
    vector; then a × b1 = b2)."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    b1 = np.cross(axis, helper)
    b1 /= np.linalg.norm(b1)
    return b1, np.cross(axis, b1)


def build_constraints(body: Coordinates, joints: tuple[Joint, ...], q_start: np.ndarray,
                      mass_solve: MassSolve | None = None) -> Constraints:
    """The independent rows of every joint, with targets taken at ``q_start`` (module
    docstring); ``mass_solve`` applies Mr⁻¹ (default: a dense solve). Drive rows come last in
    the elimination, so a drive another joint contradicts is found whatever the joints' order.
    A rotor body (``rotor.RotorBody``: ``full`` and ``coordinates``) gets the rows of its full
    body in its coordinates p; ``q_start`` is then p."""
    if isinstance(body, Body):
        every = _all_rows(body, joints, q_start)
    else:
        B = body.coordinates
        every = replace(_all_rows(body.full, joints, B @ q_start), coordinates=B)
    if not every.count:
        return every
    solve = mass_solve or partial(np.linalg.solve, np.asarray(body.mass))
    C = every.jacobian(every.directions)
    order = [i for i in range(every.count) if i not in every.drives] + sorted(every.drives)
    reach = None
    if every.coordinates is not None:
        C_full = replace(every, coordinates=None).jacobian(every.directions)
        full_mass = np.asarray(body.full.mass)
        reach = np.einsum("ij,ji->i", C_full, np.linalg.solve(full_mass, C_full.T))
    keep, implied = independent_rows(C, body.mass, solve, order, reach)
    for i, weights in implied.items():
        if i in every.drives:
            raise _contradicting_drive(joints, every, i, weights)
    return _subset(every, keep)


def _all_rows(body: Body, joints: tuple[Joint, ...], q_start: np.ndarray) -> Constraints:
    """Every row of every joint, redundant or not, with targets taken at ``q_start``."""
    vectors: list[np.ndarray] = []
    index: list[int] = []
    directions: list[np.ndarray] = []
    drives: dict[int, tuple[Drive, np.ndarray]] = {}
    rows: list[RowInfo] = []

    def add(v: np.ndarray, u: np.ndarray, info: RowInfo) -> int:
        vectors.append(v)
        index.append(len(vectors) - 1)
        directions.append(u)
        rows.append(info)
        return len(index) - 1

    for joint in joints:
        g = body.groups[joint.group]
        start = len(vectors)
        vectors.append(g.position)
        for k in range(3):
            index.append(start)
            directions.append(np.eye(3)[k])
            rows.append(RowInfo(joint.name, "force", tuple(np.eye(3)[k]), "N"))
        axis = np.eye(3)[0] if joint.axis is None else np.asarray(joint.axis)
        frame = (*plane_basis(axis), axis) if joint.axis is not None else tuple(np.eye(3))
        for k, blind in joint.moment_rows():
            c = frame[k]
            d = lever(g.span, c, axis if blind else None)
            if d is None:
                raise SceneError(
                    f"joint {joint.name!r}: group {joint.group!r} cannot hold a rotation about "
                    f"{np.round(c, 3).tolist()}: its nodes do not extend perpendicular to it")
            kind = "drive_moment" if (k == 2 and joint.drive is not None) else "moment"
            i = add(g.affine @ d, np.cross(c, d),
                    RowInfo(joint.name, kind, tuple(float(x) for x in c), "N*m"))
            if k == 2 and joint.drive is not None:
                drives[i] = (joint.drive, axis)

    vec = np.array(vectors).reshape(len(vectors), body.field_count)
    idx = np.array(index, dtype=int)
    base = Constraints(vectors=vec, index=idx, row_vectors=vec[idx],
                       directions=np.array(directions).reshape(-1, 3),
                       targets=np.zeros(len(index)), drives=drives, rows=tuple(rows))
    return replace(base, targets=base.values(q_start, base.directions_at(0.0)))


def independent_rows(C: np.ndarray, mass: Any, mass_solve: MassSolve, order: list[int],
                     reach: np.ndarray | None = None
                     ) -> tuple[list[int], dict[int, dict[int, float]]]:
    """(kept, implied): the rows of C (m × n) that are independent in the metric Mr⁻¹, taken
    greedily in ``order`` (kept: ascending), and for each other row the weights a_k of the rows
    kept before it that imply it (ĉ = Σ a_k ĉ_k for the rows normalised in that metric).

    A Cholesky factorisation of the normalised Gram matrix Ĝ = D^-1/2 C Mr⁻¹ Cᵀ D^-1/2 in
    ``order``: the pivot of row i is sin²θ_i, θ_i its angle (in the metric Mr⁻¹) to the rows
    kept before it; a dependent row has a zero pivot. Rank tolerance: the computed Ĝ differs
    from the exact one by E with |E_ij| ≤ η + (m + 2)ε, where η = max_j √(r_jᵀ Mr⁻¹ r_j / G_jj)
    bounds the solve's error (r_j = Mr w_j − c_j, the residual of w_j = Mr⁻¹ c_j, by
    Cauchy–Schwarz in the Mr⁻¹ metric) and (m + 2)ε the rounding of a length-m inner product
    and of the normalisation; E moves the pivot of a row c = Σ a_k c_k by at most
    [−a; 1]ᵀ E [−a; 1] ≤ (1 + |a|²) ‖E‖₂ ≤ (1 + |a|²) m (η + (m + 2)ε). A row is implied
    when its pivot is below that.

    ``reach``: for rows in a subspace's coordinates (the rotor basis), c_j Mr⁻¹ c_jᵀ of the same
    rows in the full coordinates; a row with G_jj ≤ UNMOVED · reach_j (the subspace gives it
    less than 1e-6 of its reach in cosine) is implied by the subspace, with no weights.
    """
    m = C.shape[0]
    W = np.asarray(mass_solve(C.T))
    G = C @ W
    G = 0.5 * (G + G.T)
    scale = np.sqrt(np.diag(G))
    moved = np.ones(m, bool) if reach is None else np.diag(G) > UNMOVED * reach
    scale = np.where(moved, scale, 1.0)
    R = np.asarray(mass @ W) - C.T
    eta = float(np.sqrt(np.max(np.abs(np.einsum("ij,ij->j", R, np.asarray(mass_solve(R))))
                               / scale ** 2)))
    bound = m * (eta + (m + 2) * EPS)
    G_hat = G / np.outer(scale, scale)
    kept: list[int] = []
    L = np.zeros((0, 0))
    implied: dict[int, dict[int, float]] = {i: {} for i in order if not moved[i]}
    for i in order:
        if not moved[i]:          # a row the coordinates cannot move: implied by them
            continue
        l = np.linalg.solve(L, G_hat[kept, i]) if kept else np.zeros(0)
        a = np.linalg.solve(L.T, l) if kept else np.zeros(0)
        pivot = 1.0 - float(l @ l)
        if pivot <= (1.0 + float(a @ a)) * bound:
            implied[i] = dict(zip(kept, a.tolist()))
            continue
        L = np.block([[L, np.zeros((len(kept), 1))], [l[None, :], np.sqrt([[pivot]])]])
        kept.append(i)
    return sorted(kept), implied


def _subset(c: Constraints, keep: list[int]) -> Constraints:
    """``c`` with only the rows ``keep`` (ascending) and the vectors they use; the others are
    recorded as dropped."""
    used = sorted(set(c.index[keep].tolist()))
    renumber = {old: new for new, old in enumerate(used)}
    vectors = c.vectors[used]
    index = np.array([renumber[k] for k in c.index[keep].tolist()], dtype=int)
    return Constraints(vectors=vectors, index=index, row_vectors=vectors[index],
                       directions=c.directions[keep], targets=c.targets[keep],
                       drives={new: c.drives[old] for new, old in enumerate(keep)
                               if old in c.drives},
                       rows=tuple(c.rows[i] for i in keep),
                       dropped=tuple(r for i, r in enumerate(c.rows) if i not in keep),
                       coordinates=c.coordinates)


def _contradicting_drive(joints: tuple[Joint, ...], c: Constraints, row: int,
                         weights: dict[int, float]) -> SceneError:
    """SceneError: the drive's row ``row`` is implied by the rows ``weights`` of other joints."""
    drive = c.rows[row]
    position = next(k for k, j in enumerate(joints) if j.name == drive.joint)
    if not weights:
        return SceneError(f"[scene] joints[{position}] ({drive.joint}): the coordinates cannot "
                          f"turn the body about {np.round(drive.axis, 3).tolist()}, the axis "
                          "its drive turns it about")
    largest = max(abs(w) for w in weights.values())
    others = list(dict.fromkeys(c.rows[k].joint for k, w in weights.items()
                                if abs(w) > _NAMED_SHARE * largest
                                and c.rows[k].joint != drive.joint))
    named = " and ".join(repr(o) for o in others) or "its own rows"
    return SceneError(
        f"[scene] joints[{position}] ({drive.joint}): its drive about "
        f"{np.round(drive.axis, 3).tolist()} contradicts joint {named}, which already holds "
        f"the rotation about that axis; a drive must be the only joint holding it")

