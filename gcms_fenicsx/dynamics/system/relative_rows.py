"""Rows between two members whose directions turn with them (docs/design.md §10): the joints
between two bodies beyond a coincidence (``rows``, whose terms and conventions these share).

A group's direction is linear in its member's coordinates, L_G d = Qᵀ (H_G d̄)
(``rows.group_vector``), so a row that compares a direction of one member with a direction or
a point of another is bilinear:

- :class:`BilinearRow` — g_i = (Q_Aᵀ a_i) · (Q_Bᵀ b_i) − g_i(0): its term for A has the
  direction Q_Bᵀ b_i, for B Q_Aᵀ a_i. :func:`align_axes` keeps a direction of one member's
  group parallel to the same direction of another's (the tilt rows of a revolute joint
  between two bodies, two rows); :func:`hold_turn` holds their relative turning about it (one
  row: with align_axes, all three relative rotations — a fixed or prismatic joint);
- :class:`LineRow` — g_k = n_k(q_A) · (x_A − x_B) − g_k(0), n_k = L_A n̄_k the two directions
  of A's group ⊥ the axis: :func:`on_member_line` keeps B's point on the line along A's
  axis through where it starts, turning and bending with A (a piston in its bore: a
  cylindrical or prismatic joint between two bodies). Terms: (A, w_k) with direction
  x_A − x_B, (A, h_A) and (B, −h_B) with direction n_k; γ = −2 ṅ_k · (ẋ_A − ẋ_B). As a
  coincidence's, its multiplier λ_k is the force −λ_k n_k on A, +λ_k n_k on B.

Every row holds where the assembly starts (g(0) is its value there). NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gcms_fenicsx.dynamics.constraints.joints import plane_basis
from gcms_fenicsx.dynamics.system.members import Flexible
from gcms_fenicsx.dynamics.system.rows import (Parts, Point, Row, Term, group_vector,
                                                node_group, unit_axis)
from gcms_fenicsx.numerics.group_geometry import MIN_LEVER


@dataclass(frozen=True)
class BilinearRow(Row):
    """(Q_Aᵀ a_i) · (Q_Bᵀ b_i): terms (A, a), (B, b)."""

    def directions(self, Q: Parts, t: float) -> tuple[np.ndarray, ...]:
        first, second = self.terms
        return second.values(Q[second.member]), first.values(Q[first.member])

    def value(self, Q: Parts, t: float) -> np.ndarray:
        first, second = self.terms
        return (first.values(Q[first.member]) * second.values(Q[second.member])).sum(axis=1)

    def rates(self, Q: Parts, V: Parts, t: float) -> tuple[np.ndarray, np.ndarray]:
        first, second = self.terms
        rate_a, rate_b = first.values(V[first.member]), second.values(V[second.member])
        return np.zeros(len(self.axes)), -2.0 * (rate_a * rate_b).sum(axis=1)


@dataclass(frozen=True)
class LineRow(Row):
    """n_k · (x_A − x_B): terms (A, w) (n = Q_Aᵀ w), (A, h_A), (B, −h_B) (module docstring)."""

    def _parts(self, Q: Parts) -> tuple[np.ndarray, np.ndarray]:
        normals, own, other = self.terms
        gap = own.values(Q[own.member])[0] + other.values(Q[other.member])[0]   # x_A − x_B
        return normals.values(Q[normals.member]), gap

    def directions(self, Q: Parts, t: float) -> tuple[np.ndarray, ...]:
        n, gap = self._parts(Q)
        return np.tile(gap, (len(n), 1)), n, n

    def value(self, Q: Parts, t: float) -> np.ndarray:
        n, gap = self._parts(Q)
        return n @ gap

    def rates(self, Q: Parts, V: Parts, t: float) -> tuple[np.ndarray, np.ndarray]:
        n_rate, gap_rate = self._parts(V)
        return np.zeros(len(n_rate)), -2.0 * (n_rate @ gap_rate)


def _within(member: Flexible, group: str, d: np.ndarray) -> bool:
    """Whether the group extends along d (an assembly direction): L_G d is its own there."""
    span = node_group(member, group).span
    return bool(np.linalg.norm(span.T @ (member.placement.T @ d)) >= 1.0 - MIN_LEVER)


def _pair(joint: str, a: Flexible, group_a: str, b: Flexible, group_b: str, c: np.ndarray,
          candidates: tuple[tuple[np.ndarray, np.ndarray], ...], needs: str
          ) -> tuple[np.ndarray, np.ndarray]:
    """The first (p, s) of ``candidates`` (p × s = c) with a's group along p and b's along s;
    ValueError naming the groups and what they ``needs`` when none is."""
    for p, s in candidates:
        if _within(a, group_a, p) and _within(b, group_b, s):
            return p, s
    raise ValueError(f"joint {joint!r}: groups {group_a!r} of {a.name!r} and {group_b!r} of "
                     f"{b.name!r} cannot hold the rotation about {np.round(c, 3).tolist()}: "
                     + needs)


def _bilinear(joint: str, a: Flexible, group_a: str, b: Flexible, group_b: str,
              pairs: list[tuple[np.ndarray, np.ndarray]], axes: np.ndarray) -> BilinearRow:
    return BilinearRow(joint, (Term(a.name, np.array([group_vector(a, group_a, p)
                                                      for p, _ in pairs])),
                               Term(b.name, np.array([group_vector(b, group_b, s)
                                                      for _, s in pairs]))),
                       axes, "moment")


def align_axes(joint: str, a: Flexible, group_a: str, b: Flexible, group_b: str,
               axis: np.ndarray) -> BilinearRow:
    """The direction ``axis`` of a's group stays parallel to that of b's group: for each c ⊥
    the axis e, the row (L_A p) · (L_B s) with p × s = c measures the relative rotation about c
    and, with p or s the axis itself, is blind to the relative turning about it: p = e,
    s = c × e where a's group extends along e and b's along s, else s = e, p = e × c. Two rows;
    ValueError naming the groups when neither pair lies in them."""
    e = unit_axis(joint, axis)
    needs = (f"one must extend along {np.round(e, 3).tolist()} and the other across it")
    pairs = [_pair(joint, a, group_a, b, group_b, c,
                   ((e, np.cross(c, e)), (np.cross(e, c), e)), needs) for c in plane_basis(e)]
    return _bilinear(joint, a, group_a, b, group_b, pairs, np.array(plane_basis(e)))


def hold_turn(joint: str, a: Flexible, group_a: str, b: Flexible, group_b: str,
              axis: np.ndarray) -> BilinearRow:
    """The relative turning of a's and b's groups about ``axis`` e is held: the row
    (L_A p) · (L_B s), p and s ⊥ e with p × s = e (b1 × b2 = e for ``plane_basis``: the pair
    (b1, b2) or (b2, −b1), the first the groups extend along; a group extends along −d where
    along d). Its multiplier is the moment about e. ValueError naming the groups when neither
    lies in them."""
    e = unit_axis(joint, axis)
    b1, b2 = plane_basis(e)
    pair = _pair(joint, a, group_a, b, group_b, e, ((b1, b2), (b2, -b1)),
                 "both must extend across it")
    return _bilinear(joint, a, group_a, b, group_b, [pair], e[None, :])


def on_member_line(joint: str, a: Flexible, group_a: str, b: Point, axis: np.ndarray) -> LineRow:
    """``b`` stays on the line along a's group's direction ``axis`` through where it starts,
    the line turning and bending with the group: two rows n_k · (x_a − x_b), n_k the group's
    directions ⊥ the axis (``plane_basis``; each a force along n_k, N). ValueError when the
    group does not extend across the axis, or b is the group itself."""
    e = unit_axis(joint, axis)
    own = node_group(a, group_a)
    if b.member == a.name and np.array_equal(b.vector, own.position):
        raise ValueError(f"joint {joint!r}: {b.label} is held on its own line")
    normals = plane_basis(e)
    for n in normals:
        if not _within(a, group_a, n):
            raise ValueError(f"joint {joint!r}: group {group_a!r} of {a.name!r} does not extend "
                             f"along {np.round(n, 3).tolist()}, across the axis "
                             f"{np.round(e, 3).tolist()}: it cannot carry the line")
    return LineRow(joint, (Term(a.name, np.array([group_vector(a, group_a, n) for n in normals])),
                           Term(a.name, np.tile(own.position, (2, 1))),
                           Term(b.member, -np.tile(b.vector, (2, 1)))),
                   np.array(normals), "force")
