"""A scene on a body: initial state, joints, loads, the time loop, and what it recorded.

``simulate(model, scene)`` runs a scene on an exported reduced model and keeps what it
records in memory; ``simulate_to_file(model, scene, path)`` streams it into ``results.h5``
instead (its memory does not grow with the run); ``simulate_body`` runs on any
:class:`~gcms_fenicsx.dynamics.bodies.body.Body` (the full-order reference uses it with sparse
matrices). Before anything is allocated or stepped, the size of the results is estimated and
a run whose results exceed the free disk space (file) or the available memory (in memory) is
refused (``budget``). A failure inside the run — Newton not converging or diverging, a
non-finite state — does not raise: the results up to the last converged step are returned
(or written), marked incomplete, with the message.

Every number of the summary is finite or None (JSON without NaN or Infinity).
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np

from gcms_fenicsx.config.basis import AttachmentLoad, ScenePatterns
from gcms_fenicsx.dynamics.bodies.body import Body, body_from_reduced, elastic_modes
from gcms_fenicsx.dynamics.run.capacity import (Capacity, check_capacity, disk_capacity,
                                          format_bytes, memory_capacity)
from gcms_fenicsx.dynamics.bodies.corotated import elastic_state
from gcms_fenicsx.dynamics.bodies.damping import RayleighDamping
from gcms_fenicsx.dynamics.constraints.factorization import (Factorize, dense_factorization,
                                                 mass_factorization)
from gcms_fenicsx.dynamics.stepping.initial import (ModeStart, consistent_state, consistent_velocity,
                                           initial_coordinates, initial_start)
from gcms_fenicsx.dynamics.stepping.integrator import GeneralizedAlpha
from gcms_fenicsx.dynamics.stepping.kernel import CompiledStepper, KernelChoice, choose_kernel
from gcms_fenicsx.dynamics.run.march import Start, Stepped, march, warm_up
from gcms_fenicsx.dynamics.stepping.state import Elastic, State, StepInfo
from gcms_fenicsx.dynamics.constraints.joints import Constraints, build_constraints
from gcms_fenicsx.dynamics.bodies.loads import ExternalForces, external_forces
from gcms_fenicsx.dynamics.run.recorder import Extremes, Recorder, RecordPlan, record_plan
from gcms_fenicsx.dynamics.run.stress_recovery import StressRecovery, StressSetup, stress_setup
from gcms_fenicsx.files.results import (MemorySink, ResultsWriter, RunInfo, Series, Sink,
                                        Trajectory)
from gcms_fenicsx.files.stress_fields import write_stress_fields
from gcms_fenicsx.files.stress_nodes import StressNodes
from gcms_fenicsx.numerics.rotation import InvertedBodyError
from gcms_fenicsx.dynamics.bodies.rotor import RotorBody
from gcms_fenicsx.dynamics.bases.run_basis import in_basis, rotor_summary
from gcms_fenicsx.config.scene import Scene, SceneError
from gcms_fenicsx.dynamics.constraints.statics import KKTSolve, dense_kkt_solve, static_equilibrium
from gcms_fenicsx.dynamics.bodies.svk import CoefficientsError, SVKLaw, svk_state
from gcms_fenicsx.files.outputs import atomic_file, finite_json
from gcms_fenicsx.files.versioned import created
from gcms_fenicsx.runtime.progress import Progress, quiet
from gcms_fenicsx.files.reduced_model import ReducedModel, ReducedModelError

__all__ = ["elastic_modes", "initial_coordinates", "modal_history", "simulate",
           "simulate_body", "simulate_to_file"]

#: Opens the sink a run records into, once its plan is known.
OpenSink = Callable[[RecordPlan], Sink]


def modal_history(body: Body, q: np.ndarray, mode: int) -> np.ndarray:
    """ψ_modeᵀ Mr (vec(Q_loc) − q0) along recorded coordinates q (steps × n): the co-rotated
    coordinate of elastic mode ``mode`` (1-based; ψ Mr-orthonormal, so rigid motion and the
    other modes drop out)."""
    _, psi = elastic_modes(body)
    w = body.mass @ psi[:, 5 + mode]
    return np.array([w @ (elastic_state(body, qk).local.ravel() - body.q0) for qk in q])


def simulate_body(body: Body | RotorBody, scene: Scene, *,
                  factorize: Factorize = dense_factorization,
                  elastic: Elastic | None = None, progress: Progress = quiet,
                  model_hash: str = "", kkt_solve: KKTSolve = dense_kkt_solve,
                  stress: StressSetup | None = None) -> tuple[Trajectory, dict]:
    """Run ``scene`` on ``body``: the recorded trajectory (in memory) and the summary
    (``summary.json``). ``factorize`` and ``elastic`` as in
    :class:`~gcms_fenicsx.dynamics.stepping.integrator.GeneralizedAlpha`; ``elastic`` is given exactly
    when the scene's ``elasticity`` is not the co-rotated law (SceneError otherwise), so the
    summary names the law that ran. ``kkt_solve`` solves the held body's statics of an
    equilibrium start (``statics``; sparse for the full-order model); with ``stress`` the
    scene's stresses are recovered into the trajectory (``stress_recovery``; the whole-body
    fields are not written)."""
    nodes = _full(body).nodes_m

    def open_sink(plan: RecordPlan) -> Sink:
        return MemorySink(plan.layout, plan.rows, nodes if plan.snapshot_steps else None)

    recovery = StressRecovery(stress, _full(body), scene.elasticity) if stress else None
    summary, traj = _run(body, scene, open_sink, memory_capacity(), factorize=factorize,
                         elastic=elastic, progress=progress, model_hash=model_hash,
                         kkt_solve=kkt_solve, stress=recovery)
    assert traj is not None
    return traj, summary


def elastic_law(model: ReducedModel, body: Body, scene: Scene) -> Elastic | None:
    """The integrator's ``elastic`` callable for the scene's ``elasticity``: None for the
    co-rotated law, the Saint Venant–Kirchhoff forces of the model's coefficients for "svk"
    (SceneError if the model has none)."""
    if scene.elasticity != "svk":
        return None
    if model.svk is None:
        raise SceneError('[scene] elasticity = "svk" needs the Saint Venant–Kirchhoff '
                         "coefficients in the reduced model, and this one has none (schema "
                         f"{model.schema_version}); reduce the body again with this scene "
                         "(gcms reduce or gcms run with the same study)")
    try:
        law = SVKLaw.of(model.svk, body)
    except CoefficientsError as exc:
        raise ReducedModelError(f"reduced model: {exc}") from exc
    return partial(svk_state, body, law)


def simulate(model: ReducedModel, scene: Scene, progress: Progress = quiet, basis: str = "full",
             attachment: tuple[Any, ...] = (), static: Any = None,
             stress_nodes: StressNodes | None = None) -> tuple[Trajectory, dict]:
    """Run ``scene`` on an exported reduced model, keeping the results in memory; ``basis``,
    ``attachment`` and ``static`` as in ``run_basis.in_basis``, ``stress_nodes`` the stress
    modes' mesh part when the scene asks for stresses."""
    body = body_from_reduced(model)
    elastic = elastic_law(model, body, scene)
    run_body = in_basis(model, body, scene, basis, attachment, progress, static)
    traj, summary = simulate_body(run_body, scene, elastic=elastic, progress=progress,
                                  model_hash=model.input_hash,
                                  stress=stress_setup(model, scene, stress_nodes))
    return traj, dict(summary, **shapes_summary(static))


def simulate_to_file(model: ReducedModel, scene: Scene, path: Path, progress: Progress = quiet,
                     basis: str = "full", attachment: tuple[AttachmentLoad, ...] = (),
                     static: ScenePatterns | None = None,
                     stress_nodes: StressNodes | None = None) -> dict:
    """Run ``scene`` on an exported reduced model, streaming the results into ``path``
    (a temporary file beside it, renamed when the run ends, complete or not); the summary.
    ``basis``, ``attachment`` and ``static`` as in ``run_basis.in_basis``; with
    ``stress_nodes`` (a scene asking for stresses) the stresses are recovered, and the
    whole-body ones written beside ``path`` (``stress_fields``)."""
    body = body_from_reduced(model)
    elastic = elastic_law(model, body, scene)
    run_body = in_basis(model, body, scene, basis, attachment, progress, static)
    setup = stress_setup(model, scene, stress_nodes)
    recovery = StressRecovery(setup, _full(run_body), scene.elasticity) if setup else None
    with atomic_file(path) as tmp, created(tmp) as f:
        def open_sink(plan: RecordPlan) -> Sink:
            return ResultsWriter(f, plan.layout, plan.block_rows,
                                 body.nodes_m if plan.snapshot_steps else None)

        summary, _ = _run(run_body, scene, open_sink, disk_capacity(tmp.parent),
                          factorize=dense_factorization, elastic=elastic, progress=progress,
                          model_hash=model.input_hash, stress=recovery)
    if recovery is not None and recovery.fields:
        write_stress_fields(path.parent, _full(run_body).nodes_m, setup.nodes.cells,
                            recovery.fields)
    return dict(summary, **shapes_summary(static))


def shapes_summary(static: ScenePatterns | None) -> dict:
    """What the body deformed along (``[basis] shapes``): "modes", or "static" with the load
    patterns of its static shapes and the band of its held modes (``run_basis.in_basis``)."""
    if static is None:
        return {"shapes": "modes", "static_patterns": [], "static_band_hz": None}
    return {"shapes": "static", "static_patterns": [load.label for load in static.loads],
            "static_band_hz": static.band_hz}


@dataclass(frozen=True)
class Prepared:
    """A run set up and checked, before its first step: the joints' independent rows, what it
    will record, the stepper and the consistent initial state."""

    constraints: Constraints
    plan: RecordPlan
    forces: ExternalForces
    integrator: GeneralizedAlpha
    state: State
    info: StepInfo
    kinetic_given_j: float   # of the initial velocity asked for
    kinetic_kept_j: float    # of the one the joints allow
    start: ModeStart | None  # how the initial mode was shaped (None without one)
    kernel: KernelChoice     # the compiled step or NumPy's (``stepping.kernel``)
    stepper: CompiledStepper | None

    def warnings(self, scene: Scene) -> list[str]:
        """The scene's warnings and the initial mode's (``ModeStart.warning``)."""
        warning = self.start.warning() if self.start is not None else None
        return scene.warnings() + ([warning] if warning else [])


def _full(body: Body | RotorBody) -> Body:
    """The body in the full basis: itself, or the one a rotor body's coordinates map into."""
    return body.full if isinstance(body, RotorBody) else body


def _run(body: Body | RotorBody, scene: Scene, open_sink: OpenSink, capacity: Capacity, *,
         factorize: Factorize, elastic: Elastic | None, progress: Progress,
         model_hash: str, kkt_solve: KKTSolve = dense_kkt_solve,
         stress: StressRecovery | None = None) -> tuple[dict, Trajectory | None]:
    """Set up, step, record into the sink ``open_sink`` gives: the summary and what the sink
    returns when closed."""
    full = _full(body)
    scene.check_groups(full.groups)
    if (elastic is None) != (scene.elasticity == "corotated"):
        raise SceneError(f'[scene] elasticity = "{scene.elasticity}" '
                         + ("needs its law's forces (simulate a reduced model that has its "
                            "coefficients)" if elastic is None else
                            "runs the co-rotated law, and another elastic law was given"))
    t_setup = time.perf_counter()
    run = prepare_run(body, scene, capacity, factorize, elastic, progress, kkt_solve,
                      stress.layout() if stress else ())
    if stress and len(run.plan.stress_steps) < len(set(stress.setup.outputs.times)):
        progress(f"note: [scene.outputs] stress_times: {len(set(stress.setup.outputs.times))} "
                 f"times "
                 f"fall on {len(run.plan.stress_steps)} steps of {scene.time_step_s:g} s; "
                 "each step's stress is written once")
    sink = open_sink(run.plan)
    recorder = Recorder(full, run.constraints, run.forces, scene.outputs, run.plan,
                        scene.time_step_s, sink,
                        body.coordinates if isinstance(body, RotorBody) else None, stress)
    recorder.step(0, run.state, run.info)
    setup_s = time.perf_counter() - t_setup
    kernel, stepper = warm_up(run.kernel, run.stepper, recorder, run.state, progress,
                              scene.solver.kernel)
    stepped = march(Start(run.integrator, run.state, run.info, run.plan.steps,
                          run.plan.snapshot_steps | run.plan.stress_steps, scene.end_time_s),
                    recorder, progress, stepper)
    if not stepped.complete and recorder.last_time != stepped.state.t:
        recorder.record(stepped.state, stepped.info)   # the last converged state
    recorder.flush()
    for name, data in (stress.datasets() if stress else {}).items():
        sink.put(name, data)
    rows = finite_json([asdict(r) for r in run.constraints.rows]) \
        if scene.outputs.constraint_forces and run.constraints.count else []  # as JSON reads
    traj = sink.close(RunInfo(stepped.complete, stepped.message, model_hash, asdict(scene), rows))
    summary = _summary(body, scene, run, stepped, recorder.extremes, setup_s, model_hash, kernel)
    return dict(summary, stress=finite_json(stress.summary()) if stress else None), traj


def prepare_run(body: Body | RotorBody, scene: Scene, capacity: Capacity,
                factorize: Factorize = dense_factorization, elastic: Elastic | None = None,
                progress: Progress = quiet, kkt_solve: KKTSolve = dense_kkt_solve,
                stress: tuple[Series, ...] = ()) -> Prepared:
    """Initial coordinates, Mr⁻¹, the independent joint rows, the results' budget (refused
    before anything is allocated if over ``capacity``), the stepper and the initial state.
    A rotor body starts from the rotor coordinates nearest the full basis's initial state
    (its velocity: nearest in kinetic energy; the rest is removed as the joints remove it).
    With ``[scene.initial] equilibrium`` the body starts at rest in its held static
    equilibrium under the forces at t = 0 (``statics.static_equilibrium``, in its own
    coordinates and law; the bordered systems solved by ``kkt_solve``)."""
    for warning in scene.warnings():
        progress(f"warning: {warning}")
    full = _full(body)
    q_full, start = initial_start(full, scene.initial)
    if start is not None:
        progress(start.line())
        warning = start.warning()
        if warning:
            progress(f"warning: {warning}")
    q = body.project(q_full)[0] if isinstance(body, RotorBody) else q_full
    if elastic is not None and scene.initial.mode is not None:
        warning = nonlinear_start(body, elastic, q, scene)
        if warning:
            progress(f"warning: {warning}")
    mass_solve = mass_factorization(body, factorize)
    constraints = build_constraints(body, scene.joints, q, mass_solve)
    if constraints.dropped:
        progress(f"joints: {len(constraints.dropped)} constraint rows dropped, implied by the "
                 f"rows of earlier joints: {_rows_text(constraints)}")
    plan = record_plan(full, constraints, scene, stress)
    check_capacity(plan, capacity, scene)
    progress(f"simulate: {plan.steps} steps of {scene.time_step_s:g} s, {body.dofs} "
             f"coordinates, {constraints.count} constraint rows; {plan.rows} recorded rows and "
             f"{len(plan.snapshot_steps)} field snapshots, {format_bytes(plan.total_bytes)} "
             f"(limit {format_bytes(capacity.bytes)} {capacity.what})")
    forces = external_forces(full, scene.gravity, scene.loads)
    if isinstance(body, RotorBody):
        B = body.coordinates
        forces = ExternalForces(B.T @ forces.gravity_force, B.T @ forces.load_vectors,
                                forces.loads)
    damping = RayleighDamping(scene.damping_alpha, scene.damping_beta)
    integrator = GeneralizedAlpha(body, constraints, forces, scene.time_step_s, scene.rho_inf,
                                  damping, scene.solver, factorize, elastic)
    if scene.initial.equilibrium:
        q, steps = static_equilibrium(body, constraints, forces, integrator.elastic, q,
                                      integrator.tolerance_m, kkt_solve)
        progress(f"initial state: at rest in its static equilibrium under the forces at t = 0 "
                 f"({steps} Newton step{'s' if steps > 1 else ''})")
        q_full = body.coordinates @ q if isinstance(body, RotorBody) else q
    v_rigid = full.rigid_velocity(q_full, np.array(scene.initial.velocity),
                                  np.array(scene.initial.angular_velocity))
    kinetic_given = 0.5 * float(v_rigid @ (full.mass @ v_rigid))
    if isinstance(body, RotorBody):
        v_rigid = body.projector @ v_rigid
    v = consistent_velocity(body, constraints, mass_solve, 0.0, q, v_rigid)
    try:
        state, info = consistent_state(body, constraints, forces, integrator.elastic, damping,
                                       mass_solve, q, v)
    except InvertedBodyError as exc:
        raise SceneError(f"[scene.initial] the initial state inverts the body: {exc}; lower "
                         "amplitude") from exc
    kernel, stepper = choose_kernel(integrator, scene.solver.kernel, progress)
    return Prepared(constraints=constraints, plan=plan, forces=forces, integrator=integrator,
                    state=state, info=info,
                    kinetic_given_j=kinetic_given,
                    kinetic_kept_j=0.5 * float(v @ (body.mass @ v)), start=start,
                    kernel=kernel, stepper=stepper)


#: An initial mode shape whose energy under another elastic law differs from the linear one
#: by more than this fraction is reported (``nonlinear_start``).
NONLINEAR_START = 0.1


def nonlinear_start(body: Body, elastic: Elastic, q: np.ndarray, scene: Scene) -> str | None:
    """A warning if the initial mode shape q (a linear eigenvector scaled to the scene's
    amplitude) has an energy under ``elastic`` more than NONLINEAR_START away from its
    co-rotated linear one: a geometrically exact law sees the fibres a linear mode shape turns
    by θ stretched by ½θ², so the run starts with that energy in stiff axial motion. The
    amplitude that keeps it within bounds is found by halving."""
    def ratio(scale: float) -> float:
        shape = body.q0 + scale * (q - body.q0)
        linear = elastic_state(body, shape).energy
        return elastic(shape).energy / linear if linear > 0 else 1.0

    excess = ratio(1.0)
    if abs(excess - 1.0) <= NONLINEAR_START:
        return None
    scale = 1.0
    while abs(ratio(scale) - 1.0) > NONLINEAR_START and scale > 1e-6:
        scale /= 2.0                       # the excess grows with the amplitude: halve it
    amplitude = scene.initial.amplitude_m
    return (f"[scene.initial] mode {scene.initial.mode} at amplitude {amplitude:g} m has "
            f"{excess:.3g} times its linear elastic energy under elasticity = "
            f'"{scene.elasticity}" (a linear mode shape stretches the fibres it turns): the run '
            "starts with that energy in stiff axial vibration, not in the mode; an amplitude of "
            f"{scale * amplitude:.2g} m keeps the two within {NONLINEAR_START:.0%}")


def _summary(body: Body | RotorBody, scene: Scene, run: Prepared, stepped: Stepped,
             extremes: Extremes, setup_s: float, model_hash: str,
             kernel: KernelChoice) -> dict:
    """``summary.json``: finite numbers or None."""
    done, wall = stepped.steps, stepped.wall_s
    return finite_json({
        "complete": stepped.complete,
        "message": stepped.message,
        "steps": done,
        "steps_planned": run.plan.steps,
        "time_reached_s": float(stepped.state.t),
        "end_time_s": scene.end_time_s,
        "time_step_s": scene.time_step_s,
        "rho_inf": scene.rho_inf,
        "wall_time_s": wall,
        "setup_time_s": setup_s,
        "steps_per_second": done / wall if done and wall > 0 else None,
        "time_per_step_us": 1e6 * wall / done if done else None,
        "reduced_dofs": body.dofs,
        "constraint_rows": run.constraints.count,
        "constraint_rows_dropped": [asdict(r) for r in run.constraints.dropped],
        "recorded_rows": extremes.rows,
        "newton_iterations_mean": stepped.newton_iterations / done if done else None,
        "newton_iterations_max": extremes.iterations,
        "jacobian": scene.solver.jacobian,
        "kernel": kernel.summary(),
        "elasticity": scene.elasticity,
        "basis": "rotor" if isinstance(body, RotorBody) else "full",
        "rotor_basis": rotor_summary(body) if isinstance(body, RotorBody) else None,
        "energy_drift_rel": extremes.energy_drift,
        "energy_drift_abs_j": extremes.energy_drift_j,
        "linear_momentum_change": extremes.momentum_change,
        "initial_kinetic_energy_j": run.kinetic_kept_j,
        "initial_kinetic_energy_removed_by_joints_j": run.kinetic_given_j - run.kinetic_kept_j,
        "model_hash": model_hash,
        "warnings": run.warnings(scene),
        "initial_mode": run.start.summary() if run.start is not None else None,
    })


def _rows_text(constraints: Constraints) -> str:
    """The dropped rows, as "joint kind [axis], …"."""
    return ", ".join(f"{r.joint} {r.kind} {np.round(r.axis, 3).tolist()}"
                     for r in constraints.dropped)
