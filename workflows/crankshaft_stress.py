"""The default crankshaft's stresses against its full model: the peak von Mises stress at the
pins and journals over the run, reduced models against reference (a).

Reference (a) is the same co-rotated model on every finite-element DOF
(``references.full_order``, a sparse LU of the iteration matrix) on the default scene; its
stresses are formed exactly as the reduced models' (``dynamics.run.stress_recovery``): the
same nodal gradient operator B at the same nodes (every node on the facets of ``pin_0`` …
``pin_3`` and ``journal_0`` … ``journal_4``, the mean over the cells holding a node), the
co-rotated law, the same recorded steps. The reduced models: Nm = 5, 10 and 20 elastic modes,
with the scene's attachment modes and without, in the full basis; Nm = 10 with attachment
modes is the default study's model. Per group, the error of its peak over the run,
|peak − peak_a| / peak_a, and over all the nodes max |peak − peak_a| / max peak_a.

The pins and journals meet the webs at sharp re-entrant corners (the geometry has no fillet
radii), where the peaks are: their nodal values are mesh-dependent numbers, compared here
between models on one mesh (docs/stresses.md).

    python workflows/crankshaft_stress.py [--out docs/crankshaft_stress] [--quick]

``--quick``: Nm = 10 with attachment modes only, against (a) over the first 20 ms. Writes
OUT.json and OUT.md (the tables of docs/stresses.md) and OUT.png (the peaks per group and the
hot spot's stress over time). One BLAS thread; (a) takes about 8 minutes on one core.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, table_row
from common import temporary_folder, write_markdown, write_record
from common.crankshaft import study

GROUPS = tuple(f"pin_{i}" for i in range(4)) + tuple(f"journal_{i}" for i in range(5))
MODE_COUNTS = (5, 10, 20)
ATTACHMENT = ("scene", "none")
QUICK_END_S = 0.02


def settings(modes: int, attachment: str) -> dict:
    """The sweep settings of ``common.crankshaft.study`` for one reduced model."""
    return {"mesh_size": None, "modes": modes, "attachment": attachment, "tolerance": 1e-6,
            "time_step": 5e-5}


def stress_scene(cfg: Any, end_s: float | None) -> Any:
    """The scene of ``cfg`` recording the stresses at GROUPS (and ending at ``end_s``)."""
    from gcms_fenicsx.config.stress_outputs import StressOutputs

    scene = cfg.scene
    scene = replace(scene, outputs=replace(scene.outputs, stress=StressOutputs(groups=GROUPS)))
    return replace(scene, end_time_s=end_s) if end_s else scene


def chain(raw: dict, folder: Path) -> tuple[Any, Any, Any, Any]:
    """(config, free-free chain, reduced model, stress nodes in the mesh file's numbering)."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.config.stress_outputs import StressOutputs
    from gcms_fenicsx.fe.nodal_gradients import stress_nodes

    cfg = parse_config(raw)
    folder.mkdir(parents=True, exist_ok=True)
    ff = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    reduced = pipeline.reduction_stage(pipeline.basis_stage(ff.assembly.model, ff.modes, ff.body),
                                       cfg.selection)
    nodes = stress_nodes(ff.body, StressOutputs(groups=GROUPS), reduced.fields.shape[0], "")
    return cfg, ff, reduced, nodes


def peaks(stress: dict, nodes: Any) -> dict:
    """Per group its peak over the run, every node's peak (Pa), the hot spot (the node of the
    largest) and the nodes' von Mises series."""
    peak = stress["stress/peak_von_mises"]
    return {"groups": {g: float(peak[m].max()) for g, m in nodes.groups.items()},
            "nodes": peak, "hot": int(np.argmax(peak)), "series": stress["stress/von_mises"]}


def reduced_run(raw: dict, folder: Path, end_s: float | None) -> dict:
    """One reduced model's run: its peaks, coordinates and seconds."""
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.dynamics.run.stress_recovery import StressSetup

    cfg, _, reduced, nodes = chain(raw, folder)
    scene = stress_scene(cfg, end_s)
    t0 = time.perf_counter()
    traj, summary = simulate_body(body_from_reduced(reduced), scene,
                                  stress=StressSetup(nodes, cfg.material.lame,
                                                     scene.outputs.stress))
    if not summary["complete"]:
        raise SystemExit(f"reduced run stopped: {summary['message']}")
    return dict(peaks(traj.stress, nodes), coordinates=summary["reduced_dofs"],
                seconds=time.perf_counter() - t0, time=traj.time,
                recovery_ms=summary["stress"]["recovery_per_recorded_step_ms"])


def reference(raw: dict, folder: Path, end_s: float | None) -> dict:
    """Reference (a): the full-order body on the same mesh, its stresses at the same nodes
    (the stress nodes renumbered into the full body's node order)."""
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.dynamics.run.stress_recovery import StressSetup
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.fe.node_order import input_node_indices
    from gcms_fenicsx.references.full_order import (full_order_body, sparse_factorization,
                                                    sparse_kkt_solve)

    cfg, ff, _, nodes = chain(raw, folder)
    model = ff.assembly.model
    full = full_order_body(model, group_weights(ff.body, model.Vs))
    order = input_node_indices(model.Vs)              # full body node j is file node order[j]
    setup = StressSetup(nodes.renumbered(order), cfg.material.lame,
                        stress_scene(cfg, end_s).outputs.stress)
    t0 = time.perf_counter()
    traj, summary = simulate_body(full, stress_scene(cfg, end_s), factorize=sparse_factorization,
                                  progress=log, kkt_solve=sparse_kkt_solve, stress=setup)
    if not summary["complete"]:
        raise SystemExit(f"reference (a) stopped: {summary['message']}")
    return dict(peaks(traj.stress, nodes), coordinates=summary["reduced_dofs"],
                seconds=time.perf_counter() - t0, time=traj.time,
                recovery_ms=summary["stress"]["recovery_per_recorded_step_ms"])


def errors(run: dict, ref: dict) -> dict:
    """Per group |peak − peak_a| / peak_a, their maximum, and over the nodes
    max |peak − peak_a| / max peak_a."""
    groups = {g: abs(run["groups"][g] - ref["groups"][g]) / ref["groups"][g] for g in GROUPS}
    return {"groups": groups, "max_group": max(groups.values()),
            "nodes": float(np.abs(run["nodes"] - ref["nodes"]).max() / ref["nodes"].max())}


def tables(rows: list[dict], ref: dict) -> str:
    """The peaks of (a) per group, and each reduced model's errors."""
    lines = ["Peak von Mises stress over the run, reference (a):", ""]
    lines += table_head("group", "peak (MPa)")
    lines += [table_row(g, f"{ref['groups'][g] / 1e6:.2f}") for g in GROUPS]
    lines += ["", "Reduced models against (a): the error of each group's peak, the largest, "
              "and over all the nodes' peaks:", ""]
    lines += table_head("Nm", "attachment modes", "coordinates", *GROUPS, "largest",
                        "nodes", "recovery ms/recorded step")
    for r in rows:
        e = r["errors"]
        lines.append(table_row(r["modes"], "yes" if r["attachment"] == "scene" else "no",
                               r["coordinates"], *(f"{100 * e['groups'][g]:.2f} %" for g in GROUPS),
                               f"{100 * e['max_group']:.2f} %", f"{100 * e['nodes']:.2f} %",
                               f"{r['recovery_ms']:.1f}"))
    return "\n".join(lines)


def plot(rows: list[dict], ref: dict, path: Path) -> None:
    """The peaks per group, (a) and the reduced models; the hot spot's stress over time."""
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    x = np.arange(len(GROUPS))
    left.plot(x, [ref["groups"][g] / 1e6 for g in GROUPS], "ko", label="(a) full order")
    for r in rows:
        left.plot(x, [r["groups"][g] / 1e6 for g in GROUPS], ".-",
                  label=f"Nm = {r['modes']}" + (" + attachment" if r["attachment"] == "scene"
                                                 else ""))
    left.set_xticks(x, GROUPS, rotation=45)
    left.set_ylabel("peak von Mises over the run (MPa)")
    left.legend(fontsize=8)
    hot = ref["hot"]
    right.plot(ref["time"], ref["series"][:, hot] / 1e6, "k-", label="(a)")
    for r in rows:
        right.plot(r["time"], r["series"][:, hot] / 1e6, "--", lw=1,
                   label=f"Nm = {r['modes']}, {r['attachment']}")
    right.set_xlabel("t (s)")
    right.set_ylabel("von Mises at (a)'s hot spot (MPa)")
    right.legend(fontsize=8)
    save_figure(fig, path)


def main() -> None:
    options = parser(__doc__, out="docs/crankshaft_stress",
                     quick="Nm = 10 with attachment modes, the first 20 ms")
    args = options.parse_args()
    quiet()
    end_s = QUICK_END_S if args.quick else None
    cases = [(10, "scene")] if args.quick else [(m, a) for a in ATTACHMENT for m in MODE_COUNTS]
    rows: list[dict] = []
    with temporary_folder() as tmp:
        log("reference (a): the full-order crankshaft on the default scene")
        ref = reference(study("crankshaft", settings(1, "none")), tmp / "a", end_s)
        log(f"(a): {ref['coordinates']} DOFs in {ref['seconds']:.0f} s; hot spot "
            f"{ref['nodes'][ref['hot']] / 1e6:.2f} MPa")
        for modes, attachment in cases:
            run = reduced_run(study("crankshaft", settings(modes, attachment)),
                              tmp / f"r{modes}{attachment}", end_s)
            run.update(modes=modes, attachment=attachment, errors=errors(run, ref))
            rows.append(run)
            log(f"Nm = {modes}, attachment {attachment}: largest group error "
                f"{100 * run['errors']['max_group']:.2f} %")
    text = tables(rows, ref)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_record(args.out.with_suffix(".json"), {
        "groups": list(GROUPS), "end_time_s": end_s,
        "reference": {"coordinates": ref["coordinates"], "seconds": ref["seconds"],
                      "peaks_pa": ref["groups"], "recovery_ms": ref["recovery_ms"]},
        "runs": [{k: r[k] for k in ("modes", "attachment", "coordinates", "seconds",
                                    "recovery_ms", "errors")} | {"peaks_pa": r["groups"]}
                 for r in rows]})
    write_markdown(args.out.with_suffix(".md"), text)
    plot(rows, ref, args.out.with_suffix(".png"))


if __name__ == "__main__":
    main()
