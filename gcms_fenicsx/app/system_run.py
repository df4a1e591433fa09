"""``gcms run`` on a system study (``config.system``): every flexible body's stages, each in
``--out/bodies/NAME`` with its own stage cache (``--fresh``, progress and errors as a one-body
study's), then the assembly (``dynamics.system``) stepped on rank 0 and its files written
into ``--out``, published with the bodies' stages when the run succeeded or stopped early
(its rows up to there, marked incomplete; ``files.outputs.staged_output``).

Files (docs/files.md): ``system.h5`` — ``time_s``, ``iterations``, ``energy/*``, the kept rows
(``rows/joint``, ``rows/kind``, ``rows/axis``, ``rows/unit``) and their ``multipliers``, each
joint's force and moment on its first body (``joints/NAME/force_n``, ``moment_nm``: −Σ λ_k
a_k over its force and moment rows, a_k the rows' axes at the start; a drive's torque
``drive_torque_nm``), with an ``[engine]`` the crank angle and the gas forces
(``engine/*``), and each body's coordinates (``bodies/NAME/q``); ``summary.json``;
``system_joints.png``.
"""
from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from gcms_fenicsx.config.system import (GROUND, FlexibleSpec, JointSpec, PointMassSpec,
                                        RigidSpec, SystemConfig, is_system, parse_system)
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.progress import Progress, quiet

SYSTEM_FILES = ("system.h5", "summary.json", "system_joints.png")
BODIES_FOLDER = "bodies"


def system_file(path: Path | None) -> dict[str, Any] | None:
    """The parsed TOML of ``path`` if it is a system study, else None (a file that cannot be
    read or parsed is left to the one-body reader, which says why)."""
    if path is None:
        return None
    try:
        raw = tomllib.loads(Path(path).read_text())
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return None
    return raw if is_system(raw) else None


def load_system(path: Path, raw: dict[str, Any]) -> SystemConfig:
    """The validated system study of ``path`` (its bodies' ``study`` paths relative to it)."""
    return parse_system(raw, str(path), Path(path).resolve().parent)


def members(cfg: SystemConfig, models: dict[str, ReducedModel],
            full_order: dict[str, Any] | None = None, progress: Progress = quiet) -> tuple:
    """The assembly's members, placed: flexible bodies of their reduced models with their
    elastic law (co-rotated, or Saint Venant–Kirchhoff of the model's coefficients; or, for a
    name in ``full_order``, its full-order Body, ``references.full_order``: F = I, a sparse LU
    of its iteration matrix) in the basis its ``[basis] kind`` asks for (the rotor basis:
    ``rotor_member``) with its Rayleigh ``damping``, rigid bodies, point masses."""
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.run.simulate import elastic_law
    from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
    from gcms_fenicsx.dynamics.system.rigid import rigid_body, rigid_member, rigid_twin

    bodies: dict[int, Any] = {}       # one Body per reduced model, however many share it
    rotors: dict[int, Any] = {}       # and one rotor body

    def member(spec: Any, x0: np.ndarray) -> Any:
        R0 = spec.placement.matrix
        if isinstance(spec, FlexibleSpec) and spec.name in (full_order or {}):
            if spec.elasticity != "corotated":
                raise ValueError(f"reference (a) of {spec.name!r} is co-rotated only: its "
                                 f"elasticity = {spec.elasticity!r} has no full-order law here")
            from gcms_fenicsx.references.full_order import sparse_factorization
            body = full_order[spec.name]
            return Flexible(spec.name, body, placed_coordinates(body, R0, x0),
                            factorize=sparse_factorization, damping=damping_of(spec))
        if isinstance(spec, FlexibleSpec):
            model = models[spec.name]
            if id(model) not in bodies:
                bodies[id(model)] = body_from_reduced(model)
            body = bodies[id(model)]
            if spec.as_rigid:
                return rigid_member(spec.name, rigid_twin(body), R0, x0)
            if id(model) not in rotors:
                rotors[id(model)] = in_rotor_basis(spec, model, body, progress)
            rotor = rotors[id(model)]
            if rotor is not None:
                from gcms_fenicsx.dynamics.system.rotor_member import rotor_member
                return rotor_member(spec.name, rotor, R0, x0, damping_of(spec))
            law = (elastic_law(model, body, spec.study.scene) if spec.elasticity == "svk"
                   else None)                                 # None: the co-rotated law
            return Flexible(spec.name, body, placed_coordinates(body, R0, x0), law=law,
                            damping=damping_of(spec))
        if isinstance(spec, RigidSpec):
            body = rigid_body(spec.mass_kg, np.array(spec.center_m),
                              np.array(spec.inertia_kgm2), spec.points)
            return rigid_member(spec.name, body, R0, x0)
        return PointMass(spec.name, spec.mass_kg, x0)

    made: dict[str, Any] = {}
    for spec in cfg.bodies:
        align, key, value = spec.placement.align, f"[bodies.{spec.name}]", spec.kind
        try:
            x0 = np.array(spec.placement.position)
            if align is not None:
                at_origin = member(spec, np.zeros(3))
                key, value = f"[bodies.{spec.name}.align]", dict(zip(
                    ("point", "to_body", "to_point"), align))
                x0 = aligned_position(align, at_origin, made)
                key, value = f"[bodies.{spec.name}]", spec.kind
            made[spec.name] = member(spec, x0)
        except ValueError as exc:
            raise ConfigError(key, value, str(exc)) from exc
    return tuple(made.values())


def damping_of(spec: FlexibleSpec) -> Any:
    """The body's Rayleigh damping (``bodies.damping``), None when it has none."""
    from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping

    return RayleighDamping(*spec.damping) if spec.damping != (0.0, 0.0) else None


def in_rotor_basis(spec: FlexibleSpec, model: ReducedModel, body: Any, progress: Progress
                   ) -> Any:
    """The rotor body of ``body`` when the study chose the rotor basis for it (by its joints
    to the ground, ``config.body_scene.basis_in_system``), else None."""
    from gcms_fenicsx.config.basis import parse_basis
    from gcms_fenicsx.dynamics.bases.run_basis import in_basis

    if spec.rotor_scene is None:
        if parse_basis(spec.tables.get("basis")).kind == "auto":
            progress(f"{spec.name}: basis: full ({spec.basis.reason})")
        return None
    return in_basis(model, body, spec.rotor_scene, "rotor", spec.study.plan.scene.attachment,
                    lambda line: progress(f"{spec.name}: {line}"))


def aligned_position(align: tuple, at_origin: Any, made: dict[str, Any]) -> np.ndarray:
    """x₀ that puts the point ``align[0]`` of a member (``at_origin``: placed at x₀ = 0) where
    the point ``align[2]`` of the member ``align[1]`` (placed before it) starts."""
    from gcms_fenicsx.dynamics.system.joint_types import point_of, start_of

    point, other, to_point = align
    target = start_of(made[other], point_of(made[other], to_point))
    return target - start_of(at_origin, point_of(at_origin, point))


def joint_rows(spec: JointSpec, by_name: dict[str, Any]) -> tuple:
    """The rows of one joint (``dynamics.system.joint_types``); a ConfigError naming it."""
    from gcms_fenicsx.dynamics.system import joint_types

    axis = None if spec.axis is None else np.array(spec.axis)
    try:
        if spec.to_body == GROUND:
            return joint_types.to_ground(spec.name, spec.type, by_name[spec.body], spec.point,
                                         axis, spec.drive)
        return joint_types.between(spec.name, spec.type, by_name[spec.body], spec.point,
                                   by_name[spec.to_body], spec.to_point, axis)
    except ValueError as exc:
        raise ConfigError(f"[[joints]] {spec.name!r}", spec.type, str(exc)) from exc


def start_velocity(cfg: SystemConfig, made: tuple) -> np.ndarray:
    """q̇ at t = 0 from each body's ``velocity`` (of its centre of mass) and
    ``angular_velocity`` (the run makes it consistent with the joints)."""
    parts = []
    for spec, member in zip(cfg.bodies, made):
        v, w = np.array(spec.placement.velocity), np.array(spec.placement.angular_velocity)
        parts.append(v if isinstance(spec, PointMassSpec) else member.rigid_velocity(v, w))
    return np.concatenate(parts)


def build_system(cfg: SystemConfig, models: dict[str, ReducedModel],
                 full_order: dict[str, Any] | None = None, progress: Progress = quiet
                 ) -> tuple[tuple, Any, Any]:
    """(members, assembly, stepper) of the study (:func:`members`, ``full_order`` and
    ``progress`` as there)."""
    from gcms_fenicsx.dynamics.system.assembly import AssemblyError, assemble
    from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings

    made = members(cfg, models, full_order, progress)
    by_name = {m.name: m for m in made}
    rows = tuple(r for spec in cfg.joints for r in joint_rows(spec, by_name))
    try:
        assembly = assemble(made, rows, np.array(cfg.gravity))
    except (AssemblyError, ValueError) as exc:
        raise ConfigError("[[joints]]", [j.name for j in cfg.joints], str(exc)) from exc
    stepper = AssemblyStepper(assembly, StepSettings(cfg.time_step_s, cfg.rho_inf,
                                                     cfg.tolerance, cfg.max_iterations),
                              gas_loads(cfg, assembly))
    return made, assembly, stepper


def full_order_body(spec: FlexibleSpec, folder: Path, progress: Progress) -> Any:
    """Reference (a) of a flexible body: its full-order Body (``references.full_order``: every
    node of its mesh, F = I), for :func:`build_system`'s ``full_order`` — the body meshed
    into ``folder``, its K, M and Ms assembled, its node groups as the reduced model's."""
    from gcms_fenicsx.app.pipeline import assembly_stage, body_mesh, mesh_stage
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references import full_order

    plan = spec.study.plan.body
    folder.mkdir(parents=True, exist_ok=True)
    mesh = body_mesh(mesh_stage(plan.geometry, plan.mesh, folder, progress))
    model = assembly_stage(mesh.mesh, plan.material, progress=progress).model
    return full_order.full_order_body(model, group_weights(mesh, model.Vs))


def simulate_system(cfg: SystemConfig, models: dict[str, ReducedModel], folder: Path,
                    progress: Progress) -> dict:
    """Assemble, step and write ``folder``/system.h5 and the summary (rank 0): a run that
    stops early (a step fails) is written up to there, its summary ``complete`` false."""
    from gcms_fenicsx.dynamics.system.march import StoppedEarly, march
    from gcms_fenicsx.dynamics.system.stepper import initial_state

    try:
        made, assembly, stepper = build_system(cfg, models, progress=progress)
        progress(f"system: {len(made)} bodies, {assembly.dofs} coordinates, {assembly.count} "
                 f"joint rows ({len(assembly.dropped)} implied by others, dropped); stepping "
                 f"to {cfg.end_time_s:g} s at {cfg.time_step_s:g} s")
        run = march(stepper, initial_state(stepper, start_velocity(cfg, made)),
                    cfg.end_time_s, every=cfg.record_every, probes=body_probes(assembly),
                    progress=progress)
    except StoppedEarly as exc:                 # its rows so far, marked incomplete
        run = exc.run
    except (np.linalg.LinAlgError, ArithmeticError) as exc:     # one line, not a traceback
        raise ComputationFailed(
            f"the assembly could not be solved ({type(exc).__name__}: {exc}): look for a mass, "
            "a length or a time step many decades away from the others") from exc
    forces = joint_forces(assembly, run.multipliers, {j.name for j in cfg.joints})
    engine = engine_series(cfg, stepper.loads, assembly.offsets, run.time_s)
    write_system(folder / "system.h5", assembly, run, forces, engine)
    return system_summary(cfg, assembly, run, forces)


def body_probes(assembly: Any) -> dict[str, Any]:
    """Each member's coordinates, recorded as ``bodies/NAME/q``: its body's GCMS coordinates
    (B p of a member in the rotor basis)."""
    return {m.name: (lambda s, m=m, where=assembly.offsets[m.name]: m.fields(s.q[where]).ravel())
            for m in assembly.members}


def gas_loads(cfg: SystemConfig, assembly: Any) -> Any:
    """t ↦ the gas forces of ``[engine]`` on the pistons (``gas_pressure.cylinder_loads``),
    the crank angle the crankshaft drive's, risen in over the ramp time; None without an
    engine."""
    from gcms_fenicsx.dynamics.system import gas_pressure

    engine = cfg.engine
    if engine is None:
        return None
    curve = pressure_curve(engine)
    firing = gas_pressure.firing_angles(engine.firing_order, engine.first_firing_deg)
    cylinders = tuple(gas_pressure.Cylinder(piston, engine.bore_m,
                                            np.array(engine.towards_crank), firing[k + 1], curve)
                      for k, piston in enumerate(engine.pistons))
    drive = cfg.crank_drive
    gas = gas_pressure.cylinder_loads(assembly.offsets, assembly.dofs, cylinders,
                                      lambda t: math.degrees(drive.angle(t)[0]))
    T = engine.ramp_time_s
    if T == 0.0:
        return gas
    return lambda t: gas(t) * (0.5 * (1.0 - math.cos(math.pi * t / T)) if t < T else 1.0)


def rigid_twin_study(cfg: SystemConfig) -> SystemConfig:
    """The same study with every flexible body stepped as the rigid body of its mass
    properties (``as_rigid``): the assembly with its elasticity taken away."""
    from dataclasses import replace

    return replace(cfg, bodies=tuple(replace(b, as_rigid=True, damping=(0.0, 0.0))
                                     if isinstance(b, FlexibleSpec) else b for b in cfg.bodies))


def pressure_curve(engine: Any) -> Any:
    """The ``[engine]``'s pressure curve (``gas_pressure``): the built-in one or its table."""
    from gcms_fenicsx.dynamics.system import gas_pressure

    return (gas_pressure.petrol_full_load() if engine.pressure == "petrol_full_load"
            else gas_pressure.PressureCurve(*engine.pressure))


def joint_forces(assembly: Any, multipliers: np.ndarray, joints: set[str]
                 ) -> dict[str, dict[str, np.ndarray]]:
    """Each of ``joints``' force (N) and moment (N·m) on its first body: −Σ λ_k a_k over its
    rows of that kind (rows named NAME or NAME/…; ``joint_types``), a_k the rows' axes at the
    start (a rigid body's rigidity rows are not joints); a driven joint's ``drive_torque_nm``
    too: −λ of its row NAME/drive, the torque the drive puts on the body about its axis."""
    found: dict[str, dict[str, np.ndarray]] = {}
    for k, info in enumerate(assembly.rows):
        name = info.joint.split("/")[0]
        if name not in joints:
            continue
        key = "force_n" if info.kind == "force" else "moment_nm"
        entry = found.setdefault(name, {})
        entry[key] = entry.get(key, 0.0) - multipliers[:, k, None] * np.array(info.axis)
        if info.joint == f"{name}/drive":
            entry["drive_torque_nm"] = -multipliers[:, k]
    return found


def engine_series(cfg: SystemConfig, gas: Any, offsets: dict[str, slice],
                  time_s: np.ndarray) -> dict[str, np.ndarray]:
    """What ``[engine]`` did at the recorded times: ``crank_angle_deg`` (the crank drive's
    angle) and ``gas_force_n`` (times × cylinders, N towards the crank, the ramp included);
    empty without an engine."""
    engine = cfg.engine
    if engine is None:
        return {}
    drive = cfg.crank_drive
    towards = np.array(engine.towards_crank)
    forces = np.array([[gas(t)[offsets[p]].dot(towards) for p in engine.pistons]
                       for t in time_s])
    return {"crank_angle_deg": np.degrees([drive.angle(t)[0] for t in time_s]),
            "gas_force_n": forces}


def write_system(path: Path, assembly: Any, run: Any, forces: dict,
                 engine: dict[str, np.ndarray]) -> None:
    """``system.h5`` (module docstring), written atomically."""
    text = h5py.string_dtype()
    with atomic_file(path) as tmp, h5py.File(tmp, "w") as f:
        f["time_s"], f["iterations"] = run.time_s, run.iterations
        for key, values in run.energy.items():
            f[f"energy/{key}"] = values
        f["multipliers"] = run.multipliers
        f.create_dataset("rows/joint", data=[r.joint for r in assembly.rows], dtype=text)
        f.create_dataset("rows/kind", data=[r.kind for r in assembly.rows], dtype=text)
        f.create_dataset("rows/unit", data=[r.unit for r in assembly.rows], dtype=text)
        f["rows/axis"] = np.array([r.axis for r in assembly.rows]).reshape(-1, 3)
        for name, entry in forces.items():
            for key, values in entry.items():
                f[f"joints/{name}/{key}"] = values
        for key, values in engine.items():
            f[f"engine/{key}"] = values
        for name, values in run.probes.items():
            f[f"bodies/{name}/q"] = values


def system_summary(cfg: SystemConfig, assembly: Any, run: Any, forces: dict) -> dict:
    """summary.json of a system run."""
    steps_per_s = run.steps / run.wall_time_s if run.wall_time_s > 0 else None
    peak = {name: {"peak_" + key: float(np.abs(v).max() if v.ndim == 1
                                        else np.linalg.norm(v, axis=1).max())
                   for key, v in entry.items()} for name, entry in forces.items()}
    return {
        "kind": "system", "complete": run.complete, "message": run.message,
        "source": cfg.source,
        "end_time_s": float(run.time_s[-1]), "time_step_s": cfg.time_step_s,
        "steps": run.steps, "wall_time_s": run.wall_time_s, "steps_per_second": steps_per_s,
        "newton_iterations_mean": run.newton_iterations / max(run.steps, 1),
        "energy_drift_rel": run.energy_drift_rel, "velocity_change_rel": run.velocity_change,
        "coordinates": assembly.dofs,
        "bodies": {m.name: {"kind": "rigid" if getattr(spec, "as_rigid", False) else spec.kind,
                            "coordinates": m.dofs, "mass_kg": m.mass_kg,
                            **({"basis": "rotor"} if getattr(m, "coordinates_map", None)
                               is not None else {})}
                   for spec, m in zip(cfg.bodies, assembly.members)},
        "joints": {j.name: {"type": j.type, "body": j.body, "to_body": j.to_body,
                            **peak.get(j.name, {})} for j in cfg.joints},
        "dropped_rows": [r.joint for r in assembly.dropped],
    }


def system_text(summary: dict) -> str:
    """The run's lines for a person."""
    ended = "" if summary["complete"] else f" (INCOMPLETE: {summary['message']})"
    lines = [f"system: {len(summary['bodies'])} bodies, {summary['coordinates']} coordinates; "
             f"{summary['steps']} steps to {summary['end_time_s']:.4g} s{ended} in "
             f"{summary['wall_time_s']:.1f} s ({summary['steps_per_second']:,.0f} steps/s), "
             f"{summary['newton_iterations_mean']:.2f} Newton iterations a step, energy drift "
             f"{summary['energy_drift_rel']:.2e}"]
    for name, joint in summary["joints"].items():
        peaks = [f"peak force {joint['peak_force_n']:.4g} N" if "peak_force_n" in joint else "",
                 f"peak moment {joint['peak_moment_nm']:.4g} N·m"
                 if "peak_moment_nm" in joint else "",
                 f"peak drive torque {joint['peak_drive_torque_nm']:.4g} N·m"
                 if "peak_drive_torque_nm" in joint else ""]
        lines.append(f"  joint {name} ({joint['type']}): " + (", ".join(p for p in peaks if p)
                     or "every row implied by the other joints (dropped)"))
    return "\n".join(lines)

