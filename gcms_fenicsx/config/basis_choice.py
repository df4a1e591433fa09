"""Which basis a scene runs in: ``[basis] kind`` against the scene's joints and elastic law
(docs/design.md §7.1). The rotor basis fits when every joint is revolute, driven or not, on
parallel axes, and the law is the co-rotated one. No NumPy: the study is checked with it when
it is read (``config.study``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from gcms_fenicsx.config.scene import Joint, Scene, SceneError

#: Joint axes whose sines of the angle between them are below this are one axis.
PARALLEL = 1e-9


@dataclass(frozen=True)
class BasisChoice:
    """The basis a scene runs in: "full" or "rotor" (with its axis), and why."""

    kind: str
    axis: tuple[float, float, float] | None
    reason: str


def choose_basis(kind: str, scene: Scene) -> BasisChoice:
    """``[basis] kind`` for a scene: "full"; "rotor" when its joints leave only rotation about
    one axis (revolute joints, driven or not, on parallel axes), SceneError naming the joints
    otherwise; "auto": the rotor basis when the joints allow it (and the elastic law is the
    co-rotated one), else the full one."""
    if kind == "full":
        return BasisChoice("full", None, "[basis] kind = \"full\"")
    problem = _rotor_problem(scene)
    if problem is None:
        axis = next(j.axis for j in scene.joints)
        assert axis is not None
        names = ", ".join(repr(j.name) for j in scene.joints)
        return BasisChoice("rotor", axis, f"joints {names} leave at most rotation about "
                                          f"{[round(x, 6) for x in axis]}")
    if kind == "rotor":
        raise SceneError(f'[basis] kind = "rotor": {problem}')
    return BasisChoice("full", None, problem)


def _rotor_problem(scene: Scene) -> str | None:
    """Why the rotor basis does not fit the scene, or None."""
    if scene.elasticity != "corotated":
        return (f'[scene] elasticity = "{scene.elasticity}" runs in the full basis (the rotor '
                "basis has the co-rotated law only)")
    needs = "the rotor basis needs revolute joints on one axis, driven or not"
    if not scene.joints:
        return f"the scene has no joints, so the body may turn about every axis; {needs}"
    for j in scene.joints:
        if j.type != "revolute":
            return f"joint {j.name!r} is {j.type}; {needs}"
    first, j = scene.joints[0], off_axis(scene.joints)
    if j is not None:
        return (f"joints {first.name!r} (axis {list(first.axis)}) and {j.name!r} (axis "
                f"{list(j.axis)}) turn about different axes")
    return None


def off_axis(joints: Sequence[Joint]) -> Joint | None:
    """The first of ``joints`` (each with a unit axis) whose axis is not parallel to the first
    one's, or None (also used by ``config.basis`` for the rotation loads can take)."""
    a = joints[0].axis
    for j in joints[1:]:
        b = j.axis
        cross = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        if math.sqrt(sum(x * x for x in cross)) > PARALLEL:
            return j
    return None

