"""Joint rows of an assembly (docs/design.md §10).

A point of a member is linear in its coordinates: a node group's weighted mean position
x_G = Qᵀ h (``body.GroupRows``), a point mass's position (its coordinates, h = [1]); so is a
group's direction, L_G d = Qᵀ (H_G d). Every row here has the Jacobian of the single body's
rows, kron(v_i, u_i) over a member's coordinates (a :class:`Term`: v_i constant, u_i a
direction), in one of three forms:

- :class:`LinearRow` — g_i = Σ_terms u_i · (Qᵀ v_i) − u_i · (p(t) − p(0)) − g_i(0), u_i
  constant: :func:`coincide` (two points stay together, or a point follows a prescribed path
  p, a crank pin driven round its circle: three rows along x, y, z), :func:`on_line` (a point
  stays on the line through its start: two rows ⊥ it), :func:`keep_axis` (a group's direction
  stays along an axis fixed in space: two rows u · L_G d with d the axis, as a revolute
  joint's tilt rows to the ground, ``constraints.joints``);
- :class:`DrivenRow` — g = u(t) · (Qᵀ v) − g(0), u(t) = R_e(θ(t)) u₀ turned by a drive about
  the joint's axis (``joints.Constraints.directions_at``): :func:`drive` holds a group's
  rotation about a fixed axis at the drive's angle;
- rows between two members whose directions turn with them: ``relative_rows``.

Every row holds where the assembly starts (g(0) is its value there). For the initial state
and the work of the rows each gives ∂g/∂t and γ with C q̈ = γ (the rest of g̈ = 0).

Multipliers: the residual holds + Cᵀ λ, so a row's generalized force is −λ_i c_i: a
coincidence row along e_k applies −λ_i e_k (N) to its first point and +λ_i e_k to its
second; an axis or drive row's λ is a moment (N·m).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable, Mapping

import numpy as np

from gcms_fenicsx.config.scene import Drive
from gcms_fenicsx.dynamics.constraints.joints import RowInfo, plane_basis, turned
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass
from gcms_fenicsx.numerics.group_geometry import lever

#: t ↦ (p, ṗ, p̈) of a prescribed point (m, m/s, m/s²).
Path = Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]
#: Each member's coordinates as rows of 3 (Q, or Q̇), by name.
Parts = Mapping[str, np.ndarray]
AXES = np.eye(3)


@dataclass(frozen=True)
class Point:
    """x = Qᵀ v of the member named ``member`` (``vector`` v: a group's h, [1] for a point
    mass)."""

    member: str
    vector: np.ndarray
    label: str


def node_group(member: Flexible, group: str) -> Any:
    """The member's node group (a refusal naming the groups it has)."""
    if not isinstance(member, Flexible):
        raise ValueError(f"{member.name!r} is a point mass: it has no node groups (its point "
                         "is rows.mass_point)")
    checks.known("group", group, f"member {member.name!r}", member.body.groups)
    return member.body.groups[group]


def group_point(member: Flexible, group: str) -> Point:
    """The weighted mean position of a node group of a flexible member."""
    return Point(member.name, node_group(member, group).position, f"{member.name}.{group}")


def mass_point(member: PointMass) -> Point:
    """A point mass's position."""
    return Point(member.name, np.ones(1), member.name)


@dataclass(frozen=True)
class Term:
    """One member's part of a joint's rows: row i's Jacobian block is kron(v_i, u_i), v_i the
    rows of ``vectors`` (m × the member's fields), u_i the row's direction."""

    member: str
    vectors: np.ndarray

    def values(self, Q: np.ndarray) -> np.ndarray:
        """Qᵀ v_i for every row (m × 3)."""
        return self.vectors @ Q

    def matrix(self, directions: np.ndarray) -> np.ndarray:
        """[kron(v_i, u_i)]_i (m × 3 fields)."""
        m, nf = self.vectors.shape
        return (self.vectors[:, :, None] * directions[:, None, :]).reshape(m, 3 * nf)


@dataclass(frozen=True)
class Row:
    """The rows of one joint: its terms, ``axes`` (m × 3: what each row's multiplier acts
    along or about, at the start), ``kind`` ("force" or "moment")."""

    joint: str
    terms: tuple[Term, ...]
    axes: np.ndarray
    kind: str

    #: C does not change with q or t
    constant = False

    def infos(self) -> tuple[RowInfo, ...]:
        unit = "N" if self.kind == "force" else "N*m"
        return tuple(RowInfo(self.joint, self.kind, tuple(float(x) for x in u), unit)
                     for u in self.axes)

    def directions(self, Q: Parts, t: float) -> tuple[np.ndarray, ...]:
        """Each term's directions u_i (m × 3) at (q, t)."""
        raise NotImplementedError

    def value(self, Q: Parts, t: float) -> np.ndarray:
        """g + g(0) at (q, t) (m,)."""
        raise NotImplementedError

    def rates(self, Q: Parts, V: Parts, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(∂g/∂t, γ) at (q, q̇, t), C q̈ = γ the rest of g̈ = 0."""
        raise NotImplementedError


@dataclass(frozen=True)
class LinearRow(Row):
    """Σ_terms u_i · (Qᵀ v_i) − u_i · (p(t) − p(0)): constant ``units`` (one m × 3 array a
    term) and an optional path (rows along ``axes``)."""

    units: tuple[np.ndarray, ...] = ()
    path: Path | None = None
    meets: bool = False      # a coincidence: its points (or point and path) start together
    constant = True

    def directions(self, Q: Parts, t: float) -> tuple[np.ndarray, ...]:
        return self.units

    def value(self, Q: Parts, t: float) -> np.ndarray:
        g = sum((u * term.values(Q[term.member])).sum(axis=1)
                for term, u in zip(self.terms, self.units))
        return np.asarray(g) - self.moved(t)

    def gap(self, Q: Parts) -> np.ndarray:
        """How far apart a coincidence's points (or its point and its path) are (m)."""
        anchor = self.axes @ self.path(0.0)[0] if self.path is not None else 0.0
        return self.value(Q, 0.0) - anchor

    def moved(self, t: float) -> np.ndarray:
        """u_i · (p(t) − p(0)): how far the path has moved the rows' targets (zero without)."""
        if self.path is None:
            return np.zeros(len(self.axes))
        return self.axes @ (self.path(t)[0] - self.path(0.0)[0])

    def rates(self, Q: Parts, V: Parts, t: float) -> tuple[np.ndarray, np.ndarray]:
        if self.path is None:
            return np.zeros(len(self.axes)), np.zeros(len(self.axes))
        _, rate, acceleration = self.path(t)
        return -self.axes @ rate, self.axes @ acceleration


@dataclass(frozen=True)
class DrivenRow(Row):
    """u(t) · (Qᵀ v), u(t) = R_e(θ(t)) u₀ (one term, ``start`` u₀ (m × 3), ``axis`` e)."""

    start: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    axis: np.ndarray = field(default_factory=lambda: AXES[2])
    drive: Drive | None = None

    @cached_property
    def _rodrigues(self) -> tuple[np.ndarray, np.ndarray]:
        """e × u₀ and (u₀ · e) e of Rodrigues' formula, formed once (``joints.turned``)."""
        e, u0 = self.axis, self.start
        return np.cross(e, u0), np.outer(u0 @ e, e)

    def turned(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, u̇, ü) at t, u₀ turned about the axis by the drive's θ(t) (``joints.turned``)."""
        assert self.drive is not None
        return turned(self.start, *self._rodrigues, self.drive.angle(t))

    def directions(self, Q: Parts, t: float) -> tuple[np.ndarray, ...]:
        return (self.turned(t)[0],)

    def value(self, Q: Parts, t: float) -> np.ndarray:
        (term,) = self.terms
        return (self.turned(t)[0] * term.values(Q[term.member])).sum(axis=1)

    def rates(self, Q: Parts, V: Parts, t: float) -> tuple[np.ndarray, np.ndarray]:
        (term,) = self.terms
        _, u_rate, u_accel = self.turned(t)
        x, v = term.values(Q[term.member]), term.values(V[term.member])
        return (u_rate * x).sum(axis=1), -(2.0 * u_rate * v + u_accel * x).sum(axis=1)


def _along(point: Point, sign: float, count: int) -> Term:
    return Term(point.member, sign * np.tile(point.vector, (count, 1)))


def coincide(joint: str, a: Point, b: Point | Path) -> LinearRow:
    """x_a = x_b, or x_a = p(t) for a path p (``assemble`` refuses points that do not start
    together: the rows hold them where they start)."""
    if isinstance(b, Point):
        if b.member == a.member and np.array_equal(a.vector, b.vector):
            raise ValueError(f"joint {joint!r}: {a.label} is joined to itself")
        return LinearRow(joint, (_along(a, 1.0, 3), _along(b, -1.0, 3)), AXES.copy(), "force",
                         units=(AXES, AXES), meets=True)
    _check_path(joint, b)
    return LinearRow(joint, (_along(a, 1.0, 3),), AXES.copy(), "force", units=(AXES,), path=b,
                     meets=True)


def _check_path(joint: str, path: Path) -> None:
    """A path gives three finite 3-vectors (p, ṗ, p̈)."""
    try:
        values = [np.asarray(x, float) for x in path(0.0)]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"joint {joint!r}: its path must map t to (p, ṗ, p̈): {exc}") from exc
    if len(values) != 3 or any(v.shape != (3,) or not np.isfinite(v).all() for v in values):
        raise ValueError(f"joint {joint!r}: its path must map t to three finite 3-vectors "
                         "(p, ṗ, p̈)")


def on_line(joint: str, a: Point, direction: np.ndarray) -> LinearRow:
    """x_a stays on the line through its start along ``direction``: the two rows n_k · x_a."""
    axis = unit_axis(joint, direction)
    normals = np.array(plane_basis(axis))
    return LinearRow(joint, (_along(a, 1.0, 2),), normals, "force", units=(normals,))


def unit_axis(joint: str, axis: np.ndarray) -> np.ndarray:
    return checks.direction(f"joint {joint!r}: its axis", axis)


def _lever(joint: str, member: Flexible, group: str, c: np.ndarray,
           turning: np.ndarray | None) -> np.ndarray:
    """A direction d (in the assembly) the group extends in, ⊥ c (``lever``; spans are of the
    undeformed body, turned by the member's placement)."""
    span = node_group(member, group).span
    R0 = member.placement
    d = lever(span, R0.T @ c,
              None if turning is None else R0.T @ turning)
    if d is None:
        raise ValueError(f"joint {joint!r}: group {group!r} of {member.name!r} cannot hold a "
                         f"rotation about {np.round(c, 3).tolist()}: its nodes do not extend "
                         "perpendicular to it")
    return R0 @ d


def group_vector(member: Flexible, group: str, d: np.ndarray) -> np.ndarray:
    """v with Qᵀ v = L_G d̄, d̄ = R₀ᵀ d the direction d of the assembly in the body's own
    coordinates (L_G maps those; it is R₀ at the start)."""
    return node_group(member, group).affine @ (member.placement.T @ d)


def keep_axis(joint: str, member: Flexible, group: str, axis: np.ndarray) -> LinearRow:
    """The group's direction ``axis`` stays along it: for c ⊥ axis, the rotation about c is the
    row u · L_G d with d = axis (turning about the axis leaves it alone: ``lever``) and u = c × d,
    so its multiplier is the moment about c. ValueError if the group cannot hold it."""
    e = unit_axis(joint, axis)
    levers = [(c, _lever(joint, member, group, c, e)) for c in plane_basis(e)]
    vectors = np.array([group_vector(member, group, d) for _, d in levers])
    return LinearRow(joint, (Term(member.name, vectors),),
                     np.array([c for c, _ in levers]), "moment",
                     units=(np.array([np.cross(c, d) for c, d in levers]),))


def drive(joint: str, member: Flexible, group: str, axis: np.ndarray, prescribed: Drive
          ) -> DrivenRow:
    """The group's rotation about the fixed ``axis`` is the drive's angle θ(t): the row
    u(t) · L_G d, d ⊥ axis in the group, u₀ = axis × d turned by θ(t) (its multiplier the drive
    moment, N·m; ``joints``: sin(φ − θ) for a rotation φ)."""
    e = unit_axis(joint, axis)
    if not isinstance(prescribed, Drive):
        raise ValueError(f"joint {joint!r}: its drive must be a Drive, got {prescribed!r}")
    d = _lever(joint, member, group, e, None)
    return DrivenRow(joint, (Term(member.name, group_vector(member, group, d)[None, :]),),
                     e[None, :], "moment",
                     start=np.cross(e, d)[None, :], axis=e, drive=prescribed)


def circle_path(center: np.ndarray, start: np.ndarray, axis: np.ndarray, rate: float) -> Path:
    """A point turning about ``axis`` through ``center`` at ``rate`` rad/s from ``start``: a
    crank pin driven at constant speed (Rodrigues' rotation of r = start − center)."""
    e = checks.direction("circle_path: axis", axis)
    c = checks.vector("circle_path: center (m)", center)
    r = checks.vector("circle_path: start (m)", start) - c
    rate = float(rate)
    if not np.isfinite(rate):
        raise ValueError(f"circle_path: rate must be a finite number (rad/s), got {rate!r}")
    along, across, normal = e * (e @ r), np.cross(e, r), r - e * (e @ r)

    def path(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cs, sn = np.cos(rate * t), np.sin(rate * t)
        x = c + along + cs * normal + sn * across
        v = rate * (-sn * normal + cs * across)
        a = -rate * rate * (cs * normal + sn * across)
        return x, v, a
    return path


@dataclass(frozen=True)
class FixedPoint:
    """A point that does not move (the ground): a path that prescribes no motion."""

    x: np.ndarray

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.x, np.zeros(3), np.zeros(3)


def fixed_point(x: np.ndarray) -> FixedPoint:
    """A point of the ground."""
    return FixedPoint(checks.vector("fixed_point (m)", x))
