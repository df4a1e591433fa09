"""What the assembly API refuses, and how (``dynamics.system``; a hostile user's probes).

Every refusal is a ValueError (AssemblyError for the assembly as a whole, IntegrationError
for a step) that names the argument or joint, the value and what is allowed; the inputs that
used to run silently into wrong results are among them: a coincidence whose points do not
start together (its rows would keep the gap), a drive or path whose motion other joints
already hold (it would be dropped as redundant), a point mass of mass ≤ 0, a placement that is
not a rotation, a cylinder direction that is not a unit vector, a ρ∞ outside [0, 1], loads of
the wrong shape. A flexible member with no joint floats freely, and a Newton that diverges
says when, not which matrix failed.
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.config.scene import Drive
from gcms_fenicsx.dynamics.stepping.errors import IntegrationError
from gcms_fenicsx.dynamics.system import rows
from gcms_fenicsx.dynamics.system.assembly import AssemblyError, assemble
from gcms_fenicsx.dynamics.system.gas_pressure import Cylinder, firing_angles, petrol_full_load
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
from gcms_fenicsx.dynamics.system.rigid import rigid_body
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state

Y = np.array([0.0, 1.0, 0.0])


@pytest.fixture
def hinged(beam6_body):
    """(the beam, its hinge rows about y at end_x0)."""
    rod = Flexible("rod", beam6_body, beam6_body.q0.copy())
    root = rows.fixed_point(beam6_body.groups["end_x0"].center_m)
    return rod, (rows.coincide("hinge", rows.group_point(rod, "end_x0"), root),
                 rows.keep_axis("hinge", rod, "end_x0", Y))


def test_points_that_do_not_meet_are_refused(hinged):
    rod, joints = hinged
    away = rows.coincide("hinge", rows.group_point(rod, "end_x0"), rows.fixed_point([1, 0, 0]))
    with pytest.raises(AssemblyError, match=r"'hinge': its points are \[-1.0, 0.0, 0.0\] m apart"):
        assemble((rod,), (away,))
    crank = rows.circle_path([0, 0, 0], [0.1, 0, 0], [0, 0, 1], 10.0)
    with pytest.raises(AssemblyError, match="'crank': its points are"):
        assemble((rod,), (rows.coincide("crank", rows.group_point(rod, "end_x0"), crank),))
    with pytest.raises(ValueError, match="joined to itself"):
        rows.coincide("self", rows.group_point(rod, "end_x0"), rows.group_point(rod, "end_x0"))


def test_a_prescribed_motion_other_joints_hold_is_refused(hinged):
    rod, joints = hinged
    spin = rows.drive("spin", rod, "end_x0", [0, 0, 1], Drive(10.0, 0.01))
    with pytest.raises(AssemblyError, match="'spin': the motion it prescribes is held"):
        assemble((rod,), joints + (spin,))
    twice = (rows.drive("a", rod, "end_x0", Y, Drive(10.0)), rows.drive("b", rod, "end_x0", Y,
                                                                         Drive(20.0)))
    with pytest.raises(AssemblyError, match="'b': the motion it prescribes is held"):
        assemble((rod,), joints[:1] + twice)
    again = rows.coincide("again", rows.group_point(rod, "end_x0"),
                          rows.fixed_point(rod.body.groups["end_x0"].center_m))
    assert [r.joint for r in assemble((rod,), joints + (again,)).dropped] == ["again"] * 3


@pytest.mark.parametrize("make, says", [
    (lambda b: PointMass("p", 0.0, [0, 0, 0]), "'p': mass \\(kg\\) must be a finite number > 0"),
    (lambda b: PointMass("p", np.nan, [0, 0, 0]), "must be a finite number > 0"),
    (lambda b: PointMass("p", 1.0, [0, 0]), "position \\(m\\) must be 3 finite numbers"),
    (lambda b: placed_coordinates(b, 2 * np.eye(3)), "rotation must be a rotation matrix"),
    (lambda b: placed_coordinates(b, np.diag([1.0, 1.0, -1.0])), "det R = \\+1"),
    (lambda b: StepSettings(0.0), "time_step_s \\(s\\) must be a finite number > 0"),
    (lambda b: StepSettings(1e-3, rho_inf=1.2), r"rho_inf must be in \[0, 1\]"),
    (lambda b: StepSettings(1e-3, rho_inf=np.nan), r"rho_inf must be in \[0, 1\]"),
    (lambda b: StepSettings(1e-3, max_iterations=0), "max_iterations must be a whole number"),
    (lambda b: rows.on_line("g", rows.Point("p", np.ones(1), "p"), [0, 0, 0]),
     "'g': its axis must be a non-zero direction"),
    (lambda b: rows.circle_path([0, 0, 0], [1, 0, 0], [np.nan, 0, 1], 1.0), "axis must be"),
    (lambda b: rows.group_point(Flexible("r", b, b.q0), "end_xx"),
     "member 'r' has no group 'end_xx'; its groups are \\['end_x0', 'end_xL'\\]"),
    (lambda b: rows.keep_axis("k", PointMass("p", 1.0, [0, 0, 0]), "end_x0", Y), "point mass"),
    (lambda b: rigid_body(1.0, [0, 0, 0], np.diag([1.0, 1.0, 2.0]), {}), "each less than"),
    (lambda b: rigid_body(1.0, [0, 0, 0], np.ones(3), {}), "3 × 3 tensor"),
    (lambda b: Cylinder("p", 0.08, np.array([-10.0, 0, 0]), 0.0, petrol_full_load()),
     "towards_crank must be a unit vector"),
    (lambda b: Cylinder("p", -0.08, np.array([-1.0, 0, 0]), 0.0, petrol_full_load()),
     "bore_m must be a finite number > 0"),
    (lambda b: petrol_full_load(compression_ratio=0.5), "compression_ratio must be > 1"),
    (lambda b: petrol_full_load(spark_deg=400), "spark_deg"),
    (lambda b: petrol_full_load(step_deg=0), "step_deg"),
    (lambda b: firing_angles(()), "every cylinder"),
])
def test_bad_inputs_are_refused_naming_them(beam6_body, make, says):
    with pytest.raises(ValueError, match=says):
        make(beam6_body)


def test_bad_run_settings_are_refused(hinged):
    """Settings of a run that cannot be (a velocity of the wrong length, a negative end time, a
    record spacing of 0, loads of the wrong shape, an unknown member, a step in µs given in s),
    and the end of a run at the first step at or past its end time."""
    rod, joints = hinged
    a = assemble((rod,), joints)
    stepper = AssemblyStepper(a, StepSettings(1e-3))
    with pytest.raises(ValueError, match="velocity .* must be 66 finite numbers"):
        initial_state(stepper, np.zeros(10))
    start = initial_state(stepper)
    with pytest.raises(ValueError, match="end_time_s \\(s\\) must be a finite number > 0"):
        march(stepper, start, -0.01)
    with pytest.raises(ValueError, match="every must be a whole number ≥ 1"):
        march(stepper, start, 0.01, every=0)
    with pytest.raises(ValueError, match="loads\\(t\\) must give 66 finite numbers"):
        AssemblyStepper(a, StepSettings(1e-3), loads=lambda t: 1.0)
    with pytest.raises(ValueError, match="has no member 'nope'"):
        a.member("nope")
    assert march(stepper, start, 0.0025).steps == 3          # the first step at or past it
    with pytest.raises(IntegrationError, match="member 'rod': its iteration matrix .* "
                                               "time_step_s = 20 s: the step is far too large"):
        AssemblyStepper(a, StepSettings(20.0))


def test_a_free_member_floats_and_a_diverging_newton_says_when(beam6_body, hinged):
    free = Flexible("free", beam6_body, beam6_body.q0.copy())
    stepper = AssemblyStepper(assemble((free,), (), gravity=[0, 0, -9.81]), StepSettings(1e-3))
    run = march(stepper, initial_state(stepper), 0.01)
    assert run.energy_drift_rel <= 1e-6
    rod, joints = hinged
    a = assemble((rod,), joints)
    tip = np.zeros(a.dofs)
    tip[:] = np.outer(beam6_body.groups["end_xL"].position, [0.0, 0.0, 5e5]).ravel()
    stepper = AssemblyStepper(a, StepSettings(2e-2), loads=lambda t: tip)
    with pytest.raises(IntegrationError, match="(Newton (diverged|did not converge)) at t = ") \
            as stopped:
        march(stepper, initial_state(stepper), 0.2)
    run = stopped.value.run                  # StoppedEarly: the rows up to the failed step
    assert not run.complete and run.message == str(stopped.value)
    assert run.time_s[-1] < stopped.value.time_s and len(run.time_s) == run.steps + 1
