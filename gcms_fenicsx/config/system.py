"""A system study: several bodies in one assembly, the joints between them and to the ground,
and the time span to step (docs/study-file.md "System studies", docs/design.md §10).

A study file with a ``[system]`` table is a system study; every other study is one body, as
before. ``[bodies.NAME]`` tables give the members — a flexible body (its own study, inline or
by a ``study`` path relative to the system file), a ``rigid`` body or a ``point_mass`` — each
placed by ``position`` and ``rotation``; ``[[joints]]`` hold a point of one body to a point of
another or to the ground. Parsing only: the bodies' stages and the run are ``app.system_run``'s.

A flexible body's own ``[scene]`` is replaced by one the system's joints imply
(``config.body_scene``): the groups they hold are where its attachment modes go
(``[basis] attachment``), so the reduction knows the assembly's joints.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from gcms_fenicsx.config.body_scene import GROUND, basis_in_system, body_scene, body_study
from gcms_fenicsx.config.engine import EngineSpec, parse_engine
from gcms_fenicsx.config.scene import ELASTICITIES, Drive, parse_drive
from gcms_fenicsx.config.study import KNOWN_TABLES, StudyConfig
from gcms_fenicsx.config.table import ConfigError, Table
from gcms_fenicsx.numerics.rotation import rotation_about

SYSTEM_TABLES = ("system", "bodies", "joints", "engine")
JOINT_TYPES = ("spherical", "revolute", "cylindrical", "prismatic", "fixed")
#: A run of more steps than this is a time step given in the wrong unit (days at ~300 steps/s).
MAX_STEPS = 1e8
#: Tables of a flexible body's study that may be given inline in [bodies.NAME].
BODY_STUDY_TABLES = tuple(t for t in KNOWN_TABLES if t != "scene")


@dataclass(frozen=True)
class Placement:
    """Where a body's own coordinates go: x = position + rotation X; its start velocity
    (of its centre of mass) and angular velocity, made consistent with the joints."""

    position: tuple[float, ...] = (0.0, 0.0, 0.0)
    rotation: tuple[tuple[float, ...], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    #: (its point or None for a point mass, another body, that body's point or None): the
    #: position that puts the point where the other body's point starts, in place of position
    align: tuple[str | None, str, str | None] | None = None

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.rotation)


@dataclass(frozen=True)
class FlexibleSpec:
    """A flexible body: its study's tables (without a scene), where they come from, its
    placement, and the study parsed with the scene its joints imply (``config.body_scene``)."""

    name: str
    tables: Mapping[str, Any]
    source: str
    placement: Placement
    study: StudyConfig | None = None
    #: the digest of its tables and implied scene: bodies of one key share one reduced model
    model_key: str = ""
    #: stepped as the rigid body of its mass properties (``rigid.rigid_twin``)
    as_rigid: bool = False
    #: its elastic law: "corotated" or "svk" (``[scene] elasticity`` of a one-body study)
    elasticity: str = "corotated"
    #: Rayleigh damping (α in 1/s, β in s) of its co-rotated deformation rate
    damping: tuple[float, float] = (0.0, 0.0)
    #: the basis it steps in (``body_scene.basis_in_system``) and, for the rotor basis, the
    #: scene of its joints to the ground that chose it
    basis: Any = None
    rotor_scene: Any = None
    kind: str = field(default="flexible", init=False)


@dataclass(frozen=True)
class RigidSpec:
    """A rigid body: mass (kg), centre of mass (m) and inertia tensor about it (kg m²) in its
    own coordinates, and its named points."""

    name: str
    mass_kg: float
    center_m: tuple[float, ...]
    inertia_kgm2: tuple[tuple[float, ...], ...]
    points: dict[str, tuple[float, ...]]
    placement: Placement
    kind: str = field(default="rigid", init=False)


@dataclass(frozen=True)
class PointMassSpec:
    name: str
    mass_kg: float
    placement: Placement
    kind: str = field(default="point_mass", init=False)


BodySpec = FlexibleSpec | RigidSpec | PointMassSpec


@dataclass(frozen=True)
class JointSpec:
    """``body``'s ``point`` held to ``to_body``'s ``to_point`` (``to_body`` = "ground": to
    where the point starts) by a joint of ``type``; ``axis`` in the assembly's coordinates."""

    name: str
    type: str
    body: str
    point: str | None
    to_body: str = GROUND
    to_point: str | None = None
    axis: tuple[float, ...] | None = None
    drive: Drive | None = None


@dataclass(frozen=True)
class SystemConfig:
    bodies: tuple[BodySpec, ...]
    joints: tuple[JointSpec, ...]
    end_time_s: float
    time_step_s: float
    rho_inf: float = 0.8
    record_every: int = 1
    gravity: tuple[float, ...] = (0.0, 0.0, 0.0)
    tolerance: float = 1e-10
    max_iterations: int = 25
    source: str = "<dict>"
    engine: EngineSpec | None = None

    def body(self, name: str) -> BodySpec:
        return next(b for b in self.bodies if b.name == name)

    @property
    def flexible(self) -> tuple[FlexibleSpec, ...]:
        return tuple(b for b in self.bodies if isinstance(b, FlexibleSpec))

    @property
    def crank_drive(self) -> Drive:
        """The drive of the ``[engine]``'s crank_drive joint: its angle is the crank angle."""
        assert self.engine is not None
        return next(j.drive for j in self.joints if j.name == self.engine.crank_drive)


def is_system(raw: Mapping[str, Any]) -> bool:
    """Whether a parsed study file is a system study (it has a ``[system]`` table)."""
    return "system" in raw


def _placement(t: Table) -> Placement:
    rotation = np.eye(3)
    if t.has("rotation"):
        r = Table(f"{t.name}.rotation", t.subtable("rotation"))
        rotation = rotation_about(np.array(r.direction("axis")),
                                  math.radians(r.number("angle")))
        r.finish()
    align = None
    if t.has("align"):
        if t.has("position"):
            raise t.error("align", t.get("align"), "give position or align, not both")
        a = Table(f"{t.name}.align", t.subtable("align"))
        named = [a.get(k, None) for k in ("point", "to_body", "to_point")]
        if not all(v is None or (isinstance(v, str) and v) for v in named) or not named[1]:
            raise t.error("align", t.get("align"), "must be {point = P, to_body = B, to_point = "
                          "Q} (names; no point for a point mass): this body's P placed where "
                          "B's Q starts")
        a.finish()
        align = (named[0], named[1], named[2])
    return Placement(position=t.vector("position", [0.0, 0.0, 0.0]),
                     rotation=tuple(tuple(float(x) for x in row) for row in rotation),
                     align=align,
                     velocity=t.vector("velocity", [0.0, 0.0, 0.0]),
                     angular_velocity=t.vector("angular_velocity", [0.0, 0.0, 0.0]))


def _inertia(t: Table) -> tuple[tuple[float, ...], ...]:
    value = t.get("inertia")
    if (isinstance(value, list) and len(value) == 3
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        value = np.diag(value).tolist()
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(r, list) and len(r) == 3 for r in value)
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                       and math.isfinite(x) for r in value for x in r)):
        raise t.error("inertia", value, "must be the 3 × 3 inertia tensor about the centre of "
                      "mass (kg m²), or its three principal moments")
    return tuple(tuple(float(x) for x in r) for r in value)


def _rigid(name: str, t: Table, placement: Placement) -> RigidSpec:
    r = Table(f"{t.name}.rigid", t.subtable("rigid"))
    points = r.subtable("points")
    if not points:
        raise r.error("points", points, "name at least one point (its joints' places), e.g. "
                      "points = {pin = [0.15, 0, 0]}")
    p = Table(f"{r.name}.points", points)
    named = {key: p.vector(key) for key in points}
    spec = RigidSpec(name, r.positive("mass"), r.vector("center"), _inertia(r), named, placement)
    r.finish()
    return spec


def _flexible(name: str, t: Table, raw: Mapping[str, Any], folder: Path) -> FlexibleSpec:
    inline = {k: raw[k] for k in BODY_STUDY_TABLES if k in raw}
    for key in inline:
        t.get(key)
    if t.has("study"):
        if inline:
            raise t.error("study", t.get("study"), f"give the body's study by a path or inline "
                          f"([{t.name}.{next(iter(inline))}] …), not both")
        value = t.get("study")
        if not isinstance(value, str) or not value:
            raise t.error("study", value, "must be the path of the body's study file")
        path = (folder / value).resolve()
        try:
            study = tomllib.loads(path.read_text())
        except OSError as exc:
            raise t.error("study", value, f"cannot be read ({exc.strerror})") from exc
        except tomllib.TOMLDecodeError as exc:
            raise t.error("study", value, f"is not valid TOML ({exc})") from exc
        if is_system(study):
            raise t.error("study", value, "is a system study; a body's study is one body")
        inline, source = {k: v for k, v in study.items() if k != "scene"}, str(path)
    else:
        source = f"[{t.name}]"
    as_rigid = t.boolean("as_rigid", False)
    elasticity = t.choice("elasticity", ELASTICITIES, "corotated")
    return FlexibleSpec(name, inline, source, _placement(t), as_rigid=as_rigid,
                        elasticity=elasticity, damping=_damping(t, as_rigid, elasticity))


def _damping(t: Table, as_rigid: bool, elasticity: str) -> tuple[float, float]:
    """``damping = {alpha = …, beta = …}`` of a flexible body (as ``[scene.damping]``)."""
    d = Table(f"{t.name}.damping", t.subtable("damping"))
    damping = (d.number("alpha", 0.0, low=0.0), d.number("beta", 0.0, low=0.0))
    d.finish()
    if damping != (0.0, 0.0) and (as_rigid or elasticity != "corotated"):
        why = ("as_rigid = true: a rigid body has no deformation to damp" if as_rigid else
               f'elasticity = "{elasticity}": the Rayleigh damping is the co-rotated law\'s')
        raise t.error("damping", t.get("damping"), f"is not taken with {why}")
    return damping


def _body(name: str, raw: Any, folder: Path) -> BodySpec:
    t = Table(f"bodies.{name}", raw)
    if not name or "/" in name or name == GROUND:
        raise ConfigError("[bodies]", name, f"a body's name must be non-empty, without '/' and "
                          f"not {GROUND!r}")
    kinds = [k for k in ("rigid", "point_mass") if t.has(k)]
    if len(kinds) > 1 or (kinds and any(t.has(k) for k in ("study", *BODY_STUDY_TABLES))):
        raise t.error(kinds[-1], t.get(kinds[-1]), "a body is one of: a flexible body (study = "
                      "PATH or its tables inline), rigid = {…} or point_mass = MASS")
    if kinds == ["point_mass"]:
        spec: BodySpec = PointMassSpec(name, t.positive("point_mass"), _placement(t))
    elif kinds == ["rigid"]:
        spec = _rigid(name, t, _placement(t))
    elif t.has("study") or any(t.has(k) for k in BODY_STUDY_TABLES):
        spec = _flexible(name, t, raw, folder)
    else:
        raise ConfigError(f"[bodies.{name}]", dict(raw), "a body needs study = PATH (or its "
                          "[geometry] … inline), rigid = {mass, center, inertia, points} or "
                          "point_mass = MASS (kg)")
    t.finish()
    return spec


def _point(t: Table, key: str, body: BodySpec) -> str | None:
    """The named point of ``body`` a joint holds: a node group of a flexible body, a named
    point of a rigid one; none for a point mass (its position)."""
    if isinstance(body, PointMassSpec):
        if t.has(key):
            raise t.error(key, t.get(key), f"{body.name!r} is a point mass: it is its own point")
        return None
    value = t.get(key)
    if not isinstance(value, str) or not value:
        raise t.error(key, value, f"must name a point of {body.name!r} ("
                      + ("a node group" if isinstance(body, FlexibleSpec) else
                         "one of " + ", ".join(sorted(body.points))) + ")")
    if isinstance(body, RigidSpec) and value not in body.points:
        raise t.error(key, value, f"is not a point of {body.name!r}; its points are "
                      + ", ".join(sorted(body.points)))
    return value


def _joint(t: Table, bodies: dict[str, BodySpec]) -> JointSpec:
    kind = t.choice("type", JOINT_TYPES)
    name_of = t.get("body")
    if not isinstance(name_of, str) or name_of not in bodies:
        raise t.error("body", name_of, "must be one of the bodies: " + ", ".join(bodies))
    body = bodies[name_of]
    point = _point(t, "point", body)
    other = t.get("to_body", GROUND)
    if not isinstance(other, str) or other != GROUND and other not in bodies or other == name_of:
        raise t.error("to_body", other, f"must be {GROUND!r} (the default) or another body: "
                      + ", ".join(b for b in bodies if b != name_of))
    to_point = _point(t, "to_point", bodies[other]) if other != GROUND else None
    masses = [isinstance(b, PointMassSpec) for b in (body, bodies.get(other))]
    if kind != "spherical" and (masses[0] and (other != GROUND or kind in ("revolute", "fixed"))
                                or masses[1] and kind in ("revolute", "fixed")):
        raise t.error("type", kind, "a point mass has no rotation to hold: join it by a "
                      "spherical joint, or put it on a line (cylindrical or prismatic) to the "
                      "ground or as the to_body of another body's")
    needs_axis = kind not in ("spherical", "fixed") or kind == "fixed" and t.has("axis")
    axis = t.direction("axis") if needs_axis else None
    drive = None
    if t.has("drive"):
        if kind != "revolute" or other != GROUND:
            raise t.error("drive", t.get("drive"), "a drive turns a revolute joint to the ground")
        drive = parse_drive(t)
    name = t.get("name", f"{kind}_{name_of}" + (f"_{point}" if point else ""))
    if not isinstance(name, str) or not name or "/" in name or name.endswith(".rigid"):
        raise t.error("name", name, "must be a non-empty string without '/', not ending in "
                      "'.rigid' (a rigid body's own rows)")
    t.finish()
    return JointSpec(name, kind, name_of, point, other, to_point, axis, drive)


def built_in_system() -> SystemConfig:
    """The built-in default of ``gcms run``: the inline-4 crank train (shipped as
    ``gcms_fenicsx/data/crank_train.toml``, the same as ``workflows/crank_train.toml``)."""
    from importlib import resources

    text = resources.files("gcms_fenicsx.data").joinpath("crank_train.toml").read_text()
    return parse_system(tomllib.loads(text), "<built-in default>")


def parse_system(raw: Mapping[str, Any], source: str = "<dict>",
                 folder: Path = Path(".")) -> SystemConfig:
    """Validate a system study (a parsed TOML document with a ``[system]`` table); ``folder``
    is where bodies' ``study`` paths start."""
    unknown = sorted(set(raw) - set(SYSTEM_TABLES))
    if unknown:
        raise ConfigError(f"[{unknown[0]}]", raw[unknown[0]], "unknown table in a system study "
                          "(allowed: " + ", ".join(SYSTEM_TABLES) + "; a body's own tables go "
                          "in [bodies.NAME])")
    s = Table("system", raw["system"])
    end, step = s.positive("end_time"), s.positive("time_step")
    if not end / MAX_STEPS <= step <= end:
        raise s.error("time_step", step, f"must be in [end_time / {MAX_STEPS:.0e}, end_time] "
                      f"= [{end / MAX_STEPS:g}, {end:g}] s")
    b = Table("bodies", raw.get("bodies"))
    if not raw.get("bodies"):
        raise ConfigError.missing("[bodies]", "a system needs bodies: [bodies.NAME] tables")
    bodies = {name: _body(name, b.get(name), folder) for name in raw["bodies"]}
    listed = list(bodies)
    for name, body in bodies.items():
        align = body.placement.align
        if align is not None and align[1] not in listed[:listed.index(name)]:
            raise ConfigError(f"[bodies.{name}.align] to_body", align[1], "must be a body "
                              "listed above this one: " + (", ".join(listed[:listed.index(name)])
                                                           or "(none)"))
        for key, owner, given in (("point", body, align and align[0]),
                                  ("to_point", align and bodies[align[1]], align and align[2])):
            if given is not None and isinstance(owner, PointMassSpec):
                raise ConfigError(f"[bodies.{name}.align] {key}", given, f"{owner.name!r} is a "
                                  "point mass: it is its own point (leave it out)")
    listed = raw.get("joints", [])
    if not isinstance(listed, list) or not all(isinstance(v, Mapping) for v in listed):
        raise ConfigError("[[joints]]", listed, "must be an array of tables ([[joints]])")
    joints = tuple(_joint(Table(f"joints[{i}]", v), bodies) for i, v in enumerate(listed))
    names = [x.name for x in joints]
    for x in joints:
        if names.count(x.name) > 1:
            raise ConfigError("[[joints]] name", x.name, "joint names must be unique")
    cfg = SystemConfig(
        bodies=tuple(bodies.values()), joints=joints, end_time_s=end, time_step_s=step,
        rho_inf=s.number("rho_inf", 0.8, low=0.0, high=1.0),
        record_every=s.integer("record_every", 1, low=1), gravity=s.vector("gravity",
                                                                           [0.0, 0.0, 0.0]),
        tolerance=s.number("tolerance", 1e-10, low=1e-15, high=1e-3),
        max_iterations=s.integer("max_iterations", 25, low=1), source=source,
        engine=parse_engine(raw.get("engine"), bodies,
                            {j.name: j.drive for j in joints if j.drive is not None}))
    s.finish()
    return replace(cfg, bodies=tuple(_with_study(cfg, body) for body in cfg.bodies))


def _with_study(cfg: SystemConfig, body: BodySpec) -> BodySpec:
    """A flexible body with its study parsed, the scene its joints imply added
    (``config.body_scene``)."""
    if not isinstance(body, FlexibleSpec):
        return body
    study, key = body_study(body, body_scene(cfg.joints, body, cfg.end_time_s,
                                             cfg.time_step_s))
    choice, rotor_scene = basis_in_system(replace(body, study=study), cfg.joints)
    return replace(body, study=study, model_key=key, basis=choice, rotor_scene=rotor_scene)
