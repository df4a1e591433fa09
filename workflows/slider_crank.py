"""The flexible slider crank of the IVP Test Set with a 3D GCMS conrod, against the ported
benchmark, the full-order conrod and the rigid mechanism's closed form.

The mechanism (``references.slider_crank_assembly``): the rigid crank (0.15 m) driven at
150 rad/s, the steel conrod (0.30 m pin to pin, 8 × 8 mm) a 3D P2 body reduced with GCMS,
the slider (half the conrod's mass) on the x axis; no gravity; 0 ≤ t ≤ 0.1 s from the rigid
trajectory with the conrod undeformed (the test set's second initial state). Compared:

- the conrod's midpoint deflection against the test set's equations (``references.
  slider_crank``: two sine modes and one quadratic axial element, integrated by DOP853 to
  1e-9), the error's maximum over the run relative to the benchmark's peak;
- the same against the same assembly with the conrod full order (reference (a): F = I,
  a sparse LU), unless ``--no-full-order``;
- with E × 1e4 (``--stiff``, on by default), the slider's position and the force at the slider
  pin against the rigid slider crank's closed form (``rigid_closed_form``, the 3D conrod's
  own mass and inertia).

    python workflows/slider_crank.py [--out DIR] [--modes 10] [--time-step 2e-5]
                                     [--mesh-size 0.003] [--no-full-order]

Writes DIR/slider_crank.json (``time_s``, ``midpoint_deflection_m`` of the GCMS conrod at every
recorded step, ``coordinates``, ``wall_time_s`` of its simulation, and the comparisons),
DIR/slider_crank.md (the table) and DIR/slider_crank.png (the deflections and errors).
One BLAS thread.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, table_row
from common import run_interruptibly, temporary_folder, write_markdown, write_record

RECORD_S = 1e-4       # the recorded rows' spacing
STIFF = 1e4           # the factor on E of the rigid check
#: The rigid check compares from this time on: the conrod starts undeformed, so its pin forces
#: start from the elastic body's (1.6 N at the slider pin against the rigid 382 N) and reach
#: the rigid ones as the stiff conrod's start transient decays (below 1e-3 of the peak by 2 ms
#: at h = 5e-5 s).
STIFF_FROM_S = 5e-3


def arguments() -> Any:
    p = parser(__doc__, out="docs", out_help="folder of slider_crank.json, .md and .png")
    p.add_argument("--modes", type=int, default=10, help="elastic modes of the conrod")
    p.add_argument("--time-step", type=float, default=2e-5, help="h (s)")
    p.add_argument("--mesh-size", type=float, default=0.003, help="conrod cell size (m)")
    p.add_argument("--rho-inf", type=float, default=0.8, help="generalized-α ρ∞")
    p.add_argument("--no-full-order", action="store_true", help="skip reference (a)")
    args = p.parse_args()
    if args.modes < 1 or not 0 < args.time_step <= 1e-3 or not 0 < args.mesh_size <= 0.008:
        p.error("--modes ≥ 1, 0 < --time-step ≤ 1e-3 s, 0 < --mesh-size ≤ 0.008 m")
    return args


def conrod_chain(args: Any, folder: Path, stiffness_factor: float = 1.0,
                 attachment: bool = True) -> tuple[Any, Any]:
    """(free-free chain, reduced model) of the conrod's study through the pipeline's stages;
    without its pins' attachment modes unless ``attachment``."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.references.slider_crank_assembly import CONROD_STUDY

    study = {k: v for k, v in CONROD_STUDY.items() if attachment or k not in ("basis", "scene")}
    raw = {**study, "mesh": {"size": args.mesh_size}, "modes": {"count": args.modes},
           "material": {**CONROD_STUDY["material"],
                        "E": CONROD_STUDY["material"]["E"] * stiffness_factor}}
    cfg = parse_config(raw)
    folder.mkdir(parents=True, exist_ok=True)
    ff = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    return ff, pipeline.reduction_stage(
        pipeline.basis_stage(ff.assembly.model, ff.modes, ff.body), cfg.selection)


def simulate(body: Any, args: Any, factorize: Any = None) -> dict:
    """The assembly with ``body`` as its conrod from the rigid start to 0.1 s: the recorded
    times, midpoint deflection, slider position, slider-pin force, and the run's totals."""
    from gcms_fenicsx.dynamics.system.march import march
    from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state
    from gcms_fenicsx.references import slider_crank_assembly as sca

    kwargs = {} if factorize is None else {"factorize": factorize}
    assembly = sca.slider_crank(body, **kwargs)
    stepper = AssemblyStepper(assembly, StepSettings(args.time_step, args.rho_inf))
    slider, pin = assembly.offsets["slider"], [i for i, r in enumerate(assembly.rows)
                                               if r.joint == "slider_pin"][:2]
    run = march(stepper, initial_state(stepper, sca.rigid_start_velocity(assembly)), 0.1,
                every=max(1, round(RECORD_S / args.time_step)),
                probes={"deflection": sca.midpoint_deflection(body),
                        "slider": lambda s: s.q[slider][0]}, progress=log)
    return {"time_s": run.time_s, "deflection_m": run.probes["deflection"],
            "slider_m": run.probes["slider"], "pin_force_n": -run.multipliers[:, pin],
            "coordinates": int(body.dofs), "wall_time_s": run.wall_time_s, "steps": run.steps,
            "newton_per_step": run.newton_iterations / run.steps,
            "energy_drift_rel": run.energy_drift_rel}


def benchmark(times: np.ndarray, conrod: dict | None = None) -> np.ndarray:
    """The ported test set's midpoint deflection q1 at ``times`` (from its second state), with
    its own conrod or a ``slider_crank.conrod_variant``."""
    from gcms_fenicsx.references import slider_crank as ref

    solution = ref.solve("second", 0.1, times=np.minimum(np.round(times, 12), 0.1),
                         rtol=1e-9, atol=1e-12, conrod=conrod or ref.CONROD)
    return ref.midpoint_deflection(solution)


def stiff_check(args: Any, folder: Path) -> dict:
    """E × 1e4: the slider and the slider-pin force against the rigid closed form, the largest
    differences relative to the closed form's largest values."""
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.references.slider_crank_assembly import rigid_reference

    _, reduced = conrod_chain(args, folder, STIFF)
    body = body_from_reduced(reduced)
    run = simulate(body, args)
    rigid = rigid_reference(body, run["time_s"])
    slider_error = np.abs(run["slider_m"] - rigid["slider_m"]).max()
    peak_force = np.abs(rigid["pin_force_n"]).max(axis=0)
    force_error = np.abs(run["pin_force_n"] - rigid["pin_force_n"]) / peak_force
    late = run["time_s"] >= STIFF_FROM_S
    above = np.flatnonzero(force_error.max(axis=1) > 1e-3)
    return {"slider_error_m": float(slider_error),
            "slider_error_rel": float(slider_error / np.abs(rigid["slider_m"]).max()),
            "pin_force_error_rel": force_error[late].max(axis=0).tolist(),
            "pin_force_from_s": STIFF_FROM_S, "pin_force_peak_n": peak_force.tolist(),
            "transient_below_1e-3_after_s": float(run["time_s"][above[-1] + 1]
                                                  if len(above) else 0.0),
            "run": run, "rigid": rigid}


def full_order(ff: Any, args: Any) -> dict:
    """Reference (a): the conrod on every finite-element DOF of the same mesh."""
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references.full_order import full_order_body, sparse_factorization

    model = ff.assembly.model
    body = full_order_body(model, group_weights(ff.body, model.Vs))
    log(f"reference (a): {body.dofs} coordinates")
    return simulate(body, args, sparse_factorization)


def relative_error(run: dict, reference: np.ndarray) -> dict:
    """max |q1 − q1_ref| over the run / max |q1_ref|, where, and the two peaks (m)."""
    error = np.abs(run["deflection_m"] - reference)
    peak = float(np.abs(reference).max())
    worst = int(np.argmax(error))
    return {"max_error_rel": float(error[worst] / peak), "at_s": float(run["time_s"][worst]),
            "peak_m": float(np.abs(run["deflection_m"]).max()), "reference_peak_m": peak}


def table(result: dict) -> str:
    """The comparison table of slider_crank.md."""
    lines = table_head("run", "coordinates", "steps/s", "Newton/step", "peak |q1| (mm)",
                       "max error / peak", "at (ms)", "energy drift")
    for name, run, error in result["rows"]:
        lines.append(table_row(name, run["coordinates"],
                               f"{run['steps'] / run['wall_time_s']:,.0f}",
                               f"{run['newton_per_step']:.2f}", f"{error['peak_m'] * 1e3:.4f}",
                               f"{error['max_error_rel']:.2%}", f"{error['at_s'] * 1e3:.1f}",
                               f"{run['energy_drift_rel']:.1e}"))
    f3, ft = result["bending_hz"]["conrod_3d"], result["bending_hz"]["test_set"]
    lines += ["", f"Bending frequencies pinned–pinned in the plane of motion: 3D conrod "
              f"{f3[0]:.2f} and {f3[1]:.2f} Hz, the test set's Euler–Bernoulli beam {ft[0]:.2f} "
              f"and {ft[1]:.2f} Hz ({f3[0] / ft[0] - 1:+.2%}, {f3[1] / ft[1] - 1:+.2%})."]
    stiff = result.get("stiff")
    if stiff:
        fx, fy = stiff["pin_force_error_rel"]
        lines += ["", f"E × {STIFF:g} against the rigid closed form: slider position "
                  f"{stiff['slider_error_m']:.2e} m ({stiff['slider_error_rel']:.1e} of its "
                  f"largest value); slider-pin force from t = {stiff['pin_force_from_s'] * 1e3:g} "
                  f"ms: x {fx:.1e}, y {fy:.1e} of their peaks ({stiff['pin_force_peak_n'][0]:.0f} "
                  f"N, {stiff['pin_force_peak_n'][1]:.0f} N; the start's transient, the conrod "
                  "starting undeformed, is below 1e-3 of them after "
                  f"{stiff['transient_below_1e-3_after_s'] * 1e3:.1f} ms)."]
    return "\n".join(lines) + "\n"


def plot(result: dict, path: Path) -> None:
    """The midpoint deflections over time, and the GCMS conrod's error against each reference."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    gcms = result["gcms"]
    t = gcms["time_s"] * 1e3
    top.plot(t, result["benchmark_m"] * 1e3, "k-", lw=2.5, alpha=0.35, label="test set (port)")
    top.plot(t, result["matched_m"] * 1e3, "C2:", label="test set, 3D conrod's frequencies")
    if "full" in result:
        top.plot(t, result["full"]["deflection_m"] * 1e3, "C1--", label="full-order conrod (a)")
    top.plot(t, gcms["deflection_m"] * 1e3, "C0-", lw=1, label="GCMS conrod")
    top.set_ylabel("midpoint deflection (mm)")
    top.legend(loc="lower left", fontsize=8)
    peak = np.abs(result["benchmark_m"]).max()
    bottom.plot(t, (gcms["deflection_m"] - result["benchmark_m"]) / peak * 100, "k-",
                label="GCMS − test set")
    bottom.plot(t, (gcms["deflection_m"] - result["matched_m"]) / peak * 100, "C2-",
                label="GCMS − test set with the 3D conrod's frequencies")
    if "full" in result:
        bottom.plot(t, (gcms["deflection_m"] - result["full"]["deflection_m"]) / peak * 100,
                    "C1-", label="GCMS − full order")
    bottom.set_ylabel("difference (% of peak)")
    bottom.set_xlabel("t (ms)")
    bottom.legend(loc="lower left", fontsize=8)
    save_figure(fig, path)


def main() -> None:
    args = arguments()
    quiet()
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced

    from gcms_fenicsx.references.slider_crank import bending_frequencies_hz, conrod_variant
    from gcms_fenicsx.references.slider_crank_assembly import pinned_bending_hz

    with temporary_folder("slider_crank_") as work:
        log("conrod: mesh, modes, reduction")
        ff, reduced = conrod_chain(args, work / "conrod")
        body = body_from_reduced(reduced)
        gcms = simulate(body, args)
        log(f"GCMS conrod: {gcms['coordinates']} coordinates, {gcms['wall_time_s']:.1f} s")
        bending = pinned_bending_hz(body)
        result: dict = {"gcms": gcms, "benchmark_m": benchmark(gcms["time_s"]),
                        "bending_hz": {"conrod_3d": bending,
                                       "test_set": bending_frequencies_hz()},
                        "matched_m": benchmark(gcms["time_s"], conrod_variant(bending, True))}
        rows = [("GCMS conrod vs test set", gcms, relative_error(gcms, result["benchmark_m"])),
                ("GCMS conrod vs test set with the 3D conrod's bending frequencies and "
                 "consistent axial mass", gcms, relative_error(gcms, result["matched_m"]))]
        if not args.no_full_order:
            result["full"] = full_order(ff, args)
            rows.append(("full-order conrod (a) vs test set", result["full"],
                         relative_error(result["full"], result["benchmark_m"])))
            rows.append(("full-order conrod (a) vs test set with the 3D conrod's frequencies "
                         "and consistent axial mass", result["full"],
                         relative_error(result["full"], result["matched_m"])))
            rows.append(("GCMS conrod vs (a)", gcms,
                         relative_error(gcms, result["full"]["deflection_m"])))
        log(f"E × {STIFF:g}: the rigid check")
        result["stiff"] = stiff_check(args, work / "stiff")
    result["rows"] = rows
    write(result, args)


def write(result: dict, args: Any) -> None:
    """slider_crank.json, .md and .png in ``args.out``."""
    out = Path(args.out)
    gcms = result["gcms"]
    document = {
        "time_s": gcms["time_s"].tolist(), "midpoint_deflection_m": gcms["deflection_m"].tolist(),
        "coordinates": gcms["coordinates"], "wall_time_s": gcms["wall_time_s"],
        "settings": {"modes": args.modes, "time_step_s": args.time_step,
                     "mesh_size_m": args.mesh_size, "rho_inf": args.rho_inf},
        "benchmark_midpoint_deflection_m": result["benchmark_m"].tolist(),
        "matched_benchmark_midpoint_deflection_m": result["matched_m"].tolist(),
        "bending_hz": result["bending_hz"],
        "comparisons": [{"run": name, **error, "coordinates": run["coordinates"],
                         "steps": run["steps"], "wall_time_s": run["wall_time_s"],
                         "newton_per_step": run["newton_per_step"],
                         "energy_drift_rel": run["energy_drift_rel"]}
                        for name, run, error in result["rows"]],
        "stiff": {k: v for k, v in result["stiff"].items() if k not in ("run", "rigid")},
    }
    if "full" in result:
        document["full_order_midpoint_deflection_m"] = result["full"]["deflection_m"].tolist()
    record = write_record(out / "slider_crank.json", document)["record"]
    text = table(result)
    write_markdown(out / "slider_crank.md", "# The flexible slider crank\n\n" + text, record)
    plot(result, out / "slider_crank.png")
    print(text)


if __name__ == "__main__":
    run_interruptibly(main, "--out")
