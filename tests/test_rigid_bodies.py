"""Rigid bodies in natural coordinates (``dynamics.system.rigid``): twelve coordinates, a
constant mass matrix and six rigidity rows.

- the rigid slider crank of the IVP Test Set — a rigid crank driven at 150 rad/s, a rigid
  conrod joined to it by a revolute joint (a coincidence and two bilinear rows), a slider on
  its line — follows the closed form (``slider_crank_assembly.rigid_closed_form``, the
  conrod's own mass and inertia): the slider's position to round-off (the rows hold the
  rigid kinematics exactly; bound 1e-12 of the stroke) and the force at the slider pin to
  1e-4 of its peak from 2 ms on (measured 3e-5 at h = 50 µs: the step's error, of the order
  of (Ω h)² = 6e-5; before, the index-3 generalized-α multipliers' start transient, 1.3e-3
  at 1 ms, 5e-6 at h = 20 µs); the row the others imply (the guide's out-of-plane one)
  dropped, never a rigidity row;
- a rigid body turning freely about its axis of largest inertia with a small wobble keeps
  AᵀA = I to the Newton tolerance, its kinetic energy (ρ∞ = 1) and its angular momentum;
- a bad mass or inertia tensor is refused saying which.
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.config.scene import Drive
from gcms_fenicsx.dynamics.system import relative_rows, rows
from gcms_fenicsx.dynamics.system.assembly import assemble
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.members import PointMass
from gcms_fenicsx.dynamics.system.rigid import rigid_body, rigid_member
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state
from gcms_fenicsx.references import slider_crank as ref
from gcms_fenicsx.references.slider_crank_assembly import rigid_reference

Z = np.array([0.0, 0.0, 1.0])


def bar(mass: float, length: float, width: float, height: float):
    """A uniform bar along x from 0 to ``length``: its ends ``a`` and ``b`` as points."""
    inertia = mass / 12 * np.diag([width ** 2 + height ** 2, length ** 2 + height ** 2,
                                   length ** 2 + width ** 2])
    return rigid_body(mass, [length / 2, 0.0, 0.0], inertia,
                      {"a": [0.0, 0.0, 0.0], "b": [length, 0.0, 0.0]})


@pytest.mark.slow
def test_the_rigid_slider_crank_is_its_closed_form():
    crank_body, rod_body = bar(ref.M1, ref.L1, 0.02, 0.01), bar(ref.M2, ref.L2, ref.B, ref.H)
    crank = rigid_member("crank", crank_body)
    rod = rigid_member("conrod", rod_body, position=[ref.L1, 0.0, 0.0])
    slider = PointMass("slider", ref.M3, [ref.L1 + ref.L2, 0.0, 0.0])
    a = assemble((crank, rod, slider), (
        rows.coincide("pivot", rows.group_point(crank, "a"), rows.fixed_point(np.zeros(3))),
        rows.keep_axis("pivot", crank, "a", Z),
        rows.drive("pivot", crank, "a", Z, Drive(ref.OMEGA)),
        rows.coincide("crank_pin", rows.group_point(rod, "a"), rows.group_point(crank, "b")),
        relative_rows.align_axes("crank_pin", rod, "a", crank, "b", Z),
        rows.coincide("slider_pin", rows.group_point(rod, "b"), rows.mass_point(slider)),
        rows.on_line("guide", rows.mass_point(slider), [1.0, 0.0, 0.0])))
    assert [(r.joint, r.axis) for r in a.dropped] == [("guide", (0.0, 0.0, 1.0))]
    spin = crank_body.rigid_velocity(crank.q_start, ref.OMEGA * np.cross(Z, [ref.L1 / 2, 0, 0]),
                                     ref.OMEGA * Z)
    omega = -ref.OMEGA * ref.L1 / ref.L2
    swing = rod_body.rigid_velocity(rod.q_start, [0.0, ref.OMEGA * ref.L1 + omega * ref.L2 / 2,
                                                  0.0], omega * Z)
    stepper = AssemblyStepper(a, StepSettings(5e-5, 0.8))
    start = initial_state(stepper, np.concatenate([spin, swing, np.zeros(3)]))
    assert start[1] <= 1e-12
    where = a.offsets["slider"]
    run = march(stepper, start, 0.1, every=20, probes={"slider": lambda s: s.q[where][0]})
    rigid = rigid_reference(rod_body, run.time_s, pin="a")
    assert np.abs(run.probes["slider"] - rigid["slider_m"]).max() <= 1e-12 * 2 * ref.L1
    pin = [i for i, r in enumerate(a.rows) if r.joint == "slider_pin"][:2]
    late = run.time_s >= 2e-3
    force = -run.multipliers[late][:, pin]
    peak = np.abs(rigid["pin_force_n"]).max(axis=0)
    assert (np.abs(force - rigid["pin_force_n"][late]).max(axis=0) <= 1e-4 * peak).all()


def test_a_free_rigid_body_stays_rigid_and_keeps_its_energy_and_momentum():
    body = rigid_body(2.0, [0.1, -0.2, 0.05], np.diag([0.02, 0.03, 0.045]), {})
    member = rigid_member("top", body, rotation=np.eye(3), position=[1.0, 2.0, 3.0])
    a = assemble((member,), ())
    assert a.count == 6
    omega = np.array([0.3, -0.2, 20.0])
    v = body.rigid_velocity(member.q_start, [0.5, 0.0, 0.0], omega)
    stepper = AssemblyStepper(a, StepSettings(1e-4, 1.0))
    Q = lambda s: s.q.reshape(4, 3)                                   # noqa: E731
    run = march(stepper, initial_state(stepper, v), 0.1,
                probes={"AtA": lambda s: Q(s)[1:] @ Q(s)[1:].T,
                        "L": lambda s: body.momenta(Q(s)[None], s.v.reshape(1, 4, 3))[2][0]})
    assert np.abs(run.probes["AtA"] - np.eye(3)).max() <= 1e-8
    kinetic = run.energy["kinetic"]
    assert np.abs(kinetic - kinetic[0]).max() <= 1e-6 * kinetic[0]
    momentum = run.probes["L"]
    assert np.abs(momentum - momentum[0]).max() <= 1e-6 * np.linalg.norm(momentum[0])


def test_a_bad_mass_or_inertia_is_refused():
    with pytest.raises(ValueError, match="mass_kg must be a finite number > 0"):
        rigid_body(0.0, np.zeros(3), np.eye(3), {})
    with pytest.raises(ValueError, match="principal"):
        rigid_body(1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0]), {})
