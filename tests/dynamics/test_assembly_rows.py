"""Assembly rows beyond the linear ones (``dynamics.system.rows``): driven and bilinear rows,
their Jacobians and rates against finite differences, and what they hold in a run.

- every kind of row — coincidence of two groups and of a group with a moving path, a point
  on a line, an axis kept along a fixed axis, a drive, two groups' axes kept parallel and
  their turning about it held, a point mass and a group on a line that turns and bends with
  another member's group — has
  C = ∂g/∂q (the Jacobian the Newton step uses) equal to central differences of g at a
  random deformed state of two placed members, and the second derivative of g along
  q(τ) = q + τ q̇ + ½ τ² q̈ equal to C q̈ − γ (its ``rates``, which the initial state uses);
- one beam turned by a drive about y steps exactly as the single-body driven revolute joint
  (the same rows: 1e-15 of the length);
- a double pendulum hinged about y (a revolute joint to the ground, a revolute joint between
  the beams: coincidence plus two bilinear rows) pushed sideways stays in its plane but for
  the beams' elastic deflection, where with a spherical joint between the beams it swings
  out of it; its energy balance holds.
"""
from __future__ import annotations

import numpy as np
import pytest

from beams import GRAVITY, LENGTH
from gcms_fenicsx.config.scene import Drive, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_body
from gcms_fenicsx.dynamics.system import relative_rows, rows
from gcms_fenicsx.dynamics.system.assembly import assemble
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state

EPS = float(np.finfo(float).eps)
Y_AXIS = np.array([0.0, 1.0, 0.0])
DOWN = np.array([0.0, 0.0, -GRAVITY])


def turn(axis, angle: float) -> np.ndarray:
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def hanging(body):
    """Two beams: ``upper`` along x from the origin, ``lower`` hanging from its end along −z
    (turned 90° about y), so the lower beam's top face extends along x and y."""
    upper = Flexible("upper", body, body.q0.copy())
    lower = Flexible("lower", body, placed_coordinates(body, turn(Y_AXIS, np.pi / 2),
                                                       [LENGTH, 0.0, 0.0]))
    return upper, lower


def every_kind(body):
    """An assembly with one joint of every kind on two beams and a point mass."""
    upper, lower = hanging(body)
    mass = PointMass("bob", 0.3, [0.0, 0.2, 0.0])
    bead = PointMass("bead", 0.1, [0.3, 0.01, -0.02])
    pin = rows.circle_path([0.0, -0.1, 0.0], body.groups["end_x0"].center_m, [0.0, 0.0, 1.0],
                           7.0)
    return assemble((upper, lower, mass, bead), (
        rows.coincide("elbow", rows.group_point(upper, "end_xL"),
                      rows.group_point(lower, "end_x0")),
        rows.coincide("crank", rows.group_point(upper, "end_x0"), pin),
        rows.on_line("guide", rows.mass_point(mass), [1.0, 1.0, 0.0]),
        rows.keep_axis("tilt", upper, "end_x0", Y_AXIS),
        rows.drive("spin", lower, "end_xL", [0.0, 0.0, 1.0],
                   Drive(angular_velocity=3.0, ramp_time_s=0.5)),
        relative_rows.align_axes("hinge", upper, "end_xL", lower, "end_x0", Y_AXIS),
        relative_rows.hold_turn("weld", upper, "end_xL", lower, "end_x0", Y_AXIS),
        relative_rows.on_member_line("rail", upper, "end_x0", rows.mass_point(bead),
                                     [1.0, 0.0, 0.0]),
        relative_rows.on_member_line("sleeve", lower, "end_xL",
                                     rows.group_point(upper, "end_x0"), [0.0, 0.0, 1.0])))


def test_every_rows_jacobian_and_rates_are_their_finite_differences(beam6_body):
    a = every_kind(beam6_body)
    assert a.count == 3 + 3 + 2 + 2 + 1 + 2 + 1 + 2 + 2 and not a.dropped and not a.constant
    rng = np.random.default_rng(5)
    q = a.q_start + 1e-3 * rng.normal(size=a.dofs)
    v, acc = rng.normal(size=a.dofs), rng.normal(size=a.dofs)
    t, h = 0.3, 1e-6
    C = a.jacobian(q, t)
    differences = np.empty_like(C)
    for j in range(a.dofs):
        step = np.zeros(a.dofs)
        step[j] = h
        differences[:, j] = (a.defined_residual(q + step, t)
                              - a.defined_residual(q - step, t)) / (2 * h)
    assert np.abs(C - differences).max() <= 1e-7 * np.abs(C).max()
    g = a.defined_residual(q, t)            # the fast residual: C q − d(t) for linear rows
    assert np.abs(a.residual(q, t) - g).max() <= 1e3 * EPS * np.abs(C).max() * np.abs(q).max()
    rate, gamma = a.rates(q, v, t)

    def along(tau: float) -> list[np.ndarray]:
        return [a.defined_residual(q + s * v + 0.5 * s * s * acc, t + s)
                for s in (-tau, 0.0, tau)]

    # truncation ~ tau^2 |d3g| / 6 (the bilinear rows: 2e-7 at tau = 1e-6, 2e-9 at 1e-7,
    # measured) and round-off ~ eps |g| / tau (2e-9 at 1e-7, |g| < 1): at tau = 1e-7 both
    # about 1e-11 of the largest |C q̇| (5e2), asserted 1e-9
    first = along(1e-7)
    slope = C @ v + rate
    assert np.abs((first[2] - first[0]) / 2e-7 - slope).max() <= 1e-9 * np.abs(slope).max()
    g = along(1e-3)              # truncation ~ tau^2 |d4g| ~ 1e-5, round-off ~ eps |g| / tau^2
    second = (g[2] - 2 * g[1] + g[0]) / 1e-6
    assert np.abs(second - (C @ acc - gamma)).max() <= 1e-4 * np.abs(second).max()


def test_a_driven_beam_steps_as_the_single_body_driven_revolute(beam6_body):
    """The beam turned about y at its end face by a drive (0.4 rad/s reached over 0.2 s) under
    gravity for 0.3 s: the assembly (coincidence, keep_axis, drive) and the single body's
    driven revolute joint have the same rows, so the same trajectory to 1e-10 of the length
    (measured at round-off) and the drive moment of the same size."""
    body, h = beam6_body, 1e-3
    drive = {"angular_velocity": 0.4, "ramp_time": 0.2}
    sc = parse_scene(dict(end_time=0.3, time_step=h, rho_inf=0.5, gravity=DOWN.tolist(),
                          joints=[{"type": "revolute", "group": "end_x0", "name": "motor",
                                   "axis": Y_AXIS.tolist(), "drive": drive}],
                          outputs={"coordinates": True}))
    traj, summary = simulate_body(body, sc)
    assert summary["complete"], summary["message"]
    beam = Flexible("beam", body, body.q0.copy())
    a = assemble((beam,), (
        rows.coincide("motor", rows.group_point(beam, "end_x0"),
                      rows.fixed_point(body.groups["end_x0"].center_m)),
        rows.keep_axis("motor", beam, "end_x0", Y_AXIS),
        rows.drive("motor", beam, "end_x0", Y_AXIS, Drive(0.4, 0.2))), gravity=DOWN)
    stepper = AssemblyStepper(a, StepSettings(h, 0.5))
    run = march(stepper, initial_state(stepper), 0.3, probes={"q": lambda s: s.q.copy()})
    assert np.abs(run.probes["q"] - traj.coordinates["q"]).max() <= 1e-10 * LENGTH
    assert run.energy_drift_rel == pytest.approx(summary["energy_drift_rel"], rel=1e-6)


def double_pendulum(body, hinge: bool):
    """The upper beam hinged about y at the ground, the lower hanging from its end by a revolute
    joint about y (``hinge``) or a spherical one, gravity −z; and a steady push of 5 N along y
    at the lower beam's tip (a load: t ↦ its generalized force)."""
    upper, lower = hanging(body)
    joints = (rows.coincide("root", rows.group_point(upper, "end_x0"),
                            rows.fixed_point(body.groups["end_x0"].center_m)),
              rows.keep_axis("root", upper, "end_x0", Y_AXIS),
              rows.coincide("elbow", rows.group_point(upper, "end_xL"),
                            rows.group_point(lower, "end_x0")))
    if hinge:
        joints += (relative_rows.align_axes("elbow", upper, "end_xL", lower, "end_x0", Y_AXIS),)
    a = assemble((upper, lower), joints, gravity=DOWN)
    push = np.zeros(a.dofs)
    push[a.offsets["lower"]] = np.outer(body.groups["end_xL"].position, 5.0 * Y_AXIS).ravel()
    return a, lambda t: push


@pytest.mark.parametrize("hinge", [True, False])
def test_a_revolute_joint_between_two_beams_keeps_them_in_their_plane(beam6_body, hinge):
    """0.2 s at h = 0.5 ms, ρ∞ = 1, the lower tip pushed along y: with the hinge it leaves the
    plane y = 0 only by the beams' elastic bending and the upper beam's twist (F L³/3EI and
    F L² / GJ · L: about 4e-4 L static, twice that under a push applied at once; bound 1e-3 L,
    measured 7.1e-4 L) and the hinge's rows hold to the Newton tolerance (5e-12); with a
    spherical joint the lower beam swings out (0.25 L; bound 1e-2 L). The energy balance (with
    the push's work) holds to 1e-4 either way (measured 2e-6)."""
    a, push = double_pendulum(beam6_body, hinge)
    stepper = AssemblyStepper(a, StepSettings(5e-4, 1.0), loads=push)
    tip = beam6_body.groups["end_xL"].position
    lower = a.offsets["lower"]
    run = march(stepper, initial_state(stepper), 0.2,
                probes={"tip": lambda s: tip @ s.q[lower].reshape(-1, 3),
                        "rows": lambda s: a.residual(s.q, s.t)})
    out_of_plane = np.abs(run.probes["tip"][:, 1]).max()
    assert run.energy_drift_rel <= 1e-4, run.energy_drift_rel
    assert np.abs(run.energy["load_work"]).max() > 0
    if hinge:
        assert out_of_plane <= 1e-3 * LENGTH, out_of_plane / LENGTH
        assert np.abs(run.probes["rows"]).max() <= 1e-8
    else:
        assert out_of_plane > 1e-2 * LENGTH, out_of_plane / LENGTH


def test_a_bead_on_a_swinging_beams_line_balances_its_energy(beam6_body):
    """A point mass (0.2 kg) on the line along a swinging beam's axis through its free end
    (``on_member_line``: the line turns and bends with the end face): the beam hinged about y
    at the ground, released horizontally under gravity with the bead at its tip, 0.3 s at
    h = 0.5 ms, ρ∞ = 1. The bead stays on the line (its two rows to the Newton tolerance,
    asserted 1e-8 m) while it slides outwards, and the energy balance — kinetic, elastic,
    gravity, no work by the frictionless line — holds to 1e-4 (measured 2.2e-6; the rows to
    7e-14 m, the bead slid 0.74 m)."""
    beam = Flexible("beam", beam6_body, beam6_body.q0.copy())
    tip = beam6_body.groups["end_xL"]
    bead = PointMass("bead", 0.2, tip.center_m)
    a = assemble((beam, bead), (
        rows.coincide("root", rows.group_point(beam, "end_x0"),
                      rows.fixed_point(beam6_body.groups["end_x0"].center_m)),
        rows.keep_axis("root", beam, "end_x0", Y_AXIS),
        relative_rows.on_member_line("rail", beam, "end_xL", rows.mass_point(bead),
                                     [1.0, 0.0, 0.0])), gravity=DOWN)
    stepper = AssemblyStepper(a, StepSettings(5e-4, 1.0))
    where = a.offsets["bead"]
    run = march(stepper, initial_state(stepper), 0.3,
                probes={"rows": lambda s: a.residual(s.q, s.t),
                        "bead": lambda s: s.q[where].copy()})
    slid = np.linalg.norm(run.probes["bead"][-1] - run.probes["bead"][0])
    assert run.energy_drift_rel <= 1e-4, run.energy_drift_rel
    assert np.abs(run.probes["rows"]).max() <= 1e-8
    assert slid > 0.1 * LENGTH
