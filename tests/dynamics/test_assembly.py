"""Assemblies (``dynamics.system``): members, joint rows, the block-wise Newton step, the
energy balance — on the committed six-mode test beam.

- one flexible body in an assembly steps exactly as the single-body integrator does (the same
  scheme and equations: the trajectories agree to round-off, and so do the energy balance
  and the joint forces);
- the rows are what they say: a coincidence row is the group's weighted mean position from
  the nodes (C q = Σ w_i F_i Q), an axis row measures a small rotation about its axis as the
  angle and is blind to turning about the joint's axis;
- rows implied by others are dropped and reported; bad assemblies are refused naming the
  member;
- two flexible bodies joined by a spherical joint (a double pendulum) keep the energy
  balance with ρ∞ = 1, and the joint between them holds to round-off;
- an inconsistent initial velocity is made consistent by its least change in kinetic energy.
"""
from __future__ import annotations

import numpy as np
import pytest

from beams import GRAVITY, LENGTH
from gcms_fenicsx.config.scene import parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_body
from gcms_fenicsx.dynamics.system import rows
from gcms_fenicsx.dynamics.system.assembly import AssemblyError, assemble
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state

EPS = float(np.finfo(float).eps)
Y_AXIS = np.array([0.0, 1.0, 0.0])
DOWN = np.array([0.0, 0.0, -GRAVITY])


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def hinge(body, name="beam"):
    """The beam as one member, hinged about y at its end face x = 0 (a revolute joint)."""
    rod = Flexible(name, body, body.q0.copy())
    x = body.groups["end_x0"].center_m
    return rod, (rows.coincide("hinge", rows.group_point(rod, "end_x0"), rows.fixed_point(x)),
                 rows.keep_axis("hinge", rod, "end_x0", Y_AXIS))


def test_one_body_steps_as_the_single_body_integrator(beam6_body):
    """The revolute pendulum released horizontal under gravity for 0.2 s (ρ∞ = 0.5, h = 1
    ms): the assembly's step (T S₀⁻¹ Tᵀ blocks, Schur complement on λ) and the single body's
    (bordered KKT with the rank-9 frame term) converge to the same generalized-α solution,
    so q agrees to the Newton tolerance (1e-10 of the size; measured 1e-15 L), the
    energy balance to 1e-9 of itself, and the hinge force (the single body's −λ) likewise."""
    body, h = beam6_body, 1e-3
    sc = parse_scene(dict(end_time=0.2, time_step=h, rho_inf=0.5, gravity=DOWN.tolist(),
                          joints=[{"type": "revolute", "group": "end_x0",
                                   "axis": Y_AXIS.tolist(), "name": "hinge"}],
                          outputs={"coordinates": True}))
    traj, summary = simulate_body(body, sc)
    assert summary["complete"], summary["message"]
    rod, joints = hinge(body)
    stepper = AssemblyStepper(assemble((rod,), joints, gravity=DOWN), StepSettings(h, 0.5))
    run = march(stepper, initial_state(stepper), 0.2, probes={"q": lambda s: s.q.copy()})
    assert np.abs(run.probes["q"] - traj.coordinates["q"]).max() <= 1e-10 * LENGTH
    assert run.energy_drift_rel == pytest.approx(summary["energy_drift_rel"], rel=1e-6)
    force = -run.multipliers[:, :3]
    assert np.abs(force - traj.joint_force("hinge")).max() <= 1e-8 * np.abs(force).max()


def test_coincidence_rows_are_the_groups_mean_positions(beam6_model, beam6_body):
    """C q of the three rows of ``coincide`` is Σ w_i x_i over the group's nodes (the reduced
    model's node list and weights), x_i = F_i Q, at a placed and deformed state (the rows are
    linear: this is their Jacobian too)."""
    body = beam6_body
    rng = np.random.default_rng(3)
    q = placed_coordinates(body, rotation_about([1, 2, 3], 0.7), [0.1, -0.2, 0.3])
    q = q + 1e-3 * rng.normal(size=q.shape)
    rod = Flexible("beam", body, q)
    group = beam6_model.groups["end_xL"]
    x = body.node_fields[group.nodes] @ q.reshape(-1, 3)
    C = assemble((rod,), (rows.coincide("tip", rows.group_point(rod, "end_xL"),
                                        rows.fixed_point(group.weights @ x)),)).matrix
    assert np.abs(C @ q - group.weights @ x).max() <= 100 * EPS * np.abs(x).max()


@pytest.mark.parametrize("placed", [0.0, 0.7])
def test_axis_rows_measure_rotations_and_are_blind_to_the_joints_axis(beam6_body, placed):
    """keep_axis about the end face's y direction, on the beam as it is and on the beam placed
    turned by 0.7 rad about (1, 1, 0) (the rows take the group's directions through the
    placement): turning the body further about that axis by 30° leaves both rows as they were
    (to round-off); a small rotation θ = 1e-6 about either axis ⊥ it moves its own row by θ
    (its multiplier is a moment) and the other by O(θ²). About a direction the face does not
    hold (the global y of the turned beam) the joint is refused."""
    body = beam6_body
    R0 = rotation_about([1, 1, 0], placed)
    rod = Flexible("beam", body, placed_coordinates(body, R0))
    axis = R0 @ Y_AXIS
    row = rows.keep_axis("hinge", rod, "end_x0", axis)
    C = assemble((rod,), (row,)).matrix
    g0 = C @ rod.q_start
    turned = placed_coordinates(body, rotation_about(axis, np.pi / 6) @ R0)
    assert np.abs(C @ turned - g0).max() <= 100 * EPS
    theta = 1e-6
    for axis in row.axes:
        change = (C @ placed_coordinates(body, rotation_about(axis, theta) @ R0) - g0) / theta
        own = np.argmax(np.abs(row.axes @ axis))
        assert change[own] == pytest.approx(1.0, abs=1e-6)
        assert abs(change[1 - own]) <= 1e-6
    if placed:
        with pytest.raises(ValueError, match="cannot hold a rotation"):
            rows.keep_axis("hinge", rod, "end_x0", Y_AXIS)


def test_implied_rows_are_dropped_and_reported(beam6_body):
    """A second coincidence at the same group repeats three rows: they are dropped, named."""
    rod, joints = hinge(beam6_body)
    again = rows.coincide("again", rows.group_point(rod, "end_x0"),
                          rows.fixed_point(beam6_body.groups["end_x0"].center_m))
    a = assemble((rod,), joints + (again,))
    assert a.count == 5
    assert [r.joint for r in a.dropped] == ["again"] * 3


def test_bad_assemblies_are_refused_naming_the_member(beam6_body):
    rod, joints = hinge(beam6_body)
    with pytest.raises(AssemblyError, match="distinct names"):
        assemble((rod, Flexible("beam", beam6_body, beam6_body.q0)), joints)
    ghost = PointMass("ghost", 1.0, np.zeros(3))
    with pytest.raises(AssemblyError, match="'ghost', which is not a member"):
        assemble((rod,), joints + (rows.on_line("line", rows.mass_point(ghost), Y_AXIS),))


def double_pendulum(body):
    """Two beams: the first hinged at the ground by a spherical joint at its end x = 0, the
    second's end x = 0 joined to the first's end x = L by another; both horizontal at rest."""
    upper = Flexible("upper", body, body.q0.copy())
    lower = Flexible("lower", body, placed_coordinates(body, position=[LENGTH, 0.0, 0.0]))
    return assemble((upper, lower), (
        rows.coincide("ground", rows.group_point(upper, "end_x0"),
                      rows.fixed_point(body.groups["end_x0"].center_m)),
        rows.coincide("elbow", rows.group_point(upper, "end_xL"),
                      rows.group_point(lower, "end_x0"))), gravity=DOWN)


def test_two_flexible_bodies_keep_the_energy_balance(beam6_body):
    """The double pendulum falls for 0.3 s with ρ∞ = 1 (no numerical dissipation), h = 0.5 ms:
    the energy balance holds to 1e-4 of the motion's energy (the trapezoidal work of the rows,
    zero here, and the scheme's O(h²) energy error), the elbow's two groups stay together to
    round-off, and the lower beam swings through (it gains kinetic energy)."""
    a = double_pendulum(beam6_body)
    stepper = AssemblyStepper(a, StepSettings(5e-4, 1.0))
    upper, lower = a.offsets["upper"], a.offsets["lower"]
    tip, root = beam6_body.groups["end_xL"].position, beam6_body.groups["end_x0"].position
    gap = lambda s: tip @ s.q[upper].reshape(-1, 3) - root @ s.q[lower].reshape(-1, 3)
    run = march(stepper, initial_state(stepper), 0.3, probes={"gap": gap})
    assert run.energy_drift_rel <= 1e-4, run.energy_drift_rel
    assert np.abs(run.probes["gap"]).max() <= 1e3 * EPS * LENGTH
    assert run.energy["kinetic"][-1] > 0.1 * run.energy["kinetic"].max()
    assert abs(run.energy["row_work"]).max() <= 1e-9 * run.energy["kinetic"].max()


def test_an_inconsistent_start_velocity_is_made_consistent(beam6_body):
    """A velocity that moves the hinge (the beam translating along z) is projected onto the
    rows (Cq̇ = ḋ = 0) by its least change in kinetic energy; the change is reported — less
    than the rigid beam's 1/2 (the nearest rigid swing about the hinge, ω = 3v/2L, keeps
    √(3/4) of the norm), since the flexible fields take part — and a consistent velocity
    is left alone."""
    rod, joints = hinge(beam6_body)
    stepper = AssemblyStepper(assemble((rod,), joints), StepSettings(1e-3))
    v = beam6_body.rigid_velocity(beam6_body.q0, [0.0, 0.0, 1.0], np.zeros(3))
    state, change = initial_state(stepper, v)
    assert np.abs(stepper.assembly.matrix @ state.v).max() <= 1e-12
    assert 0.05 < change < 0.5
    swing = beam6_body.rigid_velocity(beam6_body.q0, [0.0, 0.0, -LENGTH / 2], Y_AXIS)
    state, change = initial_state(stepper, swing)
    assert change <= 1e-12 and np.allclose(state.v, swing, atol=1e-14)
