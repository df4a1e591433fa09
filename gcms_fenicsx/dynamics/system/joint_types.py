"""The joint types of a system study as rows (``rows``; docs/assemblies.md "Joint types from
rows"): a point of one member held to a point of another, or to the ground where it starts.

Row names: the joint's name for its point's rows (coincide or on_line), ``NAME/axis`` for the
rows that hold its rotation, ``NAME/drive`` for a drive's row, ``NAME/turn`` for a prismatic
or fixed joint's rotation about its axis. NumPy only.
"""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.config.scene import Drive
from gcms_fenicsx.dynamics.constraints.joints import plane_basis
from gcms_fenicsx.dynamics.system import relative_rows, rows
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass

Member = Flexible | PointMass
GROUND_TYPES = ("spherical", "revolute", "cylindrical", "prismatic", "fixed")
BETWEEN_TYPES = ("spherical", "revolute", "cylindrical", "prismatic", "fixed")


def point_of(member: Member, name: str | None) -> rows.Point:
    """A point mass's position, or a node group's (a rigid body's named point's) mean."""
    if isinstance(member, PointMass):
        return rows.mass_point(member)
    return rows.group_point(member, name or "")


def start_of(member: Member, point: rows.Point) -> np.ndarray:
    """Where ``point`` of ``member`` is at the start (m)."""
    return point.vector @ member.fields(member.q_start)


def _held_rotation(joint: str, member: Member, group: str | None, axis: np.ndarray,
                   about_axis: bool) -> tuple[rows.Row, ...]:
    """The rows holding a member's group from turning away from ``axis`` (and, with
    ``about_axis``, about it): none for a point mass, which has no rotation."""
    if isinstance(member, PointMass):
        return ()
    held: tuple[rows.Row, ...] = (rows.keep_axis(f"{joint}/axis", member, group or "", axis),)
    if about_axis:
        held += (rows.keep_axis(f"{joint}/turn", member, group or "", plane_basis(axis)[0]),)
    return held


def to_ground(joint: str, kind: str, member: Member, point: str | None,
              axis: np.ndarray | None = None, drive: Drive | None = None
              ) -> tuple[rows.Row, ...]:
    """The rows of a joint of ``kind`` holding ``member``'s ``point`` to the ground where it
    starts: spherical (the point), revolute (the point and the axis; ``drive`` turns it),
    cylindrical (the point on the line along the axis, the axis), prismatic (the point on the
    line, no rotation), fixed (the point, no rotation)."""
    if kind not in GROUND_TYPES:
        raise ValueError(f"joint {joint!r}: type {kind!r} is not one of {GROUND_TYPES}")
    p = point_of(member, point)
    here = rows.fixed_point(start_of(member, p))
    e = np.array([0.0, 0.0, 1.0]) if axis is None else np.asarray(axis, float)
    if kind == "spherical":
        return (rows.coincide(joint, p, here),)
    if kind == "revolute":
        turned = (() if drive is None else
                  (rows.drive(f"{joint}/drive", member, point or "", e, drive),))
        return (rows.coincide(joint, p, here), *_held_rotation(joint, member, point, e, False),
                *turned)
    if kind in ("cylindrical", "prismatic"):
        return (rows.on_line(joint, p, e),
                *_held_rotation(joint, member, point, e, kind == "prismatic"))
    return (rows.coincide(joint, p, here), *_held_rotation(joint, member, point, e, True))


def between(joint: str, kind: str, a: Member, point_a: str | None, b: Member,
            point_b: str | None, axis: np.ndarray | None = None) -> tuple[rows.Row, ...]:
    """The rows of a joint of ``kind`` between two members' points: spherical (the points
    together), revolute (together, and ``axis`` of a's group kept parallel to b's),
    cylindrical (b's point on the line along a's axis, the axes parallel), prismatic (on the
    line, no relative rotation), fixed (together, no relative rotation; about ``axis`` or z,
    any three axes hold the same). The line is a's: a is the body (a cylinder, a guide), b the
    point moving along it; a point mass has no rotation, so as b on a line only its point is
    held, and it cannot be a or be held by a revolute or fixed joint."""
    if kind not in BETWEEN_TYPES:
        raise ValueError(f"joint {joint!r}: between two bodies a joint is one of "
                         f"{BETWEEN_TYPES}, got {kind!r}")
    if kind == "spherical":
        return (rows.coincide(joint, point_of(a, point_a), point_of(b, point_b)),)
    if isinstance(a, PointMass):
        raise ValueError(f"joint {joint!r}: a point mass has no axis for a {kind} joint: "
                         f"make {a.name!r} its to_body")
    e = np.array([0.0, 0.0, 1.0]) if axis is None else np.asarray(axis, float)
    if kind in ("cylindrical", "prismatic"):
        held: tuple[rows.Row, ...] = (relative_rows.on_member_line(
            joint, a, point_a or "", point_of(b, point_b), e),)
    else:
        held = (rows.coincide(joint, point_of(a, point_a), point_of(b, point_b)),)
    if isinstance(b, PointMass):
        if kind in ("revolute", "fixed"):
            raise ValueError(f"joint {joint!r}: a point mass has no rotation for a {kind} "
                             "joint")
        return held
    held += (relative_rows.align_axes(f"{joint}/axis", a, point_a or "", b, point_b or "", e),)
    if kind in ("prismatic", "fixed"):
        held += (relative_rows.hold_turn(f"{joint}/turn", a, point_a or "", b, point_b or "",
                                         e),)
    return held
