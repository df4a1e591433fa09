"""The ``[scene]`` table: what is simulated — joints, loads, gravity, initial motion, time span,
integrator settings and outputs. Pure parsing: nothing here knows the body, so group names
are checked when the scene meets a body (``simulate``).

SI units throughout: seconds, metres, newtons, radians. Every key, its default and what it
means: docs/study-file.md (checked against the tables here by tests/test_docs.py). The rule
that orients ``[scene.initial] mode`` is ``dynamics.stepping.initial``'s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping

from gcms_fenicsx.runtime.errors import SceneError
from gcms_fenicsx.config.stress_outputs import StressOutputs, stress_outputs
from gcms_fenicsx.config.table import ConfigError, Table

JOINT_TYPES = ("spherical", "revolute", "fixed")



LOAD_TIMES = ("constant", "ramp", "harmonic")
#: Rotation per step of a drive above which a warning is given. The default crankshaft scene
#: (docs/stability.md) drifts in energy by 9e-5 at 0.016 rad per step, 6e-4 at 0.039 and
#: 4e-2 at 0.16: second order in the step, with a large constant.
DRIVE_STEP_WARNING_RAD = 0.05
JACOBIANS = ("rotated", "exact", "assembled")
#: ``[scene] elasticity``: co-rotated linear (``dynamics.bodies.corotated``) or Saint Venant–Kirchhoff
#: with constant coefficients (``dynamics.bodies.svk``).
ELASTICITIES = ("corotated", "svk")
#: ``[scene.solver] kernel``: which step runs (``dynamics.stepping.kernel``).
KERNELS = ("auto", "numba", "numpy")


#: ``ramp`` of a drive: how θ̇ rises from 0 to Ω over the ramp time (``Drive``).
DRIVE_RAMPS = ("cosine", "cycloidal")


@dataclass(frozen=True)
class Drive:
    """A prescribed rotation θ(t) about a joint's axis: speed Ω reached smoothly over ``ramp_time_s``.

    ``ramp = "cosine"``: θ̇(t) = Ω (1 − cos(π t / T)) / 2 for t < T, then Ω: continuous
    acceleration, so the drive starts without a jerk in the constraint forces.
    ``ramp = "cycloidal"``: θ̈(t) = (Ω / T)(1 − cos(2π t / T)), the spin-up of Kane, Ryan &
    Banerjee (J. Guid. Control Dyn. 10(2), 1987): θ̇ = (Ω / T)(t − T/(2π) sin(2π t / T)),
    θ = (Ω / T)(t²/2 + (T/(2π))² (cos(2π t / T) − 1)); acceleration and jerk continuous.
    Both reach θ = Ω (t − T/2) for t ≥ T.
    """

    angular_velocity: float
    ramp_time_s: float = 0.0
    ramp: str = "cosine"

    def angle(self, t: float) -> tuple[float, float, float]:
        """(θ, θ̇, θ̈) at time t."""
        W, T = self.angular_velocity, self.ramp_time_s
        if t >= T:
            return W * (t - 0.5 * T), W, 0.0
        if self.ramp == "cycloidal":
            c = 2.0 * math.pi / T
            return (W / T * (0.5 * t * t + (math.cos(c * t) - 1.0) / (c * c)),
                    W / T * (t - math.sin(c * t) / c), W / T * (1.0 - math.cos(c * t)))
        c = math.pi / T
        return (0.5 * W * (t - math.sin(c * t) / c), 0.5 * W * (1.0 - math.cos(c * t)),
                0.5 * W * c * math.sin(c * t))


@dataclass(frozen=True)
class Joint:
    """A joint of one node group to the ground, where the group starts."""

    name: str
    type: str
    group: str
    axis: tuple[float, float, float] | None = None
    drive: Drive | None = None

    def moment_rows(self) -> tuple[tuple[int, bool], ...]:
        """The joint's moment rows as (k, blind to turning): k indexes its frame (b1, b2 ⊥ the
        axis, then the axis; x, y, z without an axis), and the row's lever must not see the
        body turn about the axis (a revolute or driven joint's first two rows). None for a
        spherical joint; a revolute joint holds two, a fixed or driven one three, the third
        the drive's when driven (``joints``, and the attachment loads of ``config.basis``)."""
        if self.type == "spherical":
            return ()
        turns = self.type == "revolute" or self.drive is not None
        held = (0, 1) if self.type == "revolute" and self.drive is None else (0, 1, 2)
        return tuple((k, turns and k < 2) for k in held)


@dataclass(frozen=True)
class Load:
    """A force on a node group's weighted mean position, in the global frame: F s(t).

    ``time = "harmonic"`` with ``ramp_time_s`` T > 0 rises in, s(t) = ½ (1 − cos(π t / T))
    sin(2π f t + φ) for t < T: from zero with zero rate, not a step that rings every mode."""

    name: str
    group: str
    force_n: tuple[float, float, float]
    time: str = "constant"
    ramp_time_s: float = 0.0
    frequency_hz: float = 0.0
    phase_deg: float = 0.0

    def factor(self, t: float) -> float:
        """s(t): 1, min(t / T, 1), or sin(2π f t + φ) (risen in over T if T > 0)."""
        if self.time == "ramp":
            return min(t / self.ramp_time_s, 1.0)
        if self.time == "harmonic":
            wave = math.sin(2.0 * math.pi * self.frequency_hz * t + math.radians(self.phase_deg))
            T = self.ramp_time_s
            return wave if t >= T else 0.5 * (1.0 - math.cos(math.pi * t / T)) * wave
        return 1.0


@dataclass(frozen=True)
class Initial:
    """Initial state: a rigid velocity field v + ω × (x − c), and optionally an elastic
    deformation in one elastic mode of the reduced model, scaled to a largest nodal
    displacement of ``amplitude_m``, oriented along the unit ``direction`` if given (module
    docstring), or (``equilibrium``) at rest in its held static equilibrium under the forces
    at t = 0 (``statics.static_equilibrium``), instead of dropping into its sag and ringing."""

    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mode: int | None = None
    amplitude_m: float = 0.0
    direction: tuple[float, float, float] | None = None
    equilibrium: bool = False


@dataclass(frozen=True)
class Solver:
    """Newton on the generalized-α step: increments below ``tolerance`` × body size end it.

    ``jacobian`` (``integrator`` explains them): "rotated" (the factorised iteration matrix
    turned with the frame; exact terms added to a step that converges slowly), "exact"
    (with the change-of-frame terms from the first iteration) or "assembled" (the exact
    matrix assembled and factorised every iteration: the baseline).

    ``kernel`` (``stepping.kernel``): "auto" steps with the compiled kernel where Numba is
    installed and the scene is one it runs, else in NumPy; "numba" insists; "numpy" is the
    reference path.
    """

    tolerance: float = 1e-10
    max_iterations: int = 25
    jacobian: str = "rotated"
    kernel: str = "auto"


@dataclass(frozen=True)
class Outputs:
    """What the simulation records, every ``every``-th step."""

    groups: tuple[str, ...] = ()
    every: int = 1
    energy: bool = True
    constraint_forces: bool = True
    coordinates: bool = False
    field_times: tuple[float, ...] = ()
    stress: StressOutputs | None = None


@dataclass(frozen=True)
class Scene:
    end_time_s: float
    time_step_s: float
    rho_inf: float = 0.8
    gravity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    damping_alpha: float = 0.0
    damping_beta: float = 0.0
    joints: tuple[Joint, ...] = ()
    elasticity: str = "corotated"
    loads: tuple[Load, ...] = ()
    initial: Initial = field(default_factory=Initial)
    solver: Solver = field(default_factory=Solver)
    outputs: Outputs = field(default_factory=Outputs)

    @property
    def steps(self) -> int:
        """Steps of time_step to reach end_time: the run ends at the first step at or beyond
        it (exactly on it when end_time is a multiple of time_step, to 1e-9 of a step)."""
        return max(1, math.ceil(self.end_time_s / self.time_step_s - 1e-9))

    @property
    def loads_risen_s(self) -> float:
        """The time by which every load has risen in: the longest ramp_time (0 if none ramps)."""
        return max((load.ramp_time_s for load in self.loads), default=0.0)

    def warnings(self) -> list[str]:
        """What in the scene predicts an inaccurate run, one line each: a drive that turns its
        body more than DRIVE_STEP_WARNING_RAD per step."""
        return [f"joint {j.name!r} turns its group {j.drive.angular_velocity * self.time_step_s:.3g} "
                f"rad per step (drive {j.drive.angular_velocity:g} rad/s, time_step "
                f"{self.time_step_s:g} s): more than {DRIVE_STEP_WARNING_RAD:g} rad, where the "
                "energy error grows fast; a time_step of at most "
                f"{DRIVE_STEP_WARNING_RAD / abs(j.drive.angular_velocity):.2g} s keeps below it"
                for j in self.joints if j.drive is not None
                and abs(j.drive.angular_velocity) * self.time_step_s > DRIVE_STEP_WARNING_RAD]

    def check_groups(self, known: Iterable[str]) -> None:
        """SceneError naming the first joint, load or output whose group is not in ``known``."""
        known = set(known)
        uses = ([(f"joints[{i}] ({j.name})", j.group) for i, j in enumerate(self.joints)]
                + [(f"loads[{i}] ({ld.name})", ld.group) for i, ld in enumerate(self.loads)]
                + [("outputs.groups", g) for g in self.outputs.groups]
                + [("outputs.stress_groups", g) for g in (self.outputs.stress.groups
                                                          if self.outputs.stress else ())])
        for where, name in uses:
            if name not in known:
                listed = ", ".join(sorted(known)) or "(none)"
                raise SceneError(f"[scene] {where}: group = {name!r} is not a node group of "
                                 f"this body; the groups are: {listed}")


def parse_drive(t: Table) -> Drive:
    """The ``drive`` table of the joint table ``t`` (``Drive``)."""
    d = Table(f"{t.name}.drive", t.subtable("drive"))
    drive = Drive(angular_velocity=d.number("angular_velocity"),
                  ramp_time_s=d.number("ramp_time", 0.0, low=0.0),
                  ramp=d.choice("ramp", DRIVE_RAMPS, "cosine"))
    d.finish()
    return drive


def _joint(t: Table) -> Joint:
    kind = t.choice("type", JOINT_TYPES)
    group = _group_name(t, "group")
    name = _name(t, f"{kind}_{group}")
    axis, drive = None, None
    if kind == "revolute" or t.has("axis"):
        axis = t.direction("axis")
    if t.has("drive"):
        if kind == "spherical":
            raise t.error("drive", t.get("drive"), "a drive needs a revolute or fixed joint")
        drive = parse_drive(t)
        if axis is None:
            raise t.error("axis", None, "required with a drive: the axis it turns the group about")
    t.finish()
    return Joint(name=name, type=kind, group=group, axis=axis, drive=drive)


def _load(t: Table, index: int) -> Load:
    group = _group_name(t, "group")
    name = _name(t, f"load{index}_{group}")
    force = t.vector("force")
    time = t.choice("time", LOAD_TIMES, "constant")
    ramp = (t.positive("ramp_time") if time == "ramp" else
            t.number("ramp_time", 0.0, low=0.0) if time == "harmonic" else 0.0)
    freq, phase = (t.positive("frequency_hz"), t.number("phase_deg", 0.0)) \
        if time == "harmonic" else (0.0, 0.0)
    t.finish()
    return Load(name=name, group=group, force_n=force, time=time, ramp_time_s=ramp,
                frequency_hz=freq, phase_deg=phase)


def _group_name(t: Table, key: str) -> str:
    value = t.get(key)
    if not isinstance(value, str) or not value:
        raise t.error(key, value, "must be the name of a node group (a string)")
    return value


def _name(t: Table, default: str) -> str:
    value = t.get("name", default)
    if not isinstance(value, str) or not value or "/" in value:
        raise t.error("name", value, "must be a non-empty string without '/'")
    return value


def _unique(kind: str, names: list[str]) -> None:
    seen = set()
    for n in names:
        if n in seen:
            raise ConfigError(f"[scene] {kind}", n, f"{kind} names must be unique; give each "
                              "a distinct name = \"...\"")
        seen.add(n)


def parse_scene(raw: Mapping[str, Any] | None) -> Scene | None:
    """The validated ``[scene]`` table, or None when the study has none."""
    if raw is None:
        return None
    t = Table("scene", raw)
    end = t.positive("end_time")
    step = t.positive("time_step")
    if step > end:
        raise t.error("time_step", step, f"must be <= end_time ({end:g} s)")

    d = Table("scene.damping", t.subtable("damping"))
    alpha, beta = d.number("alpha", 0.0, low=0.0), d.number("beta", 0.0, low=0.0)
    d.finish()

    s = Table("scene.solver", t.subtable("solver"))
    default = Solver()
    solver = Solver(tolerance=s.number("tolerance", default.tolerance, low=1e-15, high=1e-3),
                    max_iterations=s.integer("max_iterations", default.max_iterations, low=1,
                                             high=1000),
                    jacobian=s.choice("jacobian", JACOBIANS, default.jacobian),
                    kernel=s.choice("kernel", KERNELS, default.kernel))
    s.finish()

    i = Table("scene.initial", t.subtable("initial"))
    mode = i.integer("mode", None, low=1) if i.has("mode") else None
    for key in ("amplitude", "direction"):
        if mode is None and i.has(key):
            raise i.error(key, i.get(key), "needs mode = N: the elastic mode it shapes")
    equilibrium = i.boolean("equilibrium", False)
    initial = Initial(velocity=i.vector("velocity", (0.0, 0.0, 0.0)),
                      angular_velocity=i.vector("angular_velocity", (0.0, 0.0, 0.0)),
                      mode=mode,
                      amplitude_m=i.positive("amplitude") if mode is not None else 0.0,
                      direction=i.direction("direction") if i.has("direction") else None,
                      equilibrium=equilibrium)
    i.finish()

    o = Table("scene.outputs", t.subtable("outputs"))
    field_times = tuple(o.number_list("field_times", []))
    bad = [x for x in field_times if not 0.0 <= x <= end]
    if bad:
        raise o.error("field_times", list(field_times), f"each must be within 0..end_time "
                      f"({end:g} s); {bad[0]:g} is not")
    groups = o.string_list("groups", [])
    outputs = Outputs(groups=tuple(dict.fromkeys(groups)), every=o.integer("every", 1, low=1),
                      energy=o.boolean("energy", True),
                      constraint_forces=o.boolean("constraint_forces", True),
                      coordinates=o.boolean("coordinates", False), field_times=field_times,
                      stress=stress_outputs(o, end))
    o.finish()

    elasticity = t.choice("elasticity", ELASTICITIES, "corotated")
    if elasticity == "svk" and (alpha or beta):
        raise t.error("elasticity", elasticity, "runs without [scene.damping] (the co-rotated "
                      "Rayleigh damping is not combined with Saint Venant–Kirchhoff); remove "
                      "damping or use elasticity = \"corotated\"")
    if elasticity == "svk" and solver.jacobian != "rotated":
        raise t.error("elasticity", elasticity, f'runs with [scene.solver] jacobian = '
                      f'"rotated", not "{solver.jacobian}"')

    joints = tuple(_joint(jt) for jt in t.tables("joints"))
    loads = tuple(_load(lt, k) for k, lt in enumerate(t.tables("loads")))
    moving = [j.name for j in joints if j.drive is not None and j.drive.angle(0.0)[1] != 0.0]
    if equilibrium and (mode or any(initial.velocity + initial.angular_velocity) or moving):
        raise i.error("equilibrium", True, "starts the body at rest, held by every joint: not "
                      "with mode, velocity or angular_velocity, nor with a drive turning at "
                      "t = 0" + (f" (joint {moving[0]!r}: give it a ramp_time)" if moving else ""))
    _unique("joints", [j.name for j in joints])
    _unique("loads", [ld.name for ld in loads])
    scene = Scene(end_time_s=end, time_step_s=step,
                  rho_inf=t.number("rho_inf", 0.8, low=0.0, high=1.0),
                  gravity=t.vector("gravity", (0.0, 0.0, 0.0)),
                  damping_alpha=alpha, damping_beta=beta, joints=joints, loads=loads,
                  initial=initial, solver=solver, outputs=outputs, elasticity=elasticity)
    t.finish()
    return scene
