"""The ``[basis]`` table: what a body's basis holds besides its free-free eigenmodes.

``attachment = "scene"`` adds attachment modes for the node groups the scene's joints and
loads use (docs/design.md §3.7): a unit force along x, y and z at every such group, and a
unit moment about every axis a joint holds the group's rotation about (two for a revolute
joint, three for a fixed one); ``"none"`` (default) adds none. :func:`attachment_loads`
lists them for a scene.

``kind`` is the basis the scene runs in (docs/design.md §7.1): ``"full"`` (default: nine
columns per mode), ``"rotor"`` (three per mode, for joints that leave only rotation about one
axis; refused naming the joints otherwise, when the study is read) or ``"auto"`` (the rotor
basis when the joints allow it, else the full one; ``dynamics.basis_choice``). It does not
change the reduced model: the rotor basis is made from it when the scene runs
(``dynamics.run_basis``). No NumPy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from gcms_fenicsx.config.table import ConfigError, Table
from gcms_fenicsx.dynamics.scene import Scene

ATTACHMENT = ("none", "scene")
KINDS = ("auto", "full", "rotor")

AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class BasisConfig:
    """The ``[basis]`` table."""

    attachment: str = "none"
    kind: str = "full"


@dataclass(frozen=True)
class AttachmentLoad:
    """A unit force along, or a unit moment about, ``direction`` at node group ``group``."""

    group: str
    kind: str                                  # "force" or "moment"
    direction: tuple[float, float, float]

    @property
    def label(self) -> str:
        axis = ",".join(f"{c:.3g}" for c in self.direction)
        return f"{self.kind} [{axis}] at {self.group}"


def parse_basis(raw: Mapping[str, Any] | None) -> BasisConfig:
    t = Table("basis", raw)
    cfg = BasisConfig(attachment=t.choice("attachment", ATTACHMENT, BasisConfig.attachment),
                      kind=t.choice("kind", KINDS, BasisConfig.kind))
    t.finish()
    return cfg


def attachment_loads(cfg: BasisConfig, scene: Scene | None) -> tuple[AttachmentLoad, ...]:
    """The unit loads whose static responses become attachment modes (module docstring);
    ConfigError for ``attachment = "scene"`` without a scene."""
    if cfg.attachment == "none":
        return ()
    if scene is None:
        raise ConfigError("[basis] attachment", cfg.attachment, "needs a [scene]: the "
                          "attachment modes are at the groups of its joints and loads")
    loads: list[AttachmentLoad] = []
    groups = [j.group for j in scene.joints] + [ld.group for ld in scene.loads]
    for group in dict.fromkeys(groups):
        loads += [AttachmentLoad(group, "force", axis) for axis in AXES]
    for joint in scene.joints:
        if joint.type == "fixed":
            held = AXES
        elif joint.type == "revolute":
            held = _perpendicular(joint.axis)
        else:
            held = ()
        loads += [AttachmentLoad(joint.group, "moment", axis) for axis in held]
    return tuple(dict.fromkeys(loads))


def _perpendicular(e: tuple[float, float, float]) -> tuple[tuple[float, float, float], ...]:
    """Two unit vectors completing the unit ``e`` to a right-handed orthonormal frame."""
    c = min(AXES, key=lambda a: abs(sum(x * y for x, y in zip(a, e))))
    u = _unit(_cross(e, c))
    return u, _unit(_cross(e, u))


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _unit(a) -> tuple[float, float, float]:
    n = math.sqrt(sum(x * x for x in a))
    return tuple(x / n for x in a)
