"""Redundant joints: rows another joint already imposes are dropped when the constraints are
built (``joints.independent_rows``), reported, and the motion is the one of the joint alone;
a drive that another joint contradicts is bad input.

The body is the six-mode test beam of ``beams`` (30 × 20 mm, 0.5 m), read from its committed
reduced.h5; every joint is on its end face ``end_x0``.
"""
from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from gcms_fenicsx.dynamics.constraints.joints import build_constraints, independent_rows
from gcms_fenicsx.config.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_body

EPS = np.finfo(float).eps


@pytest.fixture(scope="module")
def body(beam6_body):
    return beam6_body


def joint(kind: str, name: str, **keys) -> dict:
    return {"type": kind, "group": "end_x0", "name": name, **keys}


def swing(joints: list[dict]):
    """50 ms under gravity, the beam started turning about z (a motion every joint here
    allows only in part: the swing and the sag exercise every joint row)."""
    return parse_scene({"end_time": 0.05, "time_step": 1e-3, "gravity": [0.0, 0.0, -9.81],
                        "initial": {"angular_velocity": [0.0, 0.0, 2.0]}, "joints": joints,
                        "outputs": {"groups": ["end_x0", "end_xL"], "coordinates": True}})


REDUNDANT = {
    "two spherical": ([joint("spherical", "a"), joint("spherical", "b")],
                      [joint("spherical", "a")]),
    "revolute + spherical": ([joint("revolute", "a", axis=[0, 1, 0]), joint("spherical", "b")],
                             [joint("revolute", "a", axis=[0, 1, 0])]),
    "two fixed": ([joint("fixed", "a"), joint("fixed", "b")], [joint("fixed", "a")]),
    "fixed + revolute": ([joint("fixed", "a"), joint("revolute", "b", axis=[0, 0, 1])],
                         [joint("fixed", "a")]),
}


def described(rows) -> list[tuple]:
    """What the rows constrain, without the joint names."""
    return [(r["kind"], tuple(np.round(r["axis"], 12))) for r in rows]


@pytest.mark.parametrize("case", REDUNDANT)
def test_redundant_joint_rows_are_dropped_and_the_motion_is_the_single_joints(body, case):
    """Two spherical joints, a revolute and a spherical one, two fixed joints, a fixed and a
    revolute one on the same face (singular today: LinAlgError). The second joint's rows are
    all implied by the first's: every one of them is dropped and reported (progress line and
    summary ``constraint_rows_dropped``, with joint, kind and axis); the rows kept are the first
    joint's; and the run gives the motion and the joint forces of the first joint alone.

    Same rows, same equations: the two runs may differ only by what Newton leaves, below the
    tolerance (1e-10 × body size) in every step, so over N steps by N times that."""
    redundant, single = REDUNDANT[case]
    lines: list[str] = []
    traj, summary = simulate_body(body, swing(redundant), progress=lines.append)
    alone, reference = simulate_body(body, swing(single))
    assert summary["complete"] and reference["complete"], summary["message"]

    every = build_constraints(body, swing(redundant).joints[1:], body.q0)
    assert summary["constraint_rows"] == reference["constraint_rows"]
    dropped = summary["constraint_rows_dropped"]
    assert [r["joint"] for r in dropped] == ["b"] * every.count
    assert described(dropped) == described([asdict(r) for r in every.rows])
    assert described(traj.rows) == described(alone.rows)
    assert {r["joint"] for r in traj.rows} == {"a"}
    report = [line for line in lines if "constraint rows dropped" in line]
    assert len(report) == 1 and f"{every.count} constraint rows dropped" in report[0]
    assert all(f"b {r['kind']}" in report[0] for r in dropped)

    tolerance = summary["steps"] * 1e-10 * body.size_m
    for group in ("end_x0", "end_xL"):
        np.testing.assert_allclose(traj.groups[group]["position"],
                                   alone.groups[group]["position"], rtol=0, atol=tolerance)
    force = alone.joint_force("a")
    np.testing.assert_allclose(traj.joint_force("a"), force, rtol=0,
                               atol=1e-8 * np.abs(force).max())
    assert np.ptp(traj.groups["end_xL"]["position"], axis=0).max() > 1e3 * tolerance  # moved


def test_fixed_and_revolute_about_a_face_axis_keep_the_one_independent_row(body):
    """A revolute joint about y on a clamped face: its position rows and its tilt about z are
    the fixed joint's (dropped), but its tilt about x measures that rotation with the face
    directions (d, u) = (z, y) where the fixed joint uses (y, z): the two differ by the face's
    in-plane shear, so that row is independent (normalised pivot, sin² of its angle to the
    kept rows, far above the rank tolerance) and is kept. The run completes."""
    scene = swing([joint("fixed", "a"), joint("revolute", "b", axis=[0, 1, 0])])
    traj, summary = simulate_body(body, scene)
    assert summary["complete"], summary["message"]
    assert [(r["joint"], r["kind"]) for r in summary["constraint_rows_dropped"]] == \
        [("b", "force")] * 3 + [("b", "moment")]
    assert summary["constraint_rows"] == 7


def test_rank_tolerance_sits_between_round_off_and_independent_rows(body):
    """``independent_rows`` on the rows of two fixed joints (six exact repeats) and of one
    fixed joint: the repeats are found whatever the order (each implied by the same row of the
    other joint, weight ±1 on it), the single joint's rows are all independent."""
    joints = parse_scene({"end_time": 1.0, "time_step": 1.0,
                          "joints": [joint("fixed", "a"), joint("fixed", "b")]}).joints
    every = build_constraints(body, joints[:1], body.q0)
    C1 = every.jacobian(every.directions)
    C = np.vstack([C1, C1])
    solve = np.linalg.inv(body.mass).__matmul__
    for order in (list(range(12)), list(range(11, -1, -1))):
        kept, implied = independent_rows(C, body.mass, solve, order)
        assert len(kept) == 6 and len(implied) == 6
        for i, weights in implied.items():
            twin = i + 6 if i < 6 else i - 6
            assert set(weights) == set(kept) and twin in kept
            assert abs(abs(weights[twin]) - 1.0) <= 1e3 * EPS
    kept, implied = independent_rows(C1, body.mass, solve, list(range(6)))
    assert kept == list(range(6)) and not implied


def test_a_drive_another_joint_contradicts_is_bad_input(body):
    """A driven revolute about z on a clamped face: the fixed joint already holds the rotation
    the drive prescribes. SceneError naming the driven joint (with its index) and the fixed
    one, whichever comes first in the scene."""
    motor = joint("revolute", "motor", axis=[0, 0, 1],
                  drive={"angular_velocity": 10.0, "ramp_time": 0.01})
    for joints, index in (([joint("fixed", "clamp"), motor], 1),
                          ([motor, joint("fixed", "clamp")], 0)):
        with pytest.raises(SceneError, match=rf"joints\[{index}\] \(motor\): its drive about "
                                             r"\[0\.0, 0\.0, 1\.0\] contradicts joint 'clamp'"):
            simulate_body(body, swing(joints))


def test_a_row_the_coordinates_cannot_move_is_implied_by_them():
    """In subspace coordinates (the rotor basis), a row whose reach there is below UNMOVED of
    its reach in the full coordinates is implied, with no weights; the others are decided as
    before. Rows: e1, a row of reach 1e-7 (cosine) in the subspace, e1 + e2."""
    mass = np.eye(3)
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1e-7], [1.0, 1.0, 0.0]])
    reach = np.array([1.0, 1.0, 2.0])
    kept, implied = independent_rows(C, mass, lambda X: np.linalg.solve(mass, X), [0, 1, 2],
                                     reach)
    assert kept == [0, 2] and implied == {1: {}}
    kept, implied = independent_rows(C, mass, lambda X: np.linalg.solve(mass, X), [0, 1, 2])
    assert kept == [0, 1, 2] and implied == {}
