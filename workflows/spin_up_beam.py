"""Spin-up beam: the geometrically exact SVK GCMS model against the full-order SVK reference, with
the co-rotated linear model beside them.

The published case (Kane, Ryan & Banerjee, J. Guid. Control Dyn. 10(2), 1987, also Simo &
Vu-Quoc, J. Appl. Mech. 53, 1986): a beam clamped to a hub whose rotation about the vertical
is prescribed from rest to a constant rate Ω by the cycloidal law θ̈ = (Ω/T)(1 − cos 2πt/T),
in the horizontal plane (no gravity). Their beam (L = 10 m, EI = 1.4e4 N m², ρA = 1.2 kg/m,
first clamped bending frequency ω₁ = 3.52 √(EI/ρA L⁴) = 3.80 rad/s) is spun up over T = 15 s
to Ω = 6 rad/s: Ω / ω₁ = 1.58, ω₁ T = 57. Above ω₁ a model without stress stiffening is
unstable in the rotating frame (m v̈ + (k − m Ω²) v = 0 loses its stiffness), which is the
case's point: linear floating-frame models predict a deflection that grows without bound.

Here the body is the flexible pendulum's solid beam (1 m, 20 mm square, E = 100 MPa,
ρ = 1150 kg/m³; P2 tetrahedra of 20 mm, 6,687 DOFs; a solid model of the published 10 m beam
would need 10⁵ cells through its 5 mm thickness), clamped at its end face ``end_x0`` by a revolute joint
about z whose drive follows the cycloidal law, with the published dimensionless data:
Ω = 1.58 ω₁ and T = 57 / ω₁, ω₁ from the clamped beam's first bending frequency
3.52 √(E r² / ρ L⁴) (r² = a²/12). Compared is the tip's deflection in the hub frame,
v(t) = (x_tip − R(θ) X_tip) · R(θ) e_y (transverse) and u(t) = ... · R(θ) e_x (axial), up
to t = 4T/3 (Kane et al. plot to 20 s for T = 15 s):

- reference (b): full-order Saint Venant–Kirchhoff on every FE node (``references.full_order``);
- GCMS with ``[scene] elasticity = "svk"`` for Nm eigenmodes with the clamp's attachment
  modes; the error is max_t |v − v_b| / max_t |v_b|;
- GCMS with the co-rotated linear law on the same bases, which has no stress stiffening.

    python workflows/spin_up_beam.py [--quick] [--out docs/spin_up_beam]

writes OUT.json, OUT.png and prints the table recorded in README.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: timings of one core

import math
import time
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, temporary_folder
from common import write_record

#: Kane, Ryan & Banerjee (1987): Ω = 6 rad/s, T = 15 s, ω₁ = 3.52 √(EI / ρA L⁴).
KANE_OMEGA_RAD_S, KANE_RAMP_S = 6.0, 15.0
KANE_FIRST_RAD_S = 3.52 * math.sqrt(1.4e4 / (1.2 * 10.0 ** 4))
MODE_COUNTS = (5, 10, 20)
#: Steps per period of the first bending mode, and the Newton tolerance of every run: 1e-7 of
#: the body's size is 30 nm, 1e-5 of the tip deflection. Reference (b) iterates with the
#: linear iteration matrix (it has no tangent): at 400 steps per period its Newton slows down
#: towards the end of the ramp (257 iterations at t = 9.50 s) and does not converge at
#: 9.53 s in 400; at 800 it takes 2.9 iterations per step on average, none more than 15.
STEPS_PER_PERIOD = 800
TOLERANCE = 1e-7


def case_study(quick: bool) -> tuple[dict, dict]:
    """The study tables and the case's numbers (ω₁, Ω, T, end time, step)."""
    from gcms_fenicsx.references import pendulum

    geometry, material = pendulum.STUDY["geometry"], pendulum.STUDY["material"]
    r2 = geometry["side"] ** 2 / 12.0
    first = 3.52 * math.sqrt(material["E"] * r2 / (material["rho"] * geometry["length"] ** 4))
    omega = KANE_OMEGA_RAD_S / KANE_FIRST_RAD_S * first
    ramp = KANE_FIRST_RAD_S * KANE_RAMP_S / first
    end = (0.5 if quick else 4.0 / 3.0) * ramp
    step = 2.0 * math.pi / first / STEPS_PER_PERIOD
    study = dict(pendulum.STUDY, mesh={"size": 0.02, "order": 2},
                 modes={"count": max(MODE_COUNTS)}, basis={"attachment": "scene"},
                 scene={"end_time": end, "time_step": step, "rho_inf": 0.8,
                        "elasticity": "svk",
                        "solver": {"tolerance": TOLERANCE, "max_iterations": 100},
                        "joints": [{"type": "revolute", "group": "end_x0", "axis": [0, 0, 1],
                                    "drive": {"angular_velocity": omega, "ramp_time": ramp,
                                              "ramp": "cycloidal"}}],
                        "outputs": {"groups": ["end_xL"]}})
    numbers = {"first_bending_rad_s": first, "omega_rad_s": omega, "ramp_time_s": ramp,
               "end_time_s": end, "time_step_s": step, "omega_over_first": omega / first,
               "first_times_ramp": first * ramp,
               "kane": {"omega_rad_s": KANE_OMEGA_RAD_S, "ramp_time_s": KANE_RAMP_S,
                        "first_bending_rad_s": KANE_FIRST_RAD_S}}
    return study, numbers


def tip_in_hub_frame(traj, drive, tip0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v): the tip's axial and transverse deflection in the hub frame at each recorded time."""
    from gcms_fenicsx.numerics.rotation import rotation_about

    u, v = [], []
    for t, x in zip(traj.time, traj.groups["end_xL"]["position"]):
        R = rotation_about(np.array([0.0, 0.0, 1.0]), drive.angle(t)[0])
        d = R.T @ x - tip0
        u.append(d[0])
        v.append(d[1])
    return np.array(u), np.array(v)


def main() -> None:
    args = parser(__doc__, out="docs/spin_up_beam",
                  quick="half the ramp (a smoke run)").parse_args()
    quiet()
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.dynamics.bodies.svk import SVKLaw, svk_state
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.fe.svk_coefficients import svk_coefficients
    from gcms_fenicsx.references.full_order import (full_order_body, sparse_factorization,
                                                    svk_elastic)

    study, numbers = case_study(args.quick)
    cfg = parse_config(study, "spin-up beam")
    scene = cfg.scene
    drive = scene.joints[0].drive
    log(f"ω₁ = {numbers['first_bending_rad_s']:.3f} rad/s, Ω = {numbers['omega_rad_s']:.3f} "
        f"rad/s, T = {numbers['ramp_time_s']:.2f} s, h = {numbers['time_step_s']:.2e} s, "
        f"{scene.steps} steps")
    with temporary_folder() as tmp:
        chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, tmp)
    model, body_mesh = chain.assembly.model, chain.body
    full = full_order_body(model, group_weights(body_mesh, model.Vs))
    tip0 = full.groups["end_xL"].center_m

    def run(body, **kwargs) -> dict:
        law = "svk" if "elastic" in kwargs else "corotated"
        t0 = time.perf_counter()
        traj, summary = simulate_body(body, replace(scene, elasticity=law), **kwargs)
        wall = time.perf_counter() - t0
        u, v = tip_in_hub_frame(traj, drive, tip0)
        return {"time": traj.time, "u": u, "v": v, "wall_s": wall, "complete": summary["complete"],
                "message": summary["message"], "steps_per_second": summary["steps_per_second"],
                "newton_iterations_mean": summary["newton_iterations_mean"]}

    ref = run(full, factorize=sparse_factorization, elastic=svk_elastic(model, full))
    if not ref["complete"]:
        raise SystemExit(f"reference (b) stopped: {ref['message']}")
    log(f"reference (b), SVK on {full.dofs} DOFs: {ref['wall_s']:.0f} s, tip |v| up to "
        f"{np.abs(ref['v']).max() * 1e3:.2f} mm")
    scale = np.abs(ref["v"]).max()
    rows, curves = [], {"time": ref["time"].tolist(), "b": ref["v"].tolist()}
    basis = pipeline.basis_stage(model, chain.modes, body_mesh)
    for nm in MODE_COUNTS:
        reduced = pipeline.reduction_stage(basis.lowest(nm), cfg.selection)
        body = body_from_reduced(reduced)
        coefficients, report = svk_coefficients(body_mesh.mesh, reduced.fields, cfg.material)
        law = SVKLaw.of(coefficients, body)
        for elasticity, kwargs in (("svk", {"elastic": partial(svk_state, body, law)}),
                                   ("corotated", {})):
            r = run(body, **kwargs)
            k = min(len(r["v"]), len(ref["v"]))
            row = {"elasticity": elasticity, "modes": nm, "attachment": "scene",
                   "coordinates": body.dofs, "complete": r["complete"], "message": r["message"],
                   "time_reached_s": float(r["time"][-1]),
                   "error_vs_b": float(np.abs(r["v"][:k] - ref["v"][:k]).max() / scale),
                   "max_tip_deflection_m": float(np.abs(r["v"]).max()),
                   "wall_s": r["wall_s"], "steps_per_second": r["steps_per_second"],
                   "newton_iterations_mean": r["newton_iterations_mean"],
                   "coefficients_s": report["seconds"], "coefficients_bytes": report["bytes"]}
            rows.append(row)
            curves[f"{elasticity}{nm}"] = r["v"].tolist()
            log(f"  {elasticity}, Nm = {nm} + attachment: {body.dofs} coordinates, "
                f"error vs (b) {row['error_vs_b']:.2%} up to t = {row['time_reached_s']:.2f} s"
                f"{'' if r['complete'] else ' (stopped: ' + r['message'][:80] + ')'}")
    document = {"case": numbers, "mesh_size_m": cfg.mesh.size, "full_dofs": full.dofs,
                "reference_b": {"wall_s": ref["wall_s"], "max_tip_deflection_m": float(scale),
                                "newton_iterations_mean": ref["newton_iterations_mean"]},
                "rows": rows, "curves": curves}
    write_record(Path(f"{args.out}.json"), document)
    plot(document, Path(f"{args.out}.png"))
    print(table(document))


def table(document: dict) -> str:
    c = document["case"]
    lines = [f"Ω = {c['omega_rad_s']:.3f} rad/s = {c['omega_over_first']:.2f} ω₁, "
             f"T = {c['ramp_time_s']:.2f} s (ω₁T = {c['first_times_ramp']:.0f}), "
             f"h = {c['time_step_s']:.2e} s; reference (b): {document['full_dofs']:,} DOFs, "
             f"{document['reference_b']['wall_s']:.0f} s, tip deflection up to "
             f"{document['reference_b']['max_tip_deflection_m'] * 1e3:.2f} mm", "",
             *table_head("elasticity", "Nm + attachment", "coordinates", "reached t s",
                         "error vs (b)", "max tip deflection mm", "steps/s")]
    for r in document["rows"]:
        lines.append(f"| {r['elasticity']} | {r['modes']} | {r['coordinates']} "
                     f"| {r['time_reached_s']:.2f}{'' if r['complete'] else ' (stopped)'} "
                     f"| {r['error_vs_b']:.2%} | {r['max_tip_deflection_m'] * 1e3:.2f} "
                     f"| {r['steps_per_second']:.0f} |")
    return "\n".join(lines)


def plot(document: dict, path: Path) -> None:
    plt = pyplot()
    c = document["curves"]
    t = np.array(c["time"])
    fig, ax = plt.subplots(figsize=(9, 4.8))
    ax.plot(t, 1e3 * np.array(c["b"]), "k-", lw=2, label="(b) full-order SVK")
    for key, style in (("svk10", "C0--"), ("svk20", "C2:"), ("corotated10", "C3-.")):
        if key in c:
            v = np.array(c[key])
            ax.plot(t[:len(v)], 1e3 * v, style, lw=1.3,
                    label=f"GCMS {key.rstrip('0123456789')}, Nm = "
                          f"{key.lstrip('corotatedsvk')} + attachment")
    ax.axvline(document["case"]["ramp_time_s"], color="0.5", lw=0.7)
    scale = 1e3 * document["reference_b"]["max_tip_deflection_m"]
    ax.set_ylim(-1.4 * scale, 0.6 * scale)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tip transverse deflection in the hub frame [mm]")
    ax.set_title("spin-up beam (Kane, Ryan & Banerjee 1987, scaled)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save_figure(fig, path, dpi=100)


if __name__ == "__main__":
    main()
