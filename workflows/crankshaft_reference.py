"""The default crankshaft against its full model, reference (a): what every reduced crankshaft
approximates.

Reference (a) is the same co-rotated linear model on every finite-element DOF (82k on the
study's mesh, ``references.full_order``, a sparse LU of the iteration matrix), on the default
scene: it starts at rest in its static equilibrium (solved on the full model) and its drive
and gas forces rise in smoothly, so the 50 µs step resolves its outputs. Two comparisons:

- statics (``dynamics.constraints.statics``): the body held by the scene's joints, drive included, under
  gravity and the gas forces once risen in ("scene") and under the centrifugal load at the drive's
  3000 rpm ("spin"): the nose's displacement and the bearing reactions of each reduced model
  against the full model's; with attachment modes the full model's response lies in the
  basis (docs/design.md §3.7) and they agree to round-off;
- dynamics: the nose's whirl, the bearing forces and the drive torque over the run
  (``common.crankshaft.outputs``), max_t |y − y_ref| / max_t |y_ref|, over the whole run and from
  1 ms on (``START_S``), for Nm = 5, 10, 20 with and
  without attachment modes, in the full and the rotor basis, the static shapes of Nm = 10
  with attachment modes in both (``[basis] shapes = "static"``: the held body's static
  responses to the scene's load patterns, the same for every Nm with attachment modes, whose
  span holds them), and the run ``pareto`` takes as its crankshaft reference (Nm = 20,
  attachment modes, full basis, half the step).

    python workflows/crankshaft_reference.py [--out docs/crankshaft_reference] [--half-step]

``--half-step`` also runs (a) at h/2 (about 16 minutes more, one core) to state its own
convergence. Writes OUT.json and OUT.png ((a) and some reduced runs over time) and prints
the tables recorded in README.md. One BLAS thread; (a) takes about 8 minutes.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, temporary_folder
from common import write_record
from common.crankshaft import (BASES, OUTPUTS, START_S, after_start, crankshaft_outputs, errors,
                               on_times, outputs, run_chain, shapes_of, study)

MODE_COUNTS = (5, 10, 20)
#: the Nm whose model also runs on its static shapes (with attachment modes they are the same
#: shapes for every Nm)
STATIC_MODES = 10
NOSE = "end_x0"
#: pareto's crankshaft reference: the finest and richest run of its sweep
PARETO_REFERENCE = {"mesh_size": None, "modes": 20, "attachment": "scene", "tolerance": 1e-6,
                    "time_step": 2.5e-5}


def crankshaft(s: dict) -> dict:
    """The study of sweep settings ``s`` on the default crankshaft scene."""
    return study("crankshaft", s)


def reference(cfg, folder: Path, time_step_s: float) -> tuple[Any, dict, float]:
    """(full body, outputs, seconds) of reference (a) at ``time_step_s``."""
    from dataclasses import replace

    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references.full_order import (full_order_body, sparse_factorization,
                                                    sparse_kkt_solve)

    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    model = chain.assembly.model
    full = full_order_body(model, group_weights(chain.body, model.Vs))
    t0 = time.perf_counter()
    traj, summary = simulate_body(full, replace(cfg.scene, time_step_s=time_step_s),
                                  factorize=sparse_factorization, progress=log,
                                  kkt_solve=sparse_kkt_solve)
    if not summary["complete"]:
        raise SystemExit(f"reference (a) stopped: {summary['message']}")
    return full, dict(outputs(traj), time=traj.time), time.perf_counter() - t0


def static_loads(cfg) -> dict[str, Any]:
    """Per static load case, body ↦ its load ("scene": the scene's gravity and loads once risen
    in, ``Scene.loads_risen_s``; "spin": the centrifugal load at the drive's angular velocity)."""
    from gcms_fenicsx.config.basis import AttachmentLoad
    from gcms_fenicsx.dynamics.bodies.loads import external_forces
    from gcms_fenicsx.dynamics.bases.rotor_basis import generalized_loads

    drive = cfg.scene.joints[0]
    unit = AttachmentLoad(drive.group, "centrifugal", drive.axis)
    return {"scene": lambda body: external_forces(body, cfg.scene.gravity,
                                                  cfg.scene.loads)(cfg.scene.loads_risen_s),
            "spin": lambda body: (drive.drive.angular_velocity ** 2
                                  * generalized_loads(body, [unit])[:, 0])}


def full_statics(full, cfg) -> dict[str, Any]:
    """The full model's static responses (``dynamics.constraints.statics``) per load case."""
    from gcms_fenicsx.references.full_order import full_held_static

    return {case: full_held_static(full, cfg.scene, load(full))
            for case, load in static_loads(cfg).items()}


def statics(full, exact: dict[str, Any], reduced, cfg) -> dict[str, dict[str, float]]:
    """Per load case, the reduced model's nose displacement and bearing reactions against the
    full model's (``exact``): max |difference| / |full| (nose: its Euclidean norm; reactions:
    the largest)."""
    from gcms_fenicsx.dynamics.constraints.statics import held_static

    out = {}
    for case, load in static_loads(cfg).items():
        a, r = exact[case], held_static(reduced, cfg.scene, load(reduced))
        nose = a.group_displacement(full, NOSE)
        out[case] = {
            "nose_m": nose.tolist(),
            "nose": float(np.abs(r.group_displacement(reduced, NOSE) - nose).max()
                          / np.linalg.norm(nose)),
            "reactions": float(np.abs(r.reactions - a.reactions).max()
                               / np.abs(a.reactions).max())}
    return out


def main() -> None:
    options = parser(__doc__, out="docs/crankshaft_reference")
    options.add_argument("--half-step", action="store_true")
    args = options.parse_args()
    quiet()
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced

    rows: list[dict] = []
    curves: dict[str, Any] = {}
    with temporary_folder() as tmp:
        base = {"mesh_size": None, "modes": 1, "attachment": "none", "tolerance": 1e-6,
                "time_step": 5e-5}
        cfg = parse_config(crankshaft(base))
        full, ref, seconds = reference(cfg, tmp, cfg.scene.time_step_s)
        log(f"reference (a): {full.dofs} DOFs, {seconds:.0f} s")
        exact = full_statics(full, cfg)
        result: dict[str, Any] = {"reference": {"dofs": full.dofs, "seconds": seconds,
                                                "time_step": cfg.scene.time_step_s,
                                                "damping_beta_s": cfg.scene.damping_beta}}
        if args.half_step:
            _, half, seconds_half = reference(cfg, tmp, cfg.scene.time_step_s / 2)
            halved = on_times({k: half[k] for k in OUTPUTS}, half["time"], ref["time"])
            result["reference"]["against_half_step"] = errors(ref, halved)
            result["reference"]["half_step_seconds"] = seconds_half
        curves["time"] = ref["time"]
        curves["a"] = ref
        settings = [dict(base, modes=nm, attachment=att) for att in ("none", "scene")
                    for nm in MODE_COUNTS] + [PARETO_REFERENCE]
        for s in settings:
            cfg, reduced, offline = run_chain(crankshaft(s), tmp)
            static = statics(full, exact, body_from_reduced(reduced), cfg)
            kinds = [(shapes, patterns, basis) for shapes, patterns in shapes_of(cfg).items()
                     for basis in BASES
                     if (s is not PARETO_REFERENCE or (basis, shapes) == ("full", "modes"))
                     and (shapes == "modes" or s["modes"] == STATIC_MODES)]
            for shapes, patterns, basis in kinds:
                tag = f"{s['modes']}{s['attachment']}{s['time_step']}{basis}{shapes}"
                out, online, t, dofs = crankshaft_outputs(reduced, cfg, tmp, tag, basis,
                                                          patterns)
                out = on_times(out, t, ref["time"])
                row = dict(s, shapes=shapes, basis=basis, coordinates=dofs, offline_s=offline,
                           online_s=online, error=errors(out, ref),
                           error_after_start=errors(*(after_start(o, ref["time"])
                                                      for o in (out, ref))),
                           static=static)
                rows.append(row)
                curves[f"{s['modes']} {s['attachment']} {shapes} {basis} "
                       f"{s['time_step']:g}"] = out
                log(json.dumps({k: v for k, v in row.items() if k != "static"}))
    result["rows"] = rows
    write_record(args.out.with_suffix(".json"), result)
    plot(curves, args.out.with_suffix(".png"))
    print(tables(result))


def tables(result: dict) -> str:
    """The dynamics table (per row: coordinates, the three outputs' errors, online seconds)
    and the statics table (per reduced model)."""
    lines = table_head("Nm", "attachment", "shapes", "basis", "h µs", "coordinates", *OUTPUTS,
                       f"the three from {START_S * 1e3:g} ms on", "simulation s")
    for r in result["rows"]:
        e, late = r["error"], r["error_after_start"]
        lines.append(f"| {r['modes']} | {r['attachment']} | {r['shapes']} | {r['basis']} | "
                     f"{r['time_step'] * 1e6:g} | {r['coordinates']} | "
                     + " | ".join(f"{100 * e[k]:.2f} %" for k in OUTPUTS) + " | "
                     + ", ".join(f"{100 * late[k]:.2f}" for k in OUTPUTS) + " %"
                     + f" | {r['online_s']:.2f} |")
    lines += ["", *table_head("Nm", "attachment", "static nose (scene loads)", "reactions",
                              "static nose (spin)", "reactions")]
    for r in result["rows"]:
        if r["basis"] != "full" or r["time_step"] != 5e-5 or r["shapes"] != "modes":
            continue
        st = r["static"]
        lines.append(f"| {r['modes']} | {r['attachment']} | " + " | ".join(
            f"{st[c][k]:.1e}" for c in ("scene", "spin") for k in ("nose", "reactions")) + " |")
    return "\n".join(lines)


def plot(curves: dict, path: Path) -> None:
    """The nose's whirl (z) and the front bearing's vertical force over time: (a), the
    full basis at Nm = 10 and 20 with attachment modes and at Nm = 10 without, and the rotor
    basis on the static shapes."""
    plt = pyplot()
    t = curves["time"] * 1e3
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    shown = [("a", "reference (a), full model", "k", 2.0),
             ("10 none modes full 5e-05", "Nm = 10", "tab:red", 1.0),
             ("10 scene modes full 5e-05", "Nm = 10 + attachment", "tab:blue", 1.0),
             ("20 scene modes full 5e-05", "Nm = 20 + attachment", "tab:green", 1.0),
             ("10 scene static rotor 5e-05", "static shapes, rotor basis", "tab:orange", 1.0)]
    for key, label, color, width in shown:
        axes[0].plot(t, curves[key]["nose whirl"][:, 1] * 1e9, color=color, lw=width,
                     label=label)
        axes[1].plot(t, curves[key]["bearing forces"][:, 2], color=color, lw=width)
    axes[0].set_ylabel("nose z (nm)")
    axes[1].set_ylabel("front bearing force z (N)")
    axes[1].set_xlabel("time (ms)")
    axes[0].legend(fontsize=8)
    axes[0].set_title("Default crankshaft: reduced models against the full model")
    save_figure(fig, path)


if __name__ == "__main__":
    main()
