"""Rigid bodies in natural coordinates: a GCMS body of the four rigid fields
(docs/design.md §10).

A rigid body's point at X (its own coordinates) is at x = x₀ + A X, linear in the twelve
coordinates Q = [x₀ᵀ; a_xᵀ; a_yᵀ; a_zᵀ] (A = [a_x a_y a_z]): it is the GCMS body whose fields are
1, X, Y, Z (F = [1 X Y Z]), with the constant mass matrix G ⊗ I3,

    G = ∫ρ [1; X] [1 Xᵀ] dV = [[m, m cᵀ], [m c, J_c + m c cᵀ]],    J_c = ½ tr(I_c) I − I_c,

from the mass m, the centre of mass c and the inertia tensor I_c about it (J_c is the second
moment ∫ρ (X − c)(X − c)ᵀ), no stiffness, and six rows that keep it rigid, AᵀA = I:
a_i · a_j − δ_ij, each the bilinear row (Qᵀ e_i) · (Qᵀ e_j) of one member (``rows``). So it is
a :class:`~gcms_fenicsx.dynamics.system.members.Flexible` member whose body is made here
(:class:`Rigid`, whose rows ``assemble`` adds), and every joint takes it as it takes a
flexible one: its named points are node groups of one point that extend in every direction
(a group's direction is A d).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body, GroupRows, make_body
from gcms_fenicsx.dynamics.system import checks
from gcms_fenicsx.dynamics.system.members import Flexible, placed_coordinates
from gcms_fenicsx.dynamics.system.relative_rows import BilinearRow
from gcms_fenicsx.dynamics.system.rows import Term

#: Q0 of the rigid fields: x₀ = 0, A = I.
RIGID_Q0 = np.vstack([np.zeros(3), np.eye(3)])
#: The pairs (i, j) of AᵀA = I, i ≤ j.
PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def rigid_body(mass_kg: float, center_m: np.ndarray, inertia_kgm2: np.ndarray,
               points: Mapping[str, np.ndarray]) -> Body:
    """The four-field body of a rigid body (module docstring) with named ``points`` (its own
    coordinates, m) as groups; ValueError for a mass ≤ 0 or an inertia tensor that is not
    symmetric positive definite with the triangle inequalities (a body's)."""
    c = checks.vector("rigid body: center_m", center_m)
    mass_kg = checks.positive("rigid body: mass_kg", mass_kg)
    inertia = np.asarray(inertia_kgm2, float)
    if inertia.shape != (3, 3) or not np.isfinite(inertia).all():
        raise ValueError(f"rigid body: inertia_kgm2 must be a 3 × 3 tensor of finite numbers "
                         f"(kg m², about the centre of mass), got {inertia_kgm2!r}")
    principal = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if (not np.allclose(inertia, inertia.T, rtol=1e-12, atol=1e-15 * np.abs(inertia).max())
            or not principal[0] > 0
            or not principal[2] < (1.0 - 1e-9) * (principal[0] + principal[1])):
        raise ValueError("rigid body: inertia_kgm2 must be symmetric with positive principal "
                         "moments, each less than the sum of the other two (a body that extends "
                         f"in all three directions); got principal moments {principal.tolist()}")
    points = {name: checks.vector(f"rigid body: point {name!r}", x) for name, x in points.items()}
    second = 0.5 * np.trace(inertia) * np.eye(3) - inertia + mass_kg * np.outer(c, c)
    gram = np.block([[np.array([[mass_kg]]), mass_kg * c[None, :]],
                     [mass_kg * c[:, None], second]])
    unit = np.array([1.0, 0.0, 0.0, 0.0])
    affine = np.vstack([np.zeros(3), np.eye(3)])                     # L = Qᵀ [0; I] = A
    groups = {name: GroupRows(position=np.concatenate([[1.0], np.asarray(x, float)]),
                              affine=affine, span=np.eye(3), center_m=np.asarray(x, float))
              for name, x in points.items()}
    nodes = np.vstack([np.zeros(3), np.eye(3)])
    fields = np.hstack([np.ones((4, 1)), nodes])                      # F Q0 = X at four points
    return make_body(mass=np.kron(gram, np.eye(3)), stiffness=np.zeros((12, 12)), gram=gram,
                     q0=RIGID_Q0.ravel(), unit=unit, centred=RIGID_Q0 - np.outer(unit, c),
                     gravity=np.kron(gram @ unit, np.eye(3).ravel()).reshape(12, 3),
                     groups=groups, node_fields=fields, nodes_m=nodes)


def rigid_twin(body: Body) -> Body:
    """The rigid body of a GCMS body's mass properties — its mass, centre of mass and inertia
    I = tr(J) I₃ − J from its second moment J about the centre — with its node groups' centres
    as named points: the body with its elasticity taken away."""
    J = np.asarray(body.second_moment, float)
    points = {name: group.center_m for name, group in body.groups.items()}
    return rigid_body(body.total_mass_kg, body.center_of_mass(body.q0),
                      np.trace(J) * np.eye(3) - J, points)


class Rigid(Flexible):
    """A rigid body as a member: ``assemble`` adds its :func:`rigidity` rows."""


def rigid_member(name: str, body: Body, rotation: np.ndarray | None = None,
                 position: np.ndarray | None = None) -> Rigid:
    """The rigid body (:func:`rigid_body`) as a member of an assembly, placed
    (``placed_coordinates``)."""
    return Rigid(name, body, placed_coordinates(body, rotation, position))


def rigidity(member: Flexible) -> BilinearRow:
    """The six rows a_i · a_j − δ_ij = 0 that keep a rigid member rigid (module docstring)."""
    e = np.eye(4)
    return BilinearRow(f"{member.name}.rigid",
                       (Term(member.name, np.array([e[1 + i] for i, _ in PAIRS])),
                        Term(member.name, np.array([e[1 + j] for _, j in PAIRS]))),
                       np.zeros((len(PAIRS), 3)), "rigidity")
