"""A flexible member in the rotor basis (docs/design.md §7.1, §10): a body that turns about
one axis only — a crankshaft in its main bearings — in its rotor coordinates p, q = B p of its
full basis (``bodies.rotor``).

Its joints' rows are its body's, taken at q = B p: a group's point Qᵀ v is linear in p, so a
row's Jacobian block is kron(v_i, u_i)ᵀ B (``assembly.RowPart``). Its mass matrix Mp = Bᵀ Mr B
is constant, its elastic law the rotor's co-rotated one (R2)–(R3), and its Newton solves
T(ψ) S₀⁻¹ T(ψ)ᵀ with S₀ = β' Mp + K̃ factorised once and T(ψ) turning the in-plane pairs by
the frame's phase e^{iψ} — the full basis's T S₀⁻¹ Tᵀ (``members.Flexible.iteration``), whose
rows are turned the same way: turning the body is B T(α) = (I ⊗ R(α)) B, so T(ψ)ᵀ Bᵀ kron(v, u)
= Bᵀ kron(v, R(ψ)ᵀ u), and S₀⁻¹ is applied once per run to the columns Bᵀ kron(v_i, e_l).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.dynamics.bases.run_basis import ROTOR_START
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.bodies.rotor import RotorBody, RotorState, rotor_state
from gcms_fenicsx.dynamics.constraints.factorization import Solve
from gcms_fenicsx.dynamics.system.members import Flexible, Iteration, placed_coordinates, unit_rows


@dataclass(frozen=True)
class RotorMember(Flexible):
    """A flexible member in the rotor coordinates of ``rotor`` (module docstring): ``body``
    is its full body (its groups, its GCMS coordinates q = B p), ``q_start`` its p."""

    rotor: RotorBody | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.rotor is None or self.rotor.full is not self.body:
            raise ValueError(f"member {self.name!r}: a rotor member needs the rotor body of "
                             "its body")
        object.__setattr__(self, "elastic", partial(rotor_state, self.rotor))

    @property
    def dofs(self) -> int:
        return self.rotor.dofs

    @property
    def coordinates_map(self) -> np.ndarray:
        return self.rotor.coordinates

    def fields(self, x: np.ndarray) -> np.ndarray:
        return (self.rotor.coordinates @ x).reshape(-1, 3)

    def gravity_force(self, g: np.ndarray) -> np.ndarray:
        return self.rotor.coordinates.T @ np.asarray(self.body.gravity @ g)

    def rigid_velocity(self, velocity: np.ndarray, angular_velocity: np.ndarray) -> np.ndarray:
        """The p of the rigid velocity nearest it in the kinetic-energy norm: exact for a
        turn about the axis and a translation (``RotorBody.rigid_velocities``)."""
        full = self.body.rigid_velocity(self.fields(self.q_start).ravel(), velocity,
                                        angular_velocity)
        return self.rotor.projector @ full

    @cached_property
    def damper(self) -> Any:
        """Its damping force on the rotor's deformation rate (``rotor.RotorDamping``)."""
        return self.damping.on(self.rotor) if self.damped else None

    def damping_force(self, v: np.ndarray, state: RotorState) -> tuple[np.ndarray, float]:
        local, power = self.damper.local_force(v, state)
        return self.rotor.frame.to_global(local, state.rotation), power

    def iteration_matrix(self, beta_p: float, gamma_p: float) -> Any:
        """S₀ = β' Mp + γ' D₀ + K̃ (D₀ = α Mp + β K̃ when damped)."""
        if self.damped:
            return self.damping.iteration_matrix(self.rotor, beta_p, gamma_p)
        return beta_p * self.rotor.mass + self.rotor.stiffness

    def mass_dot(self, x: np.ndarray) -> np.ndarray:
        return self.rotor.mass @ x

    def mass_solver(self) -> Solve:
        return self.factorize(self.rotor.mass)

    def iteration(self, beta_p: float, vectors: np.ndarray, gamma_p: float = 0.0
                  ) -> Callable[[Any], Iteration]:
        """state ↦ (y ↦ T S₀⁻¹ Tᵀ y, U ↦ T S₀⁻¹ Bᵀ [kron(v_i, u_i)]_i) (module docstring)."""
        rotor, k = self.rotor, len(vectors)
        inverse: Solve = self.factorize(self.iteration_matrix(beta_p, gamma_p))
        columns = rotor.coordinates.T @ unit_rows(vectors)              # Bᵀ kron(v_i, e_l)
        solved = np.asarray(inverse(columns)).reshape(rotor.dofs, k, 3) if k else None
        frame = rotor.frame

        def at(state: RotorState) -> Iteration:
            phase = state.rotation

            def solve(y: np.ndarray) -> np.ndarray:
                return frame.to_global(np.asarray(inverse(frame.to_local(y, phase))), phase)

            def rows(directions: np.ndarray) -> np.ndarray:
                local = np.einsum("pil,il->pi", solved, frame.directions(directions, phase))
                return turned(local, frame.pairs, phase)
            return Iteration(solve, rows)
        return at


def turned(X: np.ndarray, pairs: int, phase: complex) -> np.ndarray:
    """T(ψ) X for the columns of X (n × k): each in-plane pair (x, y) of rows turned to
    (x cos ψ − y sin ψ, x sin ψ + y cos ψ), the axial rows as they are (``RotorFrame``)."""
    out = X.copy()
    c, s = phase.real, phase.imag
    x, y = X[0:2 * pairs:2], X[1:2 * pairs:2]
    out[0:2 * pairs:2] = c * x - s * y
    out[1:2 * pairs:2] = s * x + c * y
    return out


def rotor_member(name: str, rotor: RotorBody, rotation: np.ndarray | None = None,
                 position: np.ndarray | None = None,
                 damping: RayleighDamping | None = None) -> RotorMember:
    """The member of ``rotor`` placed as ``placed_coordinates`` places its full body; a
    ValueError when the placement is not in the rotor basis (a turn about another axis than
    the rotor's)."""
    q = placed_coordinates(rotor.full, rotation, position)
    p, outside = rotor.project(q)
    if outside > ROTOR_START:
        raise ValueError(f"{name!r} steps in the rotor basis about "
                         f"{np.round(rotor.basis.axis, 6).tolist()} (its own coordinates): its "
                         "placement may turn it about that axis only (the rotor basis holds no "
                         f"other turn; {outside:.2g} of the placed body lies outside it)")
    return RotorMember(name, rotor.full, p, damping=damping, rotor=rotor)
