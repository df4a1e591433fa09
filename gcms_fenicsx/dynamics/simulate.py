"""A scene on a body: initial state, joints, loads, the time loop, and what it recorded.

``simulate(model, scene)`` runs a scene on an exported reduced model; ``simulate_body`` on
any :class:`~gcms_fenicsx.dynamics.body.Body` (the full-order reference uses it with sparse
matrices). A failure inside the run — Newton not converging, a non-finite or inverted
state — does not raise: the results up to the last converged step are returned, marked
incomplete, with the message.
"""
from __future__ import annotations

import time
from dataclasses import asdict

import numpy as np

from gcms_fenicsx.dynamics.body import Body, body_from_reduced
from gcms_fenicsx.dynamics.corotated import elastic_state
from gcms_fenicsx.dynamics.integrator import (Elastic, Factorize, GeneralizedAlpha,
                                              IntegrationError, dense_factorization)
from gcms_fenicsx.dynamics.joints import build_constraints
from gcms_fenicsx.dynamics.loads import external_forces
from gcms_fenicsx.dynamics.recorder import Recorder
from gcms_fenicsx.dynamics.results import Trajectory, energy_drift
from gcms_fenicsx.dynamics.rotation import InvertedBodyError
from gcms_fenicsx.dynamics.scene import Initial, Scene, SceneError
from gcms_fenicsx.progress import Progress, quiet
from gcms_fenicsx.reduced_model import ReducedModel

PROGRESS_INTERVAL_S = 2.0


def elastic_modes(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and Mr-orthonormal eigenvectors of (Kr, Mr), ascending (dense bodies).

    With L Lᵀ = Mr: L⁻¹ Kr L⁻ᵀ y = λ y and ψ = L⁻ᵀ y. The first six are the rigid modes.
    """
    L_inv = np.linalg.inv(np.linalg.cholesky(np.asarray(body.mass)))
    A = L_inv @ np.asarray(body.stiffness) @ L_inv.T
    lam, Y = np.linalg.eigh(0.5 * (A + A.T))
    return lam, L_inv.T @ Y


def modal_history(body: Body, q: np.ndarray, mode: int) -> np.ndarray:
    """ψ_modeᵀ Mr (vec(Q_loc) − q0) along recorded coordinates q (steps × n): the co-rotated
    coordinate of elastic mode ``mode`` (1-based; ψ Mr-orthonormal, so rigid motion and the
    other modes drop out)."""
    _, psi = elastic_modes(body)
    w = body.mass @ psi[:, 5 + mode]
    return np.array([w @ (elastic_state(body, qk).local.ravel() - body.q0) for qk in q])


def initial_coordinates(body: Body, initial: Initial) -> np.ndarray:
    """q0, plus the requested elastic mode scaled to a largest nodal displacement of amplitude."""
    if initial.mode is None:
        return body.q0.copy()
    lam, psi = elastic_modes(body)
    index = 5 + initial.mode
    if index >= len(lam):
        raise SceneError(f"[scene.initial] mode = {initial.mode}: the reduced model has "
                         f"{len(lam) - 6} elastic modes")
    shape = psi[:, index]
    largest = float(np.max(np.linalg.norm(body.displacement(body.q0 + shape), axis=1)))
    return body.q0 + initial.amplitude_m / largest * shape


def simulate_body(body: Body, scene: Scene, *, factorize: Factorize = dense_factorization,
                  elastic: Elastic | None = None, progress: Progress = quiet,
                  model_hash: str = "") -> tuple[Trajectory, dict]:
    """Run ``scene`` on ``body``: the recorded trajectory and the summary (``summary.json``).

    ``factorize`` and ``elastic`` as in :class:`~gcms_fenicsx.dynamics.integrator.GeneralizedAlpha`.
    """
    scene.check_groups(body.groups)
    t_setup = time.perf_counter()
    q = initial_coordinates(body, scene.initial)
    constraints = build_constraints(body, scene.joints, q)
    forces = external_forces(body, scene.gravity, scene.loads)
    integrator = GeneralizedAlpha(body, constraints, forces, scene.time_step_s, scene.rho_inf,
                                  (scene.damping_alpha, scene.damping_beta), scene.solver,
                                  factorize, elastic)
    v_rigid = body.rigid_velocity(q, np.array(scene.initial.velocity),
                                  np.array(scene.initial.angular_velocity))
    v = integrator.project_velocity(0.0, q, v_rigid)
    kinetic_given = 0.5 * float(v_rigid @ (body.mass @ v_rigid))
    kinetic_kept = 0.5 * float(v @ (body.mass @ v))
    try:
        state, info = integrator.start(q, v)
    except InvertedBodyError as exc:
        raise SceneError(f"[scene.initial] the initial state inverts the body: {exc}; lower "
                         "amplitude") from exc
    steps = scene.steps
    recorder = Recorder(body, constraints, forces, scene.outputs, steps, scene.time_step_s)
    recorder.step(0, state, info)
    setup_s = time.perf_counter() - t_setup

    progress(f"simulate: {steps} steps of {scene.time_step_s:g} s, {body.dofs} coordinates, "
           f"{constraints.count} constraint rows")
    complete, message, done = True, "", 0
    iterations = 0
    start = last_report = time.perf_counter()
    for index in range(1, steps + 1):
        try:
            state, info = integrator.step(state)
        except IntegrationError as exc:
            complete, message = False, str(exc)
            break
        except InvertedBodyError as exc:
            complete, message = False, f"at t = {state.t + scene.time_step_s:.6g} s: {exc}"
            break
        done = index
        iterations += info.iterations
        recorder.step(index, state, info, last=index == steps)
        now = time.perf_counter()
        if now - last_report > PROGRESS_INTERVAL_S:
            last_report = now
            progress(f"simulate: t = {state.t:.4g} / {scene.end_time_s:g} s ({index} steps, "
                   f"{index / (now - start):.0f} steps/s)")
    wall = time.perf_counter() - start
    if not complete and recorder.time[recorder.k - 1] != state.t:
        recorder.record(state, info)   # the last converged state, not yet written
    rows = [asdict(r) for r in constraints.rows]
    traj = recorder.trajectory(rows)
    traj.complete, traj.message, traj.model_hash = complete, message, model_hash
    traj.scene = asdict(scene)
    p = traj.momentum["linear"]
    summary = {
        "complete": complete,
        "message": message,
        "steps": done,
        "steps_planned": steps,
        "time_reached_s": float(state.t),
        "end_time_s": scene.end_time_s,
        "time_step_s": scene.time_step_s,
        "rho_inf": scene.rho_inf,
        "wall_time_s": wall,
        "setup_time_s": setup_s,
        "steps_per_second": done / wall if done and wall > 0 else None,
        "time_per_step_us": 1e6 * wall / done if done else None,
        "reduced_dofs": body.dofs,
        "constraint_rows": constraints.count,
        "newton_iterations_mean": iterations / done if done else None,
        "newton_iterations_max": int(traj.newton_iterations.max(initial=0)),
        "jacobian": scene.solver.jacobian,
        "energy_drift_rel": energy_drift(traj.energy) if len(traj.time) > 1 else None,
        "linear_momentum_change": float(np.abs(p - p[0]).max()) if len(p) else 0.0,
        "initial_kinetic_energy_j": kinetic_kept,
        "initial_kinetic_energy_removed_by_joints_j": kinetic_given - kinetic_kept,
        "model_hash": model_hash,
    }
    return traj, summary


def simulate(model: ReducedModel, scene: Scene,
             progress: Progress = quiet) -> tuple[Trajectory, dict]:
    """Run ``scene`` on an exported reduced model."""
    return simulate_body(body_from_reduced(model), scene, progress=progress,
                         model_hash=model.input_hash)
