"""A flexible member in the rotor basis (``dynamics.system.rotor_member``): its rows' solved
columns are the solves of Bᵀ kron(v, u), its rows' Jacobian is the derivative of their
values in its rotor coordinates, and a placement the rotor basis cannot hold is refused.
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.dynamics.bases.rotor_basis import mode_fields
from gcms_fenicsx.dynamics.bodies.body import elastic_modes
from gcms_fenicsx.dynamics.bodies.rotor import rotor_body
from gcms_fenicsx.dynamics.system import rows
from gcms_fenicsx.dynamics.system.assembly import assemble
from gcms_fenicsx.dynamics.system.members import Flexible
from gcms_fenicsx.dynamics.system.relative_rows import BilinearRow
from gcms_fenicsx.dynamics.system.rotor_member import rotor_member
from gcms_fenicsx.numerics.rotation import rotation_about
from test_rotor import deformed

EPS = float(np.finfo(float).eps)
AXIS = np.array([0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def beam_rotor(beam6_body):
    """The test beam's rotor body about y, its six elastic modes."""
    return rotor_body(beam6_body, AXIS, mode_fields(elastic_modes(beam6_body)[1], 6))


def hinged(rotor):
    """The beam in the rotor basis hinged about y at end_x0, with a second beam (full basis)
    joined at its free end by a spherical joint and a bilinear row (their x directions kept
    at right angles): linear rows and rows whose directions turn with both."""
    beam = rotor_member("beam", rotor)
    body = rotor.full
    tip = body.groups["end_xL"].center_m
    arm = Flexible("arm", body, (body.q0.reshape(-1, 3) @ rotation_about(AXIS, np.pi / 2).T
                                 + np.outer(body.unit, tip)).ravel())
    x0 = body.groups["end_x0"].center_m
    across = BilinearRow("square", (rows.Term("beam", rows.group_vector(beam, "end_xL", [1, 0, 0])[None]),
                                    rows.Term("arm", rows.group_vector(arm, "end_x0", [0, 0, 1])[None])),
                         np.zeros((1, 3)), "moment")
    joints = (rows.coincide("hinge", rows.group_point(beam, "end_x0"), rows.fixed_point(x0)),
              rows.keep_axis("hinge", beam, "end_x0", AXIS),
              rows.coincide("elbow", rows.group_point(beam, "end_xL"),
                            rows.group_point(arm, "end_x0")), across)
    return assemble((beam, arm), joints, np.array([0.0, 0.0, -9.81]))


def test_the_rows_solved_columns_are_the_solves_of_their_rows(beam_rotor):
    """At a turned and deformed state: each solved row column T S₀⁻¹ Tᵀ Bᵀ kron(v, u) made
    from the columns solved once (turned by Rᵀ, then by T) equals the member's solve of
    Bᵀ kron(v, u) itself, to round-off of the solve (measured 1e-16 of the largest)."""
    a = hinged(beam_rotor)
    member = a.member("beam")
    rng = np.random.default_rng(5)
    p = deformed(beam_rotor, rng, 1e-4)
    U = np.array([[0.3, -0.5, 0.8], [1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    V = a.member_rows["beam"].vectors[:3]
    at = member.iteration(4e6, V)(member.state(p))
    columns = at.rows(U)
    for i in range(3):
        row = beam_rotor.coordinates.T @ np.kron(V[i], U[i])
        solved = at.solve(row)
        assert np.abs(columns[:, i] - solved).max() <= 1e3 * EPS * np.abs(solved).max()


def test_the_jacobian_in_rotor_coordinates_is_the_rows_derivative(beam_rotor):
    """C = ∂g/∂x over both members (the beam's rotor coordinates, the arm's GCMS ones) by
    central differences at a deformed, turned state: agreement to the differences' error
    (step 1e-6: their round-off, ε |g| / step, measured 1.3e-12 of
    C's largest entry, asserted 1e-9)."""
    a = hinged(beam_rotor)
    rng = np.random.default_rng(9)
    q = a.q_start.copy()
    q[a.offsets["beam"]] = deformed(beam_rotor, rng, 1e-4)
    q[a.offsets["arm"]] += 1e-4 * rng.normal(size=a.member("arm").dofs)
    C = a.jacobian(q, 0.0)
    step = 1e-6
    numeric = np.column_stack([(a.defined_residual(q + step * e, 0.0)
                                - a.defined_residual(q - step * e, 0.0))
                               / (2 * step) for e in np.eye(a.dofs)])
    assert np.abs(C - numeric).max() <= 1e-9 * np.abs(C).max()


def test_a_placement_the_rotor_basis_cannot_hold_is_refused(beam_rotor):
    """Turned about its axis (y) it is placed; turned about x it is refused naming the axis."""
    turned = rotor_member("beam", beam_rotor, rotation_about(AXIS, 0.7), [0.1, 0.2, 0.3])
    q = turned.fields(turned.q_start).ravel()
    expected = (beam_rotor.full.q0.reshape(-1, 3) @ rotation_about(AXIS, 0.7).T
                + np.outer(beam_rotor.full.unit, [0.1, 0.2, 0.3])).ravel()
    assert np.abs(q - expected).max() <= 1e3 * EPS * np.abs(expected).max()
    with pytest.raises(ValueError, match=r"rotor basis about \[0.0, 1.0, 0.0\].*that axis only"):
        rotor_member("beam", beam_rotor, rotation_about(np.array([1.0, 0.0, 0.0]), 0.7))
