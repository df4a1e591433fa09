"""Run time against error, end to end: the flexible pendulum and the default crankshaft scene
over mesh size, mode count, attachment modes, selection tolerance and time step.

Every row runs the whole chain from the study tables — mesh, assembly, the verified solve
(with the attachment modes when asked), GCMS fields, selection, reduction — and the scene,
and times the offline part (mesh to reduced model) and the online part (the simulation).
The error is measured as the flexible pendulum measures it: the largest difference over
time divided by the reference's largest value.

- pendulum: the tip's deviation from the rigid pendulum over the first half period, against
  reference (a), the full-order co-rotated model on the study's mesh (docs/flexible_pendulum.md);
- crankshaft: the nose's whirl, the bearing forces and the drive torque
  (``common.crankshaft.outputs``), each against the finest and richest run of the sweep (the
  study's mesh, Nm = 20, attachment modes, half the time step, full basis), reported
  separately and as their maximum; that reference's own convergence is stated by comparing
  it with the same run at the study's time step (``reference_convergence``). Runs are
  compared at their own recorded times, where the reference (recorded at a multiple of them)
  has samples: a run recorded more coarsely, interpolated to the reference's times, would
  count its interpolation as error. The default scene starts at rest in its bearings, with
  its drive and gas forces rising in smoothly, so the step resolves its outputs (before it
  did, loads applied at full value at t = 0 left every mode ringing and no setting
  converged; a damped copy of the scene stood in for it).

Every reduced model runs the scene in both bases, ``basis = "full"`` and ``"rotor"``
(``[basis] kind``; the joints of both scenes allow the rotor basis), and one with attachment
modes also on the held body's static shapes (``[basis] shapes = "static"``, row key
``shapes``: "modes" or "static"; made from the reduced model when the scene runs, so their
time is online): the offline time is shared, the coordinates and the online time are each
run's.

    python workflows/pareto.py [--quick] [--out docs]

writes OUT/pareto.json (``rows``: case, mesh_size, order, modes, attachment, shapes, basis,
tolerance, time_step, coordinates, error, offline_s, online_s, total_s, and per output for
the crankshaft) and OUT/pareto.png (error against total and against online time), and
prints the cheapest settings for 10 %, 1 % and 0.1 % error.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: timings of one core

import itertools
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, temporary_folder
from common import table_row, write_record
from common.crankshaft import (BASES, OUTPUTS, crankshaft_outputs, errors, on_times, run_chain,
                               shapes_of, study)

TARGETS = (0.1, 0.01, 0.001)


def sweep(case: str, quick: bool) -> list[dict[str, Any]]:
    """The settings of every run of ``case``: study overrides and their labels."""
    if case == "pendulum":
        sizes = (None,) if quick else (None, 0.02)
        counts, steps = ((5, 10) if quick else (5, 10, 20)), ((1e-3,) if quick else (1e-3, 2e-3))
        tolerances = (1e-6,) if quick else (1e-6, 1e-4)
    else:
        sizes = (None,) if quick else (None, 0.015)
        counts = (5, 10) if quick else (5, 10, 20)
        steps = (5e-5,) if quick else (5e-5, 1e-4, 2e-4)
        tolerances = (1e-6,)
    return [{"mesh_size": size, "modes": nm, "attachment": att, "tolerance": tol, "time_step": h}
            for size, nm, att, tol, h in itertools.product(sizes, counts, ("none", "scene"),
                                                           tolerances, steps)]


def pendulum_reference(folder: Path) -> dict:
    """Reference (a) on the study's mesh: the tip deviation and the rigid pendulum."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references import pendulum
    from gcms_fenicsx.references.full_order import full_order_body, sparse_factorization

    cfg = parse_config(dict(pendulum.STUDY, basis={"attachment": "none"}))
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    model = chain.assembly.model
    full = full_order_body(model, group_weights(chain.body, model.Vs))
    rigid = pendulum.rigid_pendulum(full, np.array(cfg.scene.gravity), cfg.scene.end_time_s)
    traj, _ = simulate_body(full, cfg.scene, factorize=sparse_factorization)
    return {"rigid": rigid, "time": traj.time, "deviation": pendulum.tip_deviation(
        rigid, traj.time, traj.groups["end_xL"]["position"])}


def pendulum_error(reduced, cfg, ref: dict, basis: str, static=None
                   ) -> tuple[float, float, int]:
    """(error against (a), simulation seconds, coordinates) of one reduced pendulum in
    ``basis`` (on the static shapes of the scene's ``static`` patterns, if given)."""
    from gcms_fenicsx.dynamics.run.simulate import simulate
    from gcms_fenicsx.references import pendulum

    t0 = time.perf_counter()
    traj, summary = simulate(reduced, cfg.scene, basis=basis,
                             attachment=cfg.plan.body.modes.attachment or (), static=static)
    online = time.perf_counter() - t0
    if not summary["complete"]:
        return float("nan"), online, summary["reduced_dofs"]
    d = pendulum.tip_deviation(ref["rigid"], traj.time, traj.groups["end_xL"]["position"])
    # runs with another time step are compared at the reference's recorded times
    d_ref = np.stack([np.interp(traj.time, ref["time"], ref["deviation"][:, k])
                      for k in range(3)], axis=1)
    return (pendulum.deviation_error(traj.time, d, d_ref, ref["rigid"].half_period_s), online,
            summary["reduced_dofs"])


def main() -> None:
    args = parser(__doc__, out="docs", quick="").parse_args()
    quiet()
    rows: list[dict] = []
    convergence: dict[str, Any] = {}
    with temporary_folder() as tmp:
        ref = pendulum_reference(tmp)
        for s in sweep("pendulum", args.quick):
            cfg, reduced, offline = run_chain(study("pendulum", s), tmp)
            for (shapes, static), basis in itertools.product(shapes_of(cfg).items(), BASES):
                error, online, dofs = pendulum_error(reduced, cfg, ref, basis, static)
                rows.append(_row("pendulum", cfg, dict(s, shapes=shapes), basis, dofs, error,
                                 offline, online))
                log(json.dumps(rows[-1]))
        rows += crankshaft_rows(args.quick, tmp, convergence)
    write_record(args.out / "pareto.json", {"rows": rows, "reference_convergence": convergence})
    plot(rows, args.out / "pareto.png")
    print(cheapest_table(rows))
    print(basis_table(rows))


def crankshaft_rows(quick: bool, tmp: Path, convergence: dict) -> list[dict]:
    """The crankshaft sweep on the default scene: its reference, that reference's convergence
    (into ``convergence["crankshaft"]``), and a row per run and basis."""
    case = "crankshaft"
    finest = {"mesh_size": None, "modes": 20, "attachment": "scene", "tolerance": 1e-6,
              "time_step": 2.5e-5}
    cfg, reduced, _ = run_chain(study(case, finest), tmp)
    reference, _, t_ref, _ = crankshaft_outputs(reduced, cfg, tmp, "reference")
    cfg, reduced, _ = run_chain(study(case, dict(finest, time_step=5e-5)), tmp)
    out, _, t, _ = crankshaft_outputs(reduced, cfg, tmp, "reference_h")
    convergence[case] = {"reference": finest, "against_twice_its_time_step":
                         errors(out, on_times(reference, t_ref, t))}
    rows = []
    for k, s in enumerate(sweep("crankshaft", quick)):
        cfg, reduced, offline = run_chain(study(case, s), tmp)
        for (shapes, static), basis in itertools.product(shapes_of(cfg).items(), BASES):
            out, online, t, dofs = crankshaft_outputs(reduced, cfg, tmp, f"c{k}", basis,
                                                      static)
            e = errors(out, on_times(reference, t_ref, t))
            rows.append(dict(_row(case, cfg, dict(s, shapes=shapes), basis, dofs, e["maximum"],
                                  offline, online), **{name: e[name] for name in OUTPUTS}))
            log(json.dumps(rows[-1]))
    return rows


def _row(case: str, cfg, s: dict, basis: str, coordinates: int, error: float, offline: float,
         online: float) -> dict:
    return {"case": case, "mesh_size": cfg.mesh.size, "order": cfg.mesh.order,
            "modes": s["modes"], "attachment": s["attachment"],
            "shapes": s.get("shapes", "modes"), "basis": basis,
            "tolerance": s["tolerance"], "time_step": s["time_step"],
            "coordinates": coordinates, "error": error, "offline_s": offline,
            "online_s": online, "total_s": offline + online}


def cheapest_table(rows: list[dict]) -> str:
    """Per case and target error, the run of least total time that meets it."""
    lines = table_head("case", "error ≤", "settings (mesh size, Nm, attachment, shapes, basis, "
                       "tolerance, h)", "coordinates", "error", "total s")
    for case in dict.fromkeys(r["case"] for r in rows):
        for target in TARGETS:
            meeting = [r for r in rows if r["case"] == case and r["error"] <= target]
            if not meeting:
                lines.append(f"| {case} | {target:g} | none of the sweep | | | |")
                continue
            r = min(meeting, key=lambda r: r["total_s"])
            settings = (f"{r['mesh_size']:g} m, {r['modes']}, {r['attachment']}, {r['shapes']}, "
                        f"{r['basis']}, {r['tolerance']:g}, {r['time_step']:g} s")
            lines.append(table_row(case, f"{target:g}", settings, r["coordinates"],
                                   f"{r['error']:.2e}", f"{r['total_s']:.1f}"))
    return "\n".join(lines)


def basis_table(rows: list[dict]) -> str:
    """Per case, the rotor basis against the full one at the same settings: the median and
    range of the error ratio and of the online-time ratio (full / rotor)."""
    lines = table_head("case", "runs", "coordinates full → rotor",
                       "error rotor / full (median, range)", "online full / rotor (median, range)")
    for case in dict.fromkeys(r["case"] for r in rows):
        key = ("mesh_size", "modes", "attachment", "shapes", "tolerance", "time_step")
        full = {tuple(r[k] for k in key): r for r in rows
                if r["case"] == case and r["basis"] == "full"}
        pairs = [(full[tuple(r[k] for k in key)], r) for r in rows
                 if r["case"] == case and r["basis"] == "rotor"]
        err = np.array([b["error"] / a["error"] for a, b in pairs])
        speed = np.array([a["online_s"] / b["online_s"] for a, b in pairs])
        dofs = sorted({(a["coordinates"], b["coordinates"]) for a, b in pairs})
        spread = [f"{np.median(x):.2f} ({x.min():.2f}–{x.max():.2f})" for x in (err, speed)]
        lines.append(table_row(case, len(pairs), f"{dofs[0][0]} → {dofs[0][1]} … "
                               f"{dofs[-1][0]} → {dofs[-1][1]}", *spread))
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(len(cases), 2, figsize=(11, 4.2 * len(cases)), squeeze=False)
    for i, case in enumerate(cases):
        for j, key in enumerate(("total_s", "online_s")):
            ax = axes[i, j]
            kinds = [("none", "modes"), ("scene", "modes"), ("scene", "static")]
            for ((att, shapes), basis), marker in zip(itertools.product(kinds, BASES),
                                                      ("o", "^", "s", "D", "v", "P")):
                pts = [(r[key], r["error"]) for r in rows if r["case"] == case
                       and r["attachment"] == att and r.get("shapes", "modes") == shapes
                       and r["basis"] == basis]
                if pts:
                    ax.loglog(*zip(*pts), marker, ls="", alpha=0.7,
                              label=f"attachment {att}, {shapes}, {basis} basis")
            front = _front([(r[key], r["error"]) for r in rows if r["case"] == case])
            ax.loglog(*zip(*front), "k-", lw=1, label="Pareto front")
            ax.set_xlabel(key.replace("_s", " time [s]"))
            ax.set_ylabel("error")
            ax.set_title(case)
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=8)
    save_figure(fig, path)


def _front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The points no other is both faster and more accurate than, by time."""
    front, best = [], float("inf")
    for cost, error in sorted(p for p in points if np.isfinite(p[1])):
        if error < best:
            front.append((cost, error))
            best = error
    return front


if __name__ == "__main__":
    main()
