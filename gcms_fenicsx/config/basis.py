"""The ``[basis]`` table: what a body's basis holds besides its free-free eigenmodes.

``attachment = "scene"`` adds attachment modes for the node groups the scene's joints and
loads use (docs/design.md §3.7): a unit force along x, y and z at every joint's group and
along every direction a load can take in the body's frame at a load's group (its own
direction when a fixed joint without a drive holds every rotation; its components in the
plane ⊥ a and along a when the joints let the body turn about a only; x, y and z otherwise),
and a unit moment about every axis a joint holds the group's rotation about (two for a
revolute joint, three for a fixed one, one more for a drive), distributed over the group as that
joint's moment row distributes its reaction (the lever the row takes, ``numerics.group_geometry.lever``, which
depends on the axis the joint turns about: ``turning``), and, for every axis the scene spins
the body about (a drive's, or a revolute joint's the initial angular velocity has a part
along), the centrifugal load of spinning about it at 1 rad/s (a pendulum's swing, slow
beside its bending, gets none: on the flexible pendulum it changed the error from 0.045 % to
0.043 % for 9 more coordinates); ``"none"`` adds none; ``"auto"`` (default) is ``"scene"``
in a study with a scene and ``"none"`` in one without (chosen from the run-time-against-error
study, README: the damped crankshaft's best run is 100 % off its reference without them and
1.5 % with them, the pendulum's 0.66 % and 0.0067 %; at Nm = 10 the crankshaft's nose whirl is
121 % off its full model without them, 0.56 % with them from 1 ms on). Then the loads of the
joints' rows are exactly attachment loads, and the static response of the held body to its
loads, gravity and spin lies in the basis (design §3.7; with a load's directions pruned as
above, exactly in the undeformed frame, and to first order as the body's frame turns with
its deformation). :func:`attachment_loads` lists them
for a scene.

``kind`` is the basis the scene runs in (docs/design.md §7.1): ``"full"`` (default: nine
columns per mode), ``"rotor"`` (three per mode, for joints that leave only rotation about one
axis; refused naming the joints otherwise, when the study is read) or ``"auto"`` (the rotor
basis when the joints allow it, else the full one; ``config.basis_choice``). It does not
change the reduced model: the rotor basis is made from it when the scene runs
(``dynamics.bases.run_basis``).

``shapes`` is what the basis deforms along: ``"modes"`` (default: the model's elastic and
attachment modes) or ``"static"``: the modes of the body held by its joints below the band of
frequencies the scene excites and its static responses to the scene's load patterns
(:func:`scene_patterns`, ``dynamics.bases.static_shapes``), made from the reduced model when the
scene runs (it does not change either). The default crankshaft: no held mode below its
150 Hz band, 12 responses, 46 coordinates in the rotor basis, 120 in the full one (282 on the
modes). No NumPy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from gcms_fenicsx.config.scene_band import scene_band
from gcms_fenicsx.config.table import ConfigError, Table
from gcms_fenicsx.config.basis_choice import PARALLEL, off_axis
from gcms_fenicsx.config.scene import Scene

ATTACHMENT = ("auto", "none", "scene")
KINDS = ("auto", "full", "rotor")
SHAPES = ("modes", "static")

AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class BasisConfig:
    """The ``[basis]`` table."""

    attachment: str = "auto"
    kind: str = "full"
    shapes: str = "modes"


@dataclass(frozen=True)
class AttachmentLoad:
    """A unit force along, or a unit moment about, ``direction`` at node group ``group``; or
    ("centrifugal") the body's centrifugal load spinning at 1 rad/s about ``direction``
    (the joint at ``group`` turns about it); or, for the static shapes only, the inertia
    load of an angular acceleration of 1 rad/s² about it ("tangential") or of an acceleration
    of 1 m/s² along it ("gravity")."""

    group: str
    kind: str          # "force", "moment", "centrifugal"; "tangential", "gravity" (static only)
    direction: tuple[float, float, float]
    #: the axis the joint's rows are blind to turning about (its moment rows' lever), if any
    turning: tuple[float, float, float] | None = None

    @property
    def label(self) -> str:
        axis = ",".join(f"{c:.3g}" for c in self.direction)
        if self.kind in ("centrifugal", "tangential"):
            return f"{self.kind} about [{axis}]"
        if self.kind == "gravity":
            return f"gravity along [{axis}]"
        return f"{self.kind} [{axis}] at {self.group}"


def parse_basis(raw: Mapping[str, Any] | None) -> BasisConfig:
    t = Table("basis", raw)
    cfg = BasisConfig(attachment=t.choice("attachment", ATTACHMENT, BasisConfig.attachment),
                      kind=t.choice("kind", KINDS, BasisConfig.kind),
                      shapes=t.choice("shapes", SHAPES, BasisConfig.shapes))
    t.finish()
    return cfg


def attachment_loads(cfg: BasisConfig, scene: Scene | None) -> tuple[AttachmentLoad, ...]:
    """The unit loads whose static responses become attachment modes (module docstring);
    ConfigError for ``attachment = "scene"`` without a scene."""
    if cfg.attachment == "none" or (cfg.attachment == "auto" and scene is None):
        return ()
    if scene is None:
        raise ConfigError("[basis] attachment", cfg.attachment, "needs a [scene]: the "
                          "attachment modes are at the groups of its joints and loads")
    loads = [AttachmentLoad(j.group, "force", axis) for j in scene.joints for axis in AXES]
    loads += _scene_forces(scene, _turning(scene))
    for joint in scene.joints:
        loads += _moments(joint)
    return tuple(dict.fromkeys(loads + _spins(scene)))


@dataclass(frozen=True)
class ScenePatterns:
    """What a scene's static shapes are made of (``dynamics.bases.static_shapes``): its load
    patterns (:func:`static_loads`) and the band of frequencies it excites
    (``config.scene_band``), below which the held body's modes are kept as well."""

    loads: tuple[AttachmentLoad, ...]
    band_hz: float


def scene_patterns(cfg: BasisConfig, scene: Scene | None) -> ScenePatterns | None:
    """The static shapes' patterns and band for ``shapes = "static"``, None for "modes";
    ConfigError as :func:`static_loads` says."""
    loads = static_loads(cfg, scene)
    if cfg.shapes == "modes":
        return None
    assert scene is not None                   # static_loads refuses "static" without one
    return ScenePatterns(loads, scene_band(scene).max_frequency_hz)


def static_loads(cfg: BasisConfig, scene: Scene | None) -> tuple[AttachmentLoad, ...]:
    """The load patterns of ``shapes = "static"`` (``dynamics.bases.static_shapes``), () for
    "modes": every scene load along the directions it takes in the body's frame (as for the
    attachment modes), gravity likewise, and for the rotation about the axis a the joints
    leave, its angular acceleration ("tangential" about a) and, when the scene spins the body,
    its centrifugal load. ConfigError when the study cannot have them: no scene, joints that
    leave the body more than a rotation about one axis, an initial mode (the shapes hold no
    mode), another elastic law than the co-rotated one."""
    if cfg.shapes == "modes":
        return ()
    key = '[basis] shapes'
    if scene is None:
        raise ConfigError(key, cfg.shapes, "needs a [scene]: the shapes are the static "
                          "responses to its loads with the body held by its joints")
    turning = _turning(scene)
    if turning == FREE:
        which = ("the scene has no joints" if not scene.joints else
                 "its joints leave the body free to turn about more than one axis")
        raise ConfigError(key, cfg.shapes, "needs joints that hold the body up to at most a "
                          "rotation about one axis (revolute joints on one axis, driven or "
                          f"not, or a fixed joint); {which}")
    if scene.initial.mode is not None:
        raise ConfigError(key, cfg.shapes, f"holds no eigenmode, and [scene.initial] mode = "
                          f"{scene.initial.mode} starts from one; use shapes = \"modes\"")
    if scene.elasticity != "corotated":
        raise ConfigError(key, cfg.shapes, f'runs the co-rotated law only, not [scene] '
                          f'elasticity = "{scene.elasticity}"')
    first = scene.joints[0].group
    gravity = [AttachmentLoad(first, "gravity", d)
               for d in _load_directions(scene.gravity, turning)]
    turns = ([AttachmentLoad(first, "tangential", turning)] if turning != HELD else [])
    return tuple(dict.fromkeys(_scene_forces(scene, turning) + gravity + turns
                               + _spins(scene)))


def _scene_forces(scene: Scene, turning: str | tuple[float, float, float]
                  ) -> list[AttachmentLoad]:
    """Unit forces at the groups of the scene's loads (not at a joint's: its rows take them)
    along the directions each load takes in the body's frame, parallel ones at a group once."""
    held = {j.group for j in scene.joints}
    loads: list[AttachmentLoad] = []
    seen: dict[str, list[tuple[float, float, float]]] = {}
    for ld in scene.loads:
        if ld.group in held:
            continue
        for d in _load_directions(ld.force_n, turning):
            kept = seen.setdefault(ld.group, [])
            if all(_norm(_cross(d, e)) > PARALLEL for e in kept):   # f ∥ f': one load
                kept.append(d)
                loads.append(AttachmentLoad(ld.group, "force", d))
    return loads


def _spins(scene: Scene) -> list[AttachmentLoad]:
    """The centrifugal loads of the axes the scene spins the body about: a drive's, or a
    revolute joint's that the initial angular velocity has a part along."""
    spin = scene.initial.angular_velocity
    spins = {j.axis: j.group for j in scene.joints
             if j.axis is not None and (j.drive is not None or (
                 j.type == "revolute" and sum(a * w for a, w in zip(j.axis, spin)) != 0.0))}
    return [AttachmentLoad(group, "centrifugal", axis) for axis, group in spins.items()]


#: What the joints leave of the body's rotation: ``HELD`` (a fixed joint without a drive),
#: ``FREE`` (any rotation, as far as this reading goes), or the one axis it may turn about.
HELD, FREE = "held", "free"


def _turning(scene: Scene) -> str | tuple[float, float, float]:
    """The rotation the joints leave the body: HELD, one axis (every joint revolute or driven,
    on parallel axes), or FREE (no joints, a spherical one, axes that are not parallel)."""
    joints = scene.joints
    if any(j.type == "fixed" and j.drive is None for j in joints):
        return HELD
    if not joints or any(j.type == "spherical" or j.axis is None for j in joints):
        return FREE                            # (a spherical joint may carry an axis it ignores)
    return joints[0].axis if off_axis(joints) is None else FREE


def _load_directions(force: tuple[float, float, float], turning: str | tuple
                     ) -> tuple[tuple[float, float, float], ...]:
    """The unit directions whose span holds a world-fixed force as the body sees it in its
    own frame (Rᵀ f for every rotation R the joints leave)."""
    if turning == FREE:
        return AXES
    size = _norm(force)
    if size == 0.0:
        return ()
    if turning == HELD:
        unit = _unit(force)
        sign = 1.0 if next(x for x in unit if x != 0.0) > 0.0 else -1.0   # f and −f: one load
        return (tuple(sign * x + 0.0 for x in unit),)                     # (+ 0.0: no −0.0)
    along = sum(a * f for a, f in zip(turning, force))
    across = _norm(tuple(f - along * a for a, f in zip(turning, force)))
    return ((_perpendicular(turning) if across > PARALLEL * size else ())
            + ((turning,) if abs(along) > PARALLEL * size else ()))


def _moments(joint: Any) -> list[AttachmentLoad]:
    """The unit moments of a joint's moment rows (``Joint.moment_rows``), in the frame and with
    the levers those rows take (``dynamics.constraints.joints``)."""
    axis = AXES[0] if joint.axis is None else joint.axis
    frame = (*_perpendicular(axis), axis) if joint.axis is not None else AXES
    return [AttachmentLoad(joint.group, "moment", frame[k], axis if blind else None)
            for k, blind in joint.moment_rows()]


def _perpendicular(e: tuple[float, float, float]) -> tuple[tuple[float, float, float], ...]:
    """Two unit vectors completing the unit ``e`` to a right-handed orthonormal frame."""
    c = min(AXES, key=lambda a: abs(sum(x * y for x, y in zip(a, e))))
    u = _unit(_cross(e, c))
    return u, _unit(_cross(e, u))


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _norm(a) -> float:
    return math.sqrt(sum(x * x for x in a))


def _unit(a) -> tuple[float, float, float]:
    n = _norm(a)
    return tuple(x / n for x in a)
