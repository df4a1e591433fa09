"""An assembly: its members' coordinates stacked into one q, the block-diagonal constant mass
matrix, and the joints' independent rows (docs/design.md §10).

q = [q_1; …; q_B] in the order the members are given; Mr = diag(Mr_1, …, Mr_B) is applied
block by block, never formed. The rows of every joint (``rows``) are stacked into g(q, t) and
C(q, t) = ∂g/∂q; the rows implied by earlier ones at the start are found in the kinetic
metric (``joints.independent_rows``, with Mr⁻¹ applied block by block) and dropped, so the
Newton matrix's constraint block is regular; :attr:`Assembly.dropped` reports them. For
linear rows (C constant) what is implied at the start is implied always; for driven and
bilinear rows the test is of the start. The linear joints' rows of C and their directions are
formed once; a step forms only the other joints' (and their g from their values, the linear
rows' as C q − d(t)).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import NamedTuple, Sequence

import numpy as np

from gcms_fenicsx.dynamics.constraints.joints import RowInfo, independent_rows
from gcms_fenicsx.dynamics.system.blocks import Block, BlockDiagonal, RowScatter, group_blocks
from gcms_fenicsx.dynamics.system.members import Flexible, Member
from gcms_fenicsx.dynamics.system.rigid import Rigid, rigidity
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.dynamics.system.rows import DrivenRow, FixedPoint, LinearRow, Parts, Row


class AssemblyError(ValueError):
    """An assembly that cannot be built: which member or joint, and why."""


class MemberRows(NamedTuple):
    """A member's part of the kept rows: row ``index[i]`` has the Jacobian block kron(v_i, u_i)
    over its body's GCMS coordinates (times B for a member in the rotor basis) (``vectors`` k × its fields, constant); ``entries`` (joint, term, row
    within the joint) says where u_i comes from, ``terms`` where the u_i are in
    :meth:`Assembly.directions`. ``index`` is ascending; ``starts`` are the positions where a
    new row begins (a row may have several terms on one member)."""

    index: np.ndarray
    vectors: np.ndarray
    entries: tuple[tuple[int, int, int], ...]
    starts: np.ndarray
    terms: slice


@dataclass(frozen=True)
class Assembly:
    """Members, the kept rows and their start values, and what was dropped."""

    members: tuple[Member, ...]
    offsets: dict[str, slice]
    joints: tuple[Row, ...]
    kept: tuple[tuple[int, int], ...]   # (joint, row within it) of each kept row
    rows: tuple[RowInfo, ...]
    dropped: tuple[RowInfo, ...]
    q_start: np.ndarray
    gravity_force: np.ndarray           # f_g (N,)
    member_rows: dict[str, MemberRows]
    start_values: np.ndarray            # g(0) of the kept rows
    dropped_keys: tuple[tuple[int, int], ...] = ()   # (joint, row within it) of each dropped
    dropped_values: np.ndarray = field(default_factory=lambda: np.zeros(0))   # their g(0)

    @property
    def dofs(self) -> int:
        return len(self.q_start)

    @property
    def count(self) -> int:
        return len(self.kept)

    @property
    def constant(self) -> bool:
        """Whether C is constant (every joint's rows linear)."""
        return all(row.constant for row in self.joints)

    @property
    def matrix(self) -> np.ndarray:
        """C at the start."""
        return self.jacobian(self.q_start, 0.0)

    @cached_property
    def blocks(self) -> tuple[Block, ...]:
        """The members as the step works on them (``blocks``: a model's members together)."""
        return group_blocks(self.members, self.offsets, self._scatter)

    def _scatter(self, group: Sequence[Member]) -> RowScatter:
        """The :class:`~blocks.RowScatter` of the rows of ``group``'s members, in its order."""
        terms, owners, vectors, starts, coords, rows = [], [], [], [], [], []
        count = 0
        for j, m in enumerate(group):
            r, where = self.member_rows[m.name], self.offsets[m.name]
            terms.append(np.arange(r.terms.start, r.terms.stop))
            owners.append(np.full(len(r.index), j))
            vectors.append(r.vectors)
            starts.append(r.starts + count)
            coords.append(np.repeat(np.arange(where.start, where.stop)[:, None], len(r.starts), 1))
            rows.append(r.index[r.starts])
            count += len(r.index)
        return RowScatter(np.concatenate(terms), np.concatenate(owners), np.vstack(vectors),
                          np.concatenate(starts), np.hstack(coords), np.concatenate(rows))

    @property
    def mass(self) -> BlockDiagonal:
        return BlockDiagonal(tuple((b.where, b.mass_dot) for b in self.blocks))

    def mass_inverse(self) -> BlockDiagonal:
        """Mr⁻¹, each block's factorised here (``mass_solver``)."""
        return BlockDiagonal(tuple((b.where, b.mass_solver()) for b in self.blocks))

    @property
    def total_mass_kg(self) -> float:
        return float(sum(m.mass_kg for m in self.members))

    @property
    def size_m(self) -> float:
        """The length scale of the Newton tolerance: the largest member's radius of gyration."""
        return max(m.size_m for m in self.members)

    def member(self, name: str) -> Member:
        checks.known("member", name, "the assembly", self.offsets)
        return next(m for m in self.members if m.name == name)

    def parts(self, q: np.ndarray) -> Parts:
        """Each member's body's GCMS coordinates as rows of 3 (views of q; B p for a member in
        the rotor basis)."""
        return {m.name: m.fields(q[self.offsets[m.name]]) for m in self.members}

    @cached_property
    def _kept_index(self) -> np.ndarray:
        """Where each kept row is in the joints' rows stacked joint after joint."""
        starts = np.cumsum([0] + [len(row.axes) for row in self.joints])
        return np.array([starts[j] + k for j, k in self.kept], dtype=int)

    def _kept(self, per_joint: list[np.ndarray]) -> np.ndarray:
        stacked = np.concatenate(per_joint) if per_joint else np.zeros(0)
        return stacked[self._kept_index]

    @cached_property
    def _moving(self) -> bool:
        """Whether a linear joint's path moves its rows' targets."""
        return any(isinstance(row, LinearRow) and _prescribed(row) for row in self.joints)

    def targets(self, t: float) -> np.ndarray:
        """d(t) with g = C q − d(t) for the rows of the linear joints: the start values moved
        by the paths (the start values alone for the other rows)."""
        if not self._moving:
            return self.start_values
        return self.start_values + self._kept([
            row.moved(t) if isinstance(row, LinearRow) else np.zeros(len(row.axes))
            for row in self.joints])

    @cached_property
    def _varying_rows(self) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
        """The joints that are not linear, the kept rows that are theirs, and where each is
        among their rows stacked joint after joint."""
        joints = tuple(j for j, row in enumerate(self.joints) if not row.constant)
        starts = dict(zip(joints, np.cumsum([0] + [len(self.joints[j].axes) for j in joints])))
        chosen = [(i, starts[j] + k) for i, (j, k) in enumerate(self.kept) if j in starts]
        return (joints, np.array([i for i, _ in chosen], dtype=int),
                np.array([s for _, s in chosen], dtype=int))

    def defined_residual(self, q: np.ndarray, t: float) -> np.ndarray:
        """g(q, t) of the kept rows from every joint's values, as the rows define it (what
        :meth:`residual` forms faster, and the finite differences of C are taken of)."""
        parts = self.parts(q)
        return self._kept([row.value(parts, t) for row in self.joints]) - self.start_values

    def residual(self, q: np.ndarray, t: float) -> np.ndarray:
        """g(q, t) of the kept rows: C q − d(t) for the linear joints' rows (their C formed
        once), the other joints' rows from their values."""
        g = self._fixed_jacobian.dot(q) - self.targets(t)
        joints, rows, index = self._varying_rows
        if joints:
            parts = self.parts(q)
            g[rows] += np.concatenate([self.joints[j].value(parts, t) for j in joints])[index]
        return g

    def rates(self, q: np.ndarray, v: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(∂g/∂t, γ) of the kept rows (``rows.Row.rates``)."""
        Q, V = self.parts(q), self.parts(v)
        both = [row.rates(Q, V, t) for row in self.joints]
        return self._kept([b[0] for b in both]), self._kept([b[1] for b in both])

    def dropped_values_at(self, q: np.ndarray, t: float) -> np.ndarray:
        """The values of the rows dropped at the start (``dropped``, in that order) at (q, t)."""
        parts = self.parts(q)
        values = {j: self.joints[j].value(parts, t) for j in {j for j, _ in self.dropped_keys}}
        return np.array([values[j][k] for j, k in self.dropped_keys]).reshape(-1)

    def dropped_gap(self, q: np.ndarray, t: float) -> np.ndarray:
        """How far each dropped row is from holding at (q, t), g − g(0): zero while the kept
        rows imply it, as they did at the start (a row implied only at a dead centre, or by
        a mass too small to count, is not: the run must say so, ``march``)."""
        if not self.dropped_keys:
            return np.zeros(0)
        return self.dropped_values_at(q, t) - self.dropped_values

    def _stacked(self, joints: Sequence[int]) -> dict[tuple[int, int], int]:
        """Where each term of ``joints`` starts in their directions stacked joint after joint,
        term after term: {(joint, term): position}."""
        base, at = {}, 0
        for j in joints:
            for term in range(len(self.joints[j].terms)):
                base[j, term] = at
                at += len(self.joints[j].axes)
        return base

    @cached_property
    def _entries(self) -> tuple[tuple[int, int, int], ...]:
        """Every member's row terms, member after member: the order of :meth:`directions`."""
        return tuple(e for rows in self.member_rows.values() for e in rows.entries)

    @cached_property
    def _fixed_directions(self) -> np.ndarray:
        base = self._stacked(range(len(self.joints)))
        parts = self.parts(self.q_start)
        stacked = [u for row in self.joints for u in row.directions(parts, 0.0)]
        return (np.concatenate(stacked) if stacked else np.zeros((0, 3)))[
            np.array([base[j, term] + k for j, term, k in self._entries], dtype=int)]

    @cached_property
    def _varying(self) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
        """The joints whose directions change with q or t, where their terms are among the
        directions, and where each is in theirs stacked (:meth:`_stacked`)."""
        joints = tuple(j for j, row in enumerate(self.joints) if not row.constant)
        base = self._stacked(joints)
        chosen = [(p, base[j, term] + k) for p, (j, term, k) in enumerate(self._entries)
                  if (j, term) in base]
        return (joints, np.array([p for p, _ in chosen], dtype=int),
                np.array([i for _, i in chosen], dtype=int))

    def directions(self, q: np.ndarray, t: float) -> np.ndarray:
        """Every member's rows' directions u_i (terms × 3): member after member, each in its
        :class:`MemberRows` order (``terms``); those of constant rows formed once."""
        if self.constant:
            return self._fixed_directions
        joints, positions, index = self._varying
        parts = self.parts(q)
        D = self._fixed_directions.copy()
        D[positions] = np.concatenate([u for j in joints
                                       for u in self.joints[j].directions(parts, t)])[index]
        return D

    def _row_parts(self, constant: bool) -> tuple[RowPart, ...]:
        """Each member's terms of the rows of constant (or of varying) joints, as RowParts."""
        made = []
        for name, rows in self.member_rows.items():
            chosen = np.array([self.joints[j].constant == constant for j, _, _ in rows.entries],
                              dtype=bool)
            if chosen.any():
                index = rows.index[chosen]
                starts = np.flatnonzero(np.diff(index, prepend=-1))
                made.append(RowPart(self.offsets[name], index[starts], rows.vectors[chosen],
                                    np.arange(rows.terms.start, rows.terms.stop)[chosen],
                                    starts, getattr(self.member(name), "coordinates_map", None)))
        return tuple(made)

    @cached_property
    def _fixed_jacobian(self) -> np.ndarray:
        """The rows of the constant joints in C (the others zero), formed once."""
        C = np.zeros((self.count, self.dofs))
        for part in self._row_parts(True):
            part.add_to(C, self._fixed_directions)
        return C

    @cached_property
    def _varying_parts(self) -> tuple[RowPart, ...]:
        return self._row_parts(False)

    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        """C(q, t) (m × N), dense: the constant joints' rows formed once, the others here."""
        C = self._fixed_jacobian.copy()
        if not self.constant:
            directions = self.directions(q, t)
            for part in self._varying_parts:
                part.add_to(C, directions)
        return C


class RowPart(NamedTuple):
    """Some of a member's row terms (``where`` its coordinates): term i has the Jacobian block
    kron(v_i, u_i) (``vectors``) over its body's GCMS coordinates (times ``basis`` B for a
    member in the rotor basis, q = B x), u_i at ``terms`` among the directions; the blocks of
    one row are summed (``np.add.reduceat`` at ``starts``, not add.at) into row ``rows[j]``."""

    where: slice
    rows: np.ndarray
    vectors: np.ndarray
    terms: np.ndarray
    starts: np.ndarray
    basis: np.ndarray | None = None   # B of a member whose body's coordinates are B x

    def add_to(self, C: np.ndarray, directions: np.ndarray) -> None:
        u = directions[self.terms]
        block = (self.vectors[:, :, None] * u[:, None, :]).reshape(len(u), -1)
        summed = np.add.reduceat(block, self.starts, axis=0)
        C[self.rows, self.where] += summed if self.basis is None else summed @ self.basis


def assemble(members: tuple[Member, ...], joints: tuple[Row, ...],
             gravity: np.ndarray | None = None) -> Assembly:
    """The assembly of ``members`` held by ``joints`` and each rigid member's rigidity rows
    (``rigid``; module docstring); AssemblyError for a repeated member name or a joint on a
    member that is not there."""
    names = [m.name for m in members]
    if len(set(names)) != len(names) or not names:
        raise AssemblyError(f"an assembly needs members with distinct names, got {names}")
    offsets, start = {}, 0
    for m in members:
        offsets[m.name] = slice(start, start + m.dofs)
        start += m.dofs
    for row in joints:
        for term in row.terms:
            if term.member not in offsets:
                raise AssemblyError(f"joint {row.joint!r} holds {term.member!r}, which is not "
                                    f"a member; the members are {names}")
    # the rigidity rows first: a joint's row they imply is the one dropped, never theirs
    joints = tuple(rigidity(m) for m in members if isinstance(m, Rigid)) + tuple(joints)
    q_start = np.concatenate([m.q_start for m in members])
    _check_gaps(members, offsets, joints, q_start)
    every = tuple((j, k) for j, row in enumerate(joints) for k in range(len(row.axes)))
    full = _build(members, offsets, joints, every, q_start, gravity)
    keep = list(range(len(every)))
    if every:
        prescribed = [i for i, (j, _) in enumerate(every) if _prescribed(joints[j])]
        order = [i for i in keep if i not in prescribed] + prescribed
        keep, _ = independent_rows(full.matrix, full.mass, full.mass_inverse().dot, order)
        for i in prescribed:
            if i not in keep:
                raise AssemblyError(
                    f"joint {joints[every[i][0]].joint!r}: the motion it prescribes is held by "
                    "other joints already (its row is implied by theirs): a drive or a path "
                    "must be the only joint holding what it moves")
    infos = [info for row in joints for info in row.infos()]
    kept = _build(members, offsets, joints, tuple(every[i] for i in keep), q_start, gravity)
    kept = replace(kept, rows=tuple(infos[i] for i in keep),
                   dropped=tuple(info for i, info in enumerate(infos) if i not in keep),
                   dropped_keys=tuple(every[i] for i in range(len(every)) if i not in keep))
    return replace(kept, dropped_values=kept.dropped_values_at(q_start, 0.0))


def _prescribed(row: Row) -> bool:
    """A row that moves with time (a drive's, a moving path's)."""
    path = getattr(row, "path", None)
    return isinstance(row, DrivenRow) or not (path is None or isinstance(path, FixedPoint))


#: Two points of a coincidence start together to this fraction of the largest member's size
#: (or 1e-9 m): the rows hold them where they start, so a gap would be kept, not closed.
GAP_TOLERANCE = 1e-6


def _check_gaps(members: tuple[Member, ...], offsets: dict[str, slice],
                joints: tuple[Row, ...], q_start: np.ndarray) -> None:
    """AssemblyError for a coincidence whose points (or point and path) do not start together."""
    parts = {m.name: m.fields(q_start[offsets[m.name]]) for m in members}
    tolerance = 1e-9 + GAP_TOLERANCE * max(m.size_m for m in members)
    for row in joints:
        if isinstance(row, LinearRow) and row.meets:
            gap = row.gap(parts)
            if np.linalg.norm(gap) > tolerance:
                raise AssemblyError(
                    f"joint {row.joint!r}: its points are {(np.round(gap, 9) + 0.0).tolist()} m apart "
                    f"at the start (tolerance {tolerance:.1e} m); a coincidence holds them where "
                    "they start, so place the members (or the path) where they meet")


def _build(members: tuple[Member, ...], offsets: dict[str, slice], joints: tuple[Row, ...],
           kept: tuple[tuple[int, int], ...], q_start: np.ndarray,
           gravity: np.ndarray | None) -> Assembly:
    """The assembly with the rows ``kept`` (its start values taken at q_start)."""
    parts: dict[str, list] = {m.name: [] for m in members}
    for i, (j, k) in enumerate(kept):
        for t, term in enumerate(joints[j].terms):
            parts[term.member].append((i, term.vectors[k], (j, t, k)))
    member_rows, at = {}, 0
    for m in members:
        rows = parts[m.name]
        width = m.body.field_count if isinstance(m, Flexible) else 1
        index = np.array([r[0] for r in rows], dtype=int)
        member_rows[m.name] = MemberRows(index,
                                         np.array([r[1] for r in rows]).reshape(len(rows), width),
                                         tuple(r[2] for r in rows),
                                         np.flatnonzero(np.diff(index, prepend=-1)),
                                         slice(at, at + len(rows)))
        at += len(rows)
    g = np.zeros(3) if gravity is None else checks.vector("gravity (m/s²)", gravity)
    built = Assembly(members=tuple(members), offsets=offsets, joints=tuple(joints), kept=kept,
                     rows=(), dropped=(), q_start=q_start, gravity_force=_gravity(members, g),
                     member_rows=member_rows, start_values=np.zeros(len(kept)))
    return replace(built, start_values=built.residual(q_start, 0.0))


def _gravity(members: tuple[Member, ...], g: np.ndarray) -> np.ndarray:
    """f_g: each flexible member's generalized gravity force ``gravity @ g``, m g for a point."""
    parts = [m.gravity_force(g) for m in members]
    return np.concatenate(parts)
