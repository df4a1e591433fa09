"""Members of one model stepped together (``dynamics.system.blocks``): the batched co-rotated
states are the single ones, and an assembly whose members share a body steps exactly as the
same assembly with a copy of the body for each member (every member alone).
"""
from __future__ import annotations

import numpy as np
import pytest

from beams import GRAVITY, LENGTH
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.dynamics.stepping.alpha import AlphaParameters, newton_coefficients
from gcms_fenicsx.dynamics.bodies.corotated import elastic_state, elastic_states
from gcms_fenicsx.dynamics.system import rows
from gcms_fenicsx.dynamics.system.assembly import assemble
from gcms_fenicsx.dynamics.system.blocks import Batch, Single
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state
from gcms_fenicsx.numerics.rotation import InvertedBodyError, rotation_about

EPS = float(np.finfo(float).eps)
Y_AXIS = np.array([0.0, 1.0, 0.0])


def configurations(body, count: int, seed: int = 3) -> np.ndarray:
    """``count`` configurations (count, nf, 3): turned, moved and deformed by 1e-3 of the
    body's coordinates' scale in every field."""
    rng = np.random.default_rng(seed)
    Q0, out = body.q0.reshape(-1, 3), []
    for _ in range(count):
        axis = rng.normal(size=3)
        R = rotation_about(axis / np.linalg.norm(axis), rng.uniform(-3, 3))
        out.append(Q0 @ R.T + np.outer(body.unit, rng.normal(size=3))
                   + 1e-3 * np.abs(Q0).max() * rng.normal(size=Q0.shape))
    return np.array(out)


def test_batched_states_are_the_single_ones(beam6_body):
    """Forces and the summed energy of five configurations at once agree with five calls of
    ``elastic_state`` to round-off (the same products in another grouping: measured 2e-16 of
    the largest force), and a reflected configuration among them is refused as ``polar``
    refuses it alone."""
    body = beam6_body
    Q = configurations(body, 5)
    batch = elastic_states(body, Q)
    singles = [elastic_state(body, x.ravel()) for x in Q]
    force = np.concatenate([s.force for s in singles])
    assert np.abs(batch.force - force).max() <= 100 * EPS * np.abs(force).max()
    energy = sum(s.energy for s in singles)
    assert abs(batch.energy - energy) <= 100 * EPS * energy
    assert np.allclose(batch.rotation, [s.rotation for s in singles], rtol=0, atol=100 * EPS)
    Q[3] = Q[3] @ np.diag([1.0, 1.0, -1.0])                   # a mirror image
    with pytest.raises(InvertedBodyError):
        elastic_states(body, Q)


def chain(bodies):
    """Two beams in a chain (a hinged to the ground about y, b joined to a's free end by a
    spherical joint) and a third hinged beam c carrying a point mass at its end; the members
    in the order a, p, b, c, so the beams' coordinates are not contiguous. ``bodies`` gives
    a's, b's and c's body."""
    A, B, C = bodies
    a = Flexible("a", A, A.q0.copy())
    p_at = C.groups["end_xL"].center_m + np.array([0.0, 0.5, 0.0])
    p = PointMass("p", 0.2, p_at)
    b = Flexible("b", B, placed_coordinates(B, rotation_about(Y_AXIS, 0.4),
                                             position=A.groups["end_xL"].center_m
                                             - rotation_about(Y_AXIS, 0.4)
                                             @ B.groups["end_x0"].center_m))
    c = Flexible("c", C, placed_coordinates(C, position=[0.0, 0.5, 0.0]))
    ground_a = A.groups["end_x0"].center_m
    ground_c = ground_a + np.array([0.0, 0.5, 0.0])
    joints = (rows.coincide("hinge_a", rows.group_point(a, "end_x0"), rows.fixed_point(ground_a)),
              rows.keep_axis("hinge_a", a, "end_x0", Y_AXIS),
              rows.coincide("elbow", rows.group_point(a, "end_xL"), rows.group_point(b, "end_x0")),
              rows.coincide("hinge_c", rows.group_point(c, "end_x0"), rows.fixed_point(ground_c)),
              rows.keep_axis("hinge_c", c, "end_x0", Y_AXIS),
              rows.coincide("load", rows.group_point(c, "end_xL"), rows.mass_point(p)))
    return assemble((a, p, b, c), joints, np.array([0.0, 0.0, -GRAVITY]))


def test_members_of_one_body_step_as_each_alone(beam6_model):
    """The chain of three beams of one body (a batch of three on non-contiguous coordinates,
    rows of one joint on two of them) against the chain of three copies of the body (three
    members alone), 0.1 s at h = 1 ms: the same Newton iterations every recorded step, q
    equal to round-off grown over 100 steps (measured 4e-15 L; asserted 1e-12 L) and λ to
    the round-off of q seen through the iteration matrix: a change δq of q moves λ by about
    β' M δq, β' = 1/(β h²) (= 4.0e6 s⁻² here), so round-off ε L in q is β' M L ε in λ
    (3.2e-9 N for the chain's 7.3 kg; measured 22 times that, not shrinking with a Newton
    tolerance of 1e-13: asserted 1e3 times). The energy balance is the same."""
    shared = body_from_reduced(beam6_model)
    together = chain((shared, shared, shared))
    alone = chain(tuple(body_from_reduced(beam6_model) for _ in range(3)))
    assert [type(b) for b in together.blocks] == [Batch, Single]
    assert [m.name for m in together.blocks[0].members] == ["a", "b", "c"]
    assert all(isinstance(b, Single) for b in alone.blocks) and len(alone.blocks) == 4
    settings = StepSettings(1e-3, rho_inf=0.9)
    runs = []
    for assembly in (together, alone):
        stepper = AssemblyStepper(assembly, settings)
        probes = {"q": lambda s: s.q.copy()}
        runs.append(march(stepper, initial_state(stepper), 0.1, every=10, probes=probes))
    one, two = runs
    assert np.array_equal(one.iterations, two.iterations)
    assert np.abs(one.probes["q"] - two.probes["q"]).max() <= 1e-12 * LENGTH
    beta_p, _ = newton_coefficients(AlphaParameters.from_rho_inf(0.9), 1e-3)
    roundoff = beta_p * together.total_mass_kg * LENGTH * EPS
    assert np.abs(two.multipliers).max() > 1e6 * roundoff
    assert np.abs(one.multipliers - two.multipliers).max() <= 1e3 * roundoff
    assert abs(one.energy_drift_rel - two.energy_drift_rel) <= 1e-9
