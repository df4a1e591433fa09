"""The blocks an assembly's step works on (docs/design.md §10): the members that share a
model stepped together, every other member alone.

Members of one dense reduced body with the co-rotated law — four conrods of one model — form
a :class:`Batch`: their elastic states (``corotated.elastic_states``), mass products and
Newton solves are products with one column (or one 3×3 frame) per member, and their rows'
solves one einsum over all their rows, so k members make one member's NumPy calls and k
times its arithmetic. Every other member (a point mass, an SVK or full-order body, a model
used once) is a :class:`Single`. A block's coordinates are its members' in their order
(``where``: a slice where they are contiguous in q); :class:`RowScatter` says where its rows'
solved columns go in W = S⁻¹ Cᵀ.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple, Sequence

import numpy as np

from gcms_fenicsx.dynamics.bodies.corotated import ElasticStates, elastic_states
from gcms_fenicsx.dynamics.constraints.factorization import Solve, dense_factorization
from gcms_fenicsx.dynamics.system.members import Flexible, Iteration, Member, unit_rows

Where = slice | np.ndarray


@dataclass(frozen=True)
class BlockDiagonal:
    """diag(A_1, …, A_B) applied block by block to (N,) or (N, k) arrays by ``@``/``dot``:
    ``blocks`` (its coordinates: a slice or an index array, the block's product)."""

    blocks: tuple[tuple[slice, Any], ...]

    def dot(self, x: np.ndarray) -> np.ndarray:
        out = np.empty_like(x, dtype=float)
        for where, product in self.blocks:
            out[where] = product(x[where])
        return out

    __matmul__ = dot


class RowScatter(NamedTuple):
    """A block's row terms: ``terms`` index them in ``Assembly.directions``' array, ``owners``
    give each term's member (its position in the block), ``vectors`` its v_i (terms × fields);
    the solved columns of the terms of one row on one member are summed (``np.add.reduceat``
    at ``starts``) into column ``rows[j]`` of W on the coordinates ``coords[:, j]``."""

    terms: np.ndarray
    owners: np.ndarray
    vectors: np.ndarray
    starts: np.ndarray
    coords: np.ndarray
    rows: np.ndarray

    def add_to(self, W: np.ndarray, columns: np.ndarray) -> None:
        """W[coords, rows] = the solved ``columns`` of the terms (n × terms) summed by row."""
        if len(self.terms):
            W[self.coords, self.rows] = np.add.reduceat(columns, self.starts, axis=1)


@dataclass(frozen=True)
class Single:
    """One member alone: its own state, mass and solves (``members``)."""

    member: Member
    where: slice
    scatter: RowScatter

    @property
    def members(self) -> tuple[Member, ...]:
        return (self.member,)

    def state(self, q: np.ndarray) -> Any:
        return self.member.state(q)

    def mass_dot(self, x: np.ndarray) -> np.ndarray:
        return self.member.mass_dot(x)

    def mass_solver(self) -> Solve:
        return self.member.mass_solver()

    @property
    def damped(self) -> bool:
        return self.member.damped

    def damping_force(self, v: np.ndarray, state: Any) -> tuple[np.ndarray, float]:
        return self.member.damping_force(v, state)

    def iteration(self, beta_p: float, gamma_p: float) -> Callable[[Any], Iteration]:
        return self.member.iteration(beta_p, self.scatter.vectors, gamma_p)


@dataclass(frozen=True)
class Batch:
    """k flexible members of one dense reduced body with the co-rotated law (module
    docstring); their coordinates are ``where``, member after member."""

    members: tuple[Flexible, ...]
    where: Where
    scatter: RowScatter

    @property
    def body(self) -> Any:
        return self.members[0].body

    def _each(self, product: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
        """``product`` (n × c ↦ n × c) applied to each member's part of x (k n,) or (k n, c),
        for all k at once: one call on the n × k c array of the parts side by side."""
        k, n = len(self.members), self.body.dofs
        c = x.size // (k * n)
        side = x.reshape(k, n, c).transpose(1, 0, 2).reshape(n, k * c)
        return np.asarray(product(side)).reshape(n, k, c).transpose(1, 0, 2).reshape(x.shape)

    def state(self, q: np.ndarray) -> ElasticStates:
        return elastic_states(self.body, q.reshape(len(self.members), -1, 3))

    def mass_dot(self, x: np.ndarray) -> np.ndarray:
        """Mr x for each member's part, through G of Mr = G ⊗ I3 for vectors (``KronMass``)."""
        if x.ndim == 1:
            return np.matmul(self.body.gram, x.reshape(len(self.members), -1, 3)).reshape(-1)
        return self._each(self.body.mass.dot, x)

    def mass_solver(self) -> Solve:
        """Mr⁻¹ of each member's part."""
        inverse = self.members[0].mass_solver()
        return lambda x: self._each(inverse, x)

    #: members with damping are stepped alone (``batch_key``)
    damped = False

    def iteration(self, beta_p: float, gamma_p: float) -> Callable[[ElasticStates], Iteration]:
        """states ↦ the members' solves with T_b S₀⁻¹ T_bᵀ (``Flexible.iteration``: S₀ = β' Mr
        + Kr factorised once, and solved here once for the 3 columns kron(v_i, e_l) of every
        row term of every member), each member turned by its own frame."""
        body, k = self.body, len(self.members)
        nf = body.field_count
        inverse = dense_factorization(self.members[0].iteration_matrix(beta_p, gamma_p))
        vectors, owners = self.scatter.vectors, self.scatter.owners
        # S₀⁻¹ kron(v_i, e_l), laid out (term i, coordinate, l)
        solved = np.ascontiguousarray(np.asarray(inverse(unit_rows(vectors)))
                                      .reshape(body.dofs, len(vectors), 3).transpose(1, 0, 2))

        def at(states: ElasticStates) -> Iteration:
            R = states.rotation

            def solve(y: np.ndarray) -> np.ndarray:                     # T S₀⁻¹ Tᵀ y
                local = np.matmul(y.reshape(k, nf, 3), R).reshape(k, -1)
                x = inverse(local.T).T.reshape(k, nf, 3)
                return np.matmul(x, R.transpose(0, 2, 1)).reshape(-1)

            def rows(directions: np.ndarray) -> np.ndarray:
                turns = R[owners]
                turned = np.matmul(directions[:, None, :], turns)           # (Rᵀ u_i)ᵀ
                local = np.matmul(solved, turned.transpose(0, 2, 1))      # S₀⁻¹ Tᵀ kron(v, u)
                return np.matmul(local.reshape(len(owners), nf, 3), turns.transpose(0, 2, 1)
                                 ).reshape(len(owners), -1).T
            return Iteration(solve, rows)
        return at


Block = Single | Batch


def batch_key(member: Member) -> tuple | None:
    """What members must share to be stepped as one :class:`Batch`: the class and the body
    (dense, factorised densely, with the co-rotated law, in the full basis, undamped); None
    for a member that cannot be."""
    if not isinstance(member, Flexible) or member.law is not None or member.damped or (
            member.coordinates_map is not None):
        return None
    if member.factorize is not dense_factorization or not isinstance(
            member.body.projections.stiffness, np.ndarray):
        return None
    return type(member), id(member.body)


def group_blocks(members: Sequence[Member], offsets: dict[str, slice],
           scatters: Callable[[Sequence[Member]], RowScatter]) -> tuple[Block, ...]:
    """The members grouped into blocks (module docstring), in the order of their first
    members; ``scatters`` gives a group's :class:`RowScatter`."""
    groups: dict[Any, list[Member]] = {}
    for m in members:
        key = batch_key(m)
        groups.setdefault(m.name if key is None else key, []).append(m)
    made: list[Block] = []
    for group in groups.values():
        if len(group) == 1:
            made.append(Single(group[0], offsets[group[0].name], scatters(group)))
            continue
        index = np.concatenate([np.arange(offsets[m.name].start, offsets[m.name].stop)
                                for m in group])
        contiguous = bool(np.all(np.diff(index) == 1))
        where: Where = slice(int(index[0]), int(index[-1]) + 1) if contiguous else index
        made.append(Batch(tuple(group), where, scatters(group)))
    return tuple(made)
