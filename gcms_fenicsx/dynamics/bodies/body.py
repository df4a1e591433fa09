"""A flexible body in GCMS coordinates, as the integrator sees it (docs/design.md §2, §6).

Node i is at x_i = Σ_f F[i, f] Q[f, :], with q = Q read row by row (nf fields, n = 3 nf).
The body carries only what the equations of motion need: Mr, Kr, the field Gram matrix
G (Mr = G ⊗ I3), the undeformed coordinates q0, and three small matrices derived from the
rigid fields:

- k1 (nf): coefficients of the constant field, F k1 = 1. g1 = G k1 holds ∫ρ F_f, so the
  mass is m = k1ᵀ g1, the centre of mass c = Qᵀ g1 / m and the linear momentum Q̇ᵀ g1.
- E (nf × 3): coefficients of the centred coordinates, F E = X − c.
- H (nf × 3): A(q) = Qᵀ H is the mass-weighted least-squares affine map of the body,
  x ≈ c + A (X − c): H = G E J⁻¹ with J = Eᵀ G E (so A(q0) = I). Its rotation R = polar(A)
  is the co-rotated frame.

Nothing here assumes the fields are few or dense: the full finite-element model is the
same body with F = I (nf = nodes), and Mr, Kr may then be SciPy sparse matrices (anything
with ``@``); this module itself needs NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, NamedTuple, Protocol

import numpy as np

from gcms_fenicsx.numerics.lapack import dot_into
from gcms_fenicsx.numerics.group_geometry import group_span
from gcms_fenicsx.numerics.rotation import axial, skew
from gcms_fenicsx.files.reduced_model import ReducedModel

@dataclass(frozen=True)
class GroupRows:
    """A node group as linear functions of q: its mean position and its affine map.

    x_G(q) = Qᵀ h (the weighted mean position) and L(q) = Qᵀ H_G, the weighted
    least-squares linear map of the group's own directions: L d = R d for every d in
    ``span`` under a rigid motion R (docs/design.md §5: positions are linear in q).
    """

    position: np.ndarray   # h (nf,)
    affine: np.ndarray     # H_G (nf, 3)
    span: np.ndarray       # (3, k) orthonormal directions the group's nodes extend in
    center_m: np.ndarray   # undeformed mean position X̄_G


def group_rows(field_rows: Any, weights: np.ndarray, coords: np.ndarray) -> GroupRows:
    """Rows of a group from its nodes' field rows F_G (k × nf, dense or sparse), weights and
    undeformed coordinates.

    h = F_Gᵀ w; with r_i = X_i − X̄, S = Σ w_i r_i r_iᵀ and S⁺ its pseudo-inverse on the
    directions the group extends in, H_G = F_Gᵀ (w r) S⁺, so L(q) = Σ w_i x_i r_iᵀ S⁺.
    """
    center = weights @ coords
    r = coords - center
    span, pinv = group_span((r * weights[:, None]).T @ r)
    weighted = np.asarray(field_rows.T @ (r * weights[:, None]))
    return GroupRows(position=np.asarray(field_rows.T @ weights).ravel(),
                     affine=weighted @ pinv, span=span, center_m=center)


#: Π and Πᵀ are dense nf × nf matrices up to this many fields (8 MB); a larger body (the
#: full finite-element model) applies them as rank-one updates.
DENSE_PROJECTION_FIELDS = 1000


class RankOneUpdate(NamedTuple):
    """I − u vᵀ applied to (nf, k) arrays by ``dot``, without forming it."""

    u: np.ndarray   # (nf, 1)
    v: np.ndarray   # (1, nf)

    def dot(self, X: np.ndarray) -> np.ndarray:
        return X - self.u.dot(self.v.dot(X))


#: Above this many coordinates Mr = G ⊗ I3 is applied through G (nf × nf): a third of the
#: arithmetic, for one reshape more (measured break-even: about 70 coordinates).
KRON_MASS_DOFS = 75


class KronMass(NamedTuple):
    """Mr = G ⊗ I3 applied by ``dot`` to vectors (n,) through G."""

    gram: np.ndarray

    def dot(self, x: np.ndarray) -> np.ndarray:
        return self.gram.dot(x.reshape(-1, 3)).ravel()


class ProjectedOperator(NamedTuple):
    """(Πᵀ ⊗ I3) A applied by ``dot`` to vectors (n,), without forming it."""

    operator: Any
    force: Any      # Πᵀ, applied to (nf, 3)

    def dot(self, e: np.ndarray) -> np.ndarray:
        return self.force.dot(self.operator.dot(e).reshape(-1, 3)).ravel()


class Projections(NamedTuple):
    """The translation projections of the co-rotated energy (``corotated``), each applied to
    (nf, k) arrays by ``dot``: Π = I − k1 g1ᵀ / m removes the mean translation from
    displacements, Πᵀ = I − g1 k1ᵀ / m the net force from forces; (Πᵀ ⊗ I3) Kr, applied to
    vectors e (n,); Π Q0; and [H [e_k]×]_k (3, 3 nf), so that H [b]× = (b · that).reshape(nf,
    3)."""

    deformation: Any
    force: Any
    stiffness: Any
    q0: np.ndarray
    affine_cross: np.ndarray


class FieldFrame:
    """T = I ⊗ R on GCMS coordinates: every field's 3-vector turned by R, the frame's rotation
    (the frame operations the integrator makes; ``rotor.RotorFrame`` has the same for rotor
    coordinates, whose rotation is a phase)."""

    @staticmethod
    def to_global(y: np.ndarray, R: np.ndarray) -> np.ndarray:
        """T y."""
        return y.reshape(-1, 3).dot(R.T).ravel()

    @staticmethod
    def back_operator(R: np.ndarray) -> np.ndarray:
        """What :meth:`back` turns with, formed once per linearisation: −Rᵀ."""
        return -R.T

    @staticmethod
    def back(z: np.ndarray, minus_RT: np.ndarray) -> np.ndarray:
        """−T z (a Newton correction turned back to global coordinates), with −Rᵀ from
        :meth:`back_operator`."""
        return z.reshape(-1, 3).dot(minus_RT).ravel()

    @staticmethod
    def residual(y: np.ndarray, gradient: np.ndarray, R_state: np.ndarray,
                 R: np.ndarray) -> np.ndarray:
        """r_l = Tᵀ(y + f) with T = I ⊗ R, from forces f given in the state's own frame R_state
        (``gradient``, nf × 3): where the two frames are one, as in the first iteration, f is
        never turned."""
        r = y.reshape(-1, 3).dot(R)
        if R_state is R:
            r += gradient
        else:
            r += gradient.dot(R_state.T.dot(R))
        return r.ravel()

    @staticmethod
    def turn_rows(C: np.ndarray, R: np.ndarray, out: np.ndarray) -> None:
        """out = C T for the rows C (m × n)."""
        dot_into(C.reshape(-1, 3), R, out.reshape(-1, 3))

    @staticmethod
    def directions(U: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Rᵀ u_i for the constraint directions U (m × 3)."""
        return U.dot(R)

    @staticmethod
    def matrix(R: np.ndarray, n: int) -> np.ndarray:
        """T = I ⊗ R (n × n), dense."""
        return np.kron(np.eye(n // 3), R)


FIELD_FRAME = FieldFrame()


class Coordinates(Protocol):
    """What the integrator, the joints, the damping and the Newton systems need of a body:
    the full basis's :class:`Body`, or a rotor body (``rotor.RotorBody``, coordinates p with
    q = B p)."""

    mass: Any
    stiffness: Any
    q0: np.ndarray

    @property
    def dofs(self) -> int: ...

    @property
    def mass_product(self) -> Any: ...

    @property
    def total_mass_kg(self) -> float: ...

    @property
    def size_m(self) -> float: ...

    @property
    def frame(self) -> Any: ...

    def rigid_velocities(self, q: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Body:
    """Constant matrices and rigid-field data of one flexible body in GCMS coordinates.

    ``mass`` Mr and ``stiffness`` Kr (n × n) support ``@``; ``gram`` is G (nf × nf);
    ``gravity`` (n × 3) gives the generalized gravity force ``gravity @ g``.
    """

    mass: Any
    stiffness: Any
    gram: Any
    q0: np.ndarray
    unit: np.ndarray        # k1
    field_mass: np.ndarray  # g1 = G k1 = ∫ρ F_f
    affine: np.ndarray    # H
    gravity: np.ndarray
    groups: dict[str, GroupRows]  # by name; a scene's names are checked by Scene.check_groups
    total_mass_kg: float
    second_moment: np.ndarray  # J = Eᵀ G E = ∫ρ X̃ X̃ᵀ (kg·m²), about the centre of mass
    size_m: float         # radius of gyration √(tr J / m): the length scale of tolerances
    node_fields: Any      # F (N × nf), dense or sparse (the identity for the full model)
    nodes_m: np.ndarray   # undeformed node coordinates (N × 3)

    @property
    def dofs(self) -> int:
        return self.q0.shape[0]

    @cached_property
    def projections(self) -> Projections:
        """Π, Πᵀ, Πᵀ Kr, Π Q0 and H [e_k]× (:class:`Projections`), dense for a reduced body."""
        m, nf = self.total_mass_kg, self.field_count
        k1, g1 = self.unit[:, None], self.field_mass[:, None]
        if nf <= DENSE_PROJECTION_FIELDS:
            deformation = np.eye(nf) - k1.dot(g1.T / m)
            force: Any = deformation.T.copy()
        else:
            deformation, force = RankOneUpdate(k1, g1.T / m), RankOneUpdate(g1, k1.T / m)
        return Projections(deformation=deformation, force=force,
                           stiffness=projected_stiffness(force, self.stiffness, k1, g1 / m),
                           q0=deformation.dot(self.q0.reshape(-1, 3)),
                           affine_cross=(self.affine @ skew(np.eye(3))).reshape(3, -1))

    @cached_property
    def mass_product(self) -> Any:
        """Mr for ``dot`` with vectors: itself, or :class:`KronMass` for a large dense body."""
        if self.dofs > KRON_MASS_DOFS and isinstance(self.gram, np.ndarray):
            return KronMass(np.ascontiguousarray(self.gram))
        return self.mass

    @property
    def field_count(self) -> int:
        return self.q0.shape[0] // 3

    @property
    def frame(self) -> FieldFrame:
        return FIELD_FRAME

    def displacement(self, q: np.ndarray) -> np.ndarray:
        """Nodal displacements F Q − X (N × 3)."""
        return np.asarray(self.node_fields @ q.reshape(-1, 3)) - self.nodes_m

    def center_of_mass(self, q: np.ndarray) -> np.ndarray:
        """c = Qᵀ g1 / m."""
        return q.reshape(-1, 3).T @ self.field_mass / self.total_mass_kg

    def momenta(self, Q: np.ndarray, V: np.ndarray, GV: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For k states Q, Q̇ (k, nf, 3): kinetic energy ½ q̇ᵀ Mr q̇ = ½ Q̇ : G Q̇, linear
        momentum Q̇ᵀ g1 and angular momentum L = ∫ρ x × ẋ dV = Σ_f Q_f × (G Q̇)_f about the
        origin, of shapes (k,), (k, 3), (k, 3). G Q̇ is given (``GV``: the recorder's rows) or
        one product for all k states; L is the axial vector w((G Q̇)ᵀ Q) of k 3 × 3 products
        (np.cross summed made temporaries thrice that size: a recorded block's flush took twice
        as long)."""
        if GV is None:
            k, nf = V.shape[:2]
            GV = np.asarray(self.gram @ V.transpose(1, 0, 2).reshape(nf, 3 * k))
            GV = GV.reshape(nf, k, 3).transpose(1, 0, 2)
        return (0.5 * np.einsum("kfa,kfa->k", V, GV), np.matmul(self.field_mass, V),
                axial(np.matmul(GV.transpose(0, 2, 1), Q)))

    def rigid_velocity(self, q: np.ndarray, velocity: np.ndarray,
                       angular_velocity: np.ndarray) -> np.ndarray:
        """q̇ of the rigid velocity field ẋ = v + ω × (x − c) at configuration q.

        Exact in the GCMS space: ẋ_i = Ω F_i Q + (v − Ω c) gives Q̇ = Q Ωᵀ + k1 (v − Ω c)ᵀ.
        """
        Omega = skew(np.asarray(angular_velocity, float))
        Q = q.reshape(-1, 3)
        drift = np.asarray(velocity, float) - Omega @ self.center_of_mass(q)
        return (Q @ Omega.T + np.outer(self.unit, drift)).ravel()

    def rigid_velocities(self, q: np.ndarray) -> np.ndarray:
        """The six rigid velocities at q (n × 6): translations along x, y, z, then rotations
        about x, y, z through the centre of mass."""
        E, zero = np.eye(3), np.zeros(3)
        return np.column_stack([self.rigid_velocity(q, E[k], zero) for k in range(3)]
                               + [self.rigid_velocity(q, zero, E[k]) for k in range(3)])


def projected(force: Any, A: Any) -> Any:
    """(Πᵀ ⊗ I3) A for ``dot`` with vectors (n,), for Πᵀ = ``force`` (``Body.projections``):
    formed once where both are dense, else :class:`ProjectedOperator`."""
    if isinstance(force, np.ndarray) and isinstance(A, np.ndarray):
        return force.dot(A.reshape(len(force), -1)).reshape(A.shape)
    return ProjectedOperator(A, force)


def projected_stiffness(force: Any, Kr: Any, k1: np.ndarray, g1m: np.ndarray) -> Any:
    """(Πᵀ ⊗ I3) Kr for ``dot`` with the vectors it is applied to, which lie in the range of
    Π ⊗ I3 (e = Π Q_loc − Π Q0, and the change of frame's Ĉ): there it equals
    (Πᵀ ⊗ I3) Kr (Π ⊗ I3), Π = I − k1 g1ᵀ/m (``g1m`` = g1/m, columns), and where both are dense
    it is formed so, as that matrix's symmetric part: exactly symmetric — the compiled step
    reads one triangle of it (``kernel_data.SYMMETRIC_FROM``) — and with no net force on either
    side to round-off of it (½(Πᵀ Kr + Kr Π) would not do: Kr's rows on a translation are zero
    only to the stiffness matrix's round-off, which shows in a free body's momentum). The
    right factor is the rank-one update it is: O(n²)."""
    left = projected(force, Kr)
    if not (isinstance(force, np.ndarray) and isinstance(Kr, np.ndarray)):
        return left
    n = len(Kr)
    fields = left.reshape(n, len(k1), 3)
    on_unit = np.tensordot(fields, k1.ravel(), axes=(1, 0))          # (n, 3)
    both = fields - on_unit[:, None, :] * g1m.reshape(1, -1, 1)
    both = both.reshape(n, n)
    return 0.5 * (both + both.T)


def elastic_modes(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and Mr-orthonormal eigenvectors of (Kr, Mr), ascending (dense bodies); the
    first six are the rigid modes."""
    return mass_normalised_modes(np.asarray(body.stiffness), np.asarray(body.mass))


def mass_normalised_modes(K: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and M-orthonormal eigenvectors of (K, M), ascending: with L Lᵀ = M,
    L⁻¹ K L⁻ᵀ y = λ y and ψ = L⁻ᵀ y."""
    L_inv = np.linalg.inv(np.linalg.cholesky(M))
    A = L_inv @ K @ L_inv.T
    lam, Y = np.linalg.eigh(0.5 * (A + A.T))
    return lam, L_inv.T @ Y


def make_body(mass: Any, stiffness: Any, gram: Any, q0: np.ndarray, unit: np.ndarray,
              centred: np.ndarray, gravity: np.ndarray, groups: dict[str, GroupRows],
              node_fields: Any, nodes_m: np.ndarray) -> Body:
    """A :class:`Body` from its matrices and rigid-field coefficients; derives H, m and the size."""
    g1 = np.asarray(gram @ unit).ravel()
    total = float(unit @ g1)
    B = np.asarray(gram @ centred)
    J = centred.T @ B
    return Body(mass=mass, stiffness=stiffness, gram=gram, q0=q0, unit=unit, field_mass=g1,
                affine=B @ np.linalg.inv(J), gravity=gravity, groups=groups,
                total_mass_kg=total, second_moment=J,
                size_m=float(np.sqrt(np.trace(J) / total)),
                node_fields=node_fields, nodes_m=nodes_m)


def body_from_reduced(model: ReducedModel) -> Body:
    """The body of an exported reduced model (``reduced.h5``).

    The first four fields span {1, X, Y, Z} (scaled and shifted or not), so k1 is the exact
    least-squares solution on them and zero on the flexible fields, and so is Q0
    (``undeformed_coordinates``): F Q0 = X, hence E = Q0 − k1 cᵀ gives F E = X − c.
    """
    F, nodes = model.fields, model.nodes_m
    nf = F.shape[1]
    rigid = F[:, :4]
    unit, *_ = np.linalg.lstsq(rigid, np.ones(len(F)), rcond=None)
    G = np.ascontiguousarray(model.mass[::3, ::3])
    k1 = np.zeros(nf)
    k1[:4] = unit
    q0 = model.undeformed_coordinates()
    center = q0.reshape(-1, 3).T @ (G @ k1) / (k1 @ G @ k1)
    E = q0.reshape(-1, 3) - np.outer(k1, center)
    groups = {name: group_rows(F[g.nodes], g.weights, nodes[g.nodes])
              for name, g in model.groups.items()}
    return make_body(mass=model.mass, stiffness=model.stiffness, gram=G, q0=q0, unit=k1,
                     centred=E, gravity=model.gravity, groups=groups, node_fields=F,
                     nodes_m=nodes)
