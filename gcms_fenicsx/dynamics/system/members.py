"""The members of an assembly: flexible GCMS bodies placed in it, and point masses
(docs/design.md §10).

Every member has its own coordinates, a constant mass matrix (the assembly's is
block-diagonal), its internal force and energy, and the solve with its Newton iteration
matrix. A flexible member is a :class:`~gcms_fenicsx.dynamics.bodies.body.Body` (reduced, or
the full-order model with F = I) with an elastic law (co-rotated by default) and its
iteration matrix T S₀ Tᵀ, S₀ = β' Mr + Kr factorised once for the run, T = I ⊗ R with the
frame R of the step's first iterate (the single body's modified Newton without its rank-9
change-of-frame term, docs/design.md §6: Mr commutes with T, so S⁻¹ = T S₀⁻¹ Tᵀ). A point
mass has three coordinates, its position.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property, partial
from typing import Any, Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.bodies.corotated import elastic_state
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.constraints.factorization import Factorize, Solve, dense_factorization
from gcms_fenicsx.dynamics.stepping.state import Elastic
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.numerics.rotation import polar


class Iteration(NamedTuple):
    """A member's Newton solves at one state: with its iteration matrix S_b, ``solve`` y ↦
    S_b⁻¹ y and ``rows`` U ↦ S_b⁻¹ [kron(v_i, u_i)]_i for its rows' directions U (k × 3)."""

    solve: Callable[[np.ndarray], np.ndarray]
    rows: Callable[[np.ndarray], np.ndarray]


def placed_coordinates(body: Body, rotation: np.ndarray | None = None,
                       position: np.ndarray | None = None) -> np.ndarray:
    """q of the undeformed body turned by R₀ and moved by x₀ (a node at X goes to x₀ + R₀ X):
    Q = Q0 R₀ᵀ + k1 x₀ᵀ, since F k1 = 1."""
    R0 = np.eye(3) if rotation is None else checks.rotation("rotation", rotation)
    x0 = np.zeros(3) if position is None else checks.vector("position", position)
    return (body.q0.reshape(-1, 3) @ R0.T + np.outer(body.unit, x0)).ravel()


def unit_rows(vectors: np.ndarray) -> np.ndarray:
    """The columns kron(v_i, e_l) of rows with the vectors v_i (k × fields), laid out (3 fields,
    3 k) with column 3 i + l: what S₀⁻¹ is applied to once per run (``iteration``)."""
    k, nf = vectors.shape
    units = np.zeros((nf, 3, k, 3))
    for l in range(3):
        units[:, l, :, l] = vectors.T
    return units.reshape(3 * nf, 3 * k)


@dataclass(frozen=True)
class Flexible:
    """A flexible body in the assembly, undeformed at ``q_start`` (:func:`placed_coordinates`).

    ``law`` maps q to its elastic state (``force`` ∂V/∂q, ``energy``, ``rotation``); the
    co-rotated law of ``corotated.elastic_state`` unless another is given (Saint
    Venant–Kirchhoff, ``bodies.svk``). ``factorize`` inverts S₀: dense for a reduced body, a
    sparse LU for the full-order one (``references.full_order.sparse_factorization``).
    ``damping``: Rayleigh damping of its co-rotated deformation rate (``bodies.damping``:
    rigid motion is not damped), the co-rotated law's only.
    """

    name: str
    body: Body
    q_start: np.ndarray
    law: Elastic | None = None
    factorize: Factorize = dense_factorization
    damping: RayleighDamping | None = None
    elastic: Elastic = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "elastic", self.law or partial(elastic_state, self.body))
        if self.damped and self.law is not None:
            raise ValueError(f"member {self.name!r}: Rayleigh damping is the co-rotated law's "
                             "(its deformation rate in the body frame); not with another law")

    @property
    def damped(self) -> bool:
        return self.damping is not None and self.damping.active

    @cached_property
    def damper(self) -> Any:
        """Its damping force (``RayleighDamping.on``), None when undamped."""
        return self.damping.on(self.body) if self.damped else None

    def damping_force(self, v: np.ndarray, state: Any) -> tuple[np.ndarray, float]:
        """(f_d, its dissipated power ėᵀ D₀ ė) at the velocity v and the elastic ``state``:
        f_d = T (local force) (``damping.DampingForce``)."""
        local, power = self.damper.local_force(v, state)
        return local.dot(state.rotation.T).ravel(), power

    def iteration_matrix(self, beta_p: float, gamma_p: float) -> Any:
        """S₀ = β' Mr + γ' D₀ + Kr (``RayleighDamping.iteration_matrix``; D₀ = 0 undamped)."""
        if self.damped:
            return self.damping.iteration_matrix(self.body, beta_p, gamma_p)
        return beta_p * self.body.mass + self.body.stiffness

    @property
    def dofs(self) -> int:
        return self.body.dofs

    @property
    def mass_kg(self) -> float:
        return self.body.total_mass_kg

    @property
    def coordinates_map(self) -> np.ndarray | None:
        """B with its body's GCMS coordinates q = B x (None: x is q)."""
        return None

    def fields(self, x: np.ndarray) -> np.ndarray:
        """Its body's GCMS coordinates Q (fields × 3) at its coordinates x (or their rates)."""
        return x.reshape(-1, 3)

    @cached_property
    def placement(self) -> np.ndarray:
        """R₀ of its placement: the frame polar(Qᵀ H) at ``q_start`` (I unless turned)."""
        return polar(self.fields(self.q_start).T @ self.body.affine).rotation

    def gravity_force(self, g: np.ndarray) -> np.ndarray:
        """Its generalized gravity force for the acceleration g (m/s²)."""
        return np.asarray(self.body.gravity @ g)

    def rigid_velocity(self, velocity: np.ndarray, angular_velocity: np.ndarray) -> np.ndarray:
        """Its q̇ at the start for the rigid velocity ẋ = v + ω × (x − c) (``Body``)."""
        return self.body.rigid_velocity(self.q_start, velocity, angular_velocity)

    @property
    def size_m(self) -> float:
        return self.body.size_m

    def mass_dot(self, x: np.ndarray) -> np.ndarray:
        """Mr x for (n,) (``Body.mass_product``) and (n, k) arrays."""
        return np.asarray(self.body.mass_product.dot(x) if x.ndim == 1 else self.body.mass @ x)

    def mass_solver(self) -> Solve:
        """Mr⁻¹, for (n,) and (n, k) arrays."""
        return self.factorize(self.body.mass)

    def state(self, q: np.ndarray) -> Any:
        """Its elastic state at q: ``force`` (n,), ``energy``, ``rotation``."""
        return self.elastic(q)

    def iteration(self, beta_p: float, vectors: np.ndarray, gamma_p: float = 0.0
                  ) -> Callable[[Any], Iteration]:
        """state ↦ (y ↦ T S₀⁻¹ Tᵀ y, U ↦ T S₀⁻¹ Tᵀ [kron(v_i, u_i)]_i) for the member's rows
        with the given ``vectors`` v_i (k × fields). S₀ (:meth:`iteration_matrix`, with the
        damping's γ' D₀ when damped) is factorised here, once,
        and so are its solves with the 3k columns kron(v_i, e_l): a row turned into the frame,
        Tᵀ kron(v, u) = Σ_l (Rᵀ u)_l kron(v, e_l), costs a combination of them, not a solve
        (the single body's unit rows, ``kkt``)."""
        body = self.body
        inverse: Solve = self.factorize(self.iteration_matrix(beta_p, gamma_p))
        k = len(vectors)
        units = unit_rows(vectors)
        solved = (np.asarray(inverse(units)).reshape(body.field_count, 3, k, 3) if k
                  else units.reshape(body.field_count, 3, k, 3))

        def at(state: Any) -> Iteration:
            R = state.rotation

            def solve(y: np.ndarray) -> np.ndarray:                     # T S₀⁻¹ Tᵀ y
                return body.frame.to_global(np.asarray(inverse(y.reshape(-1, 3).dot(R).ravel())),
                                            R)

            def rows(directions: np.ndarray) -> np.ndarray:
                local = np.einsum("fail,il->fai", solved, directions.dot(R))
                return np.einsum("fbi,ab->fai", local, R).reshape(body.dofs, k)
            return Iteration(solve, rows)
        return at


@dataclass(frozen=True)
class PointMass:
    """A point mass (kg) at ``position`` (m): coordinates its position, no internal force."""

    name: str
    mass: float
    position: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", checks.positive(f"point mass {self.name!r}: mass (kg)",
                                                         self.mass))
        object.__setattr__(self, "position",
                           checks.vector(f"point mass {self.name!r}: position (m)", self.position))

    @property
    def dofs(self) -> int:
        return 3

    @property
    def q_start(self) -> np.ndarray:
        return np.asarray(self.position, float)

    @property
    def mass_kg(self) -> float:
        return self.mass

    @property
    def size_m(self) -> float:
        return 0.0

    def fields(self, x: np.ndarray) -> np.ndarray:
        """Its position as one row (its "fields": h = [1])."""
        return x.reshape(-1, 3)

    def gravity_force(self, g: np.ndarray) -> np.ndarray:
        return self.mass * g

    def mass_dot(self, x: np.ndarray) -> np.ndarray:
        return self.mass * x

    def mass_solver(self) -> Solve:
        return lambda x: x / self.mass

    def state(self, q: np.ndarray) -> None:
        return None

    @property
    def damped(self) -> bool:
        return False

    def iteration(self, beta_p: float, vectors: np.ndarray, gamma_p: float = 0.0
                  ) -> Callable[[Any], Iteration]:
        """The point's iteration matrix is β' m I; its rows are v_i u_i (v_i = ±1)."""
        scale = 1.0 / (beta_p * self.mass)
        signs = vectors[:, 0]
        fixed = Iteration(lambda y: scale * y, lambda U: scale * (U * signs[:, None]).T)
        return lambda state: fixed


Member = Flexible | PointMass
