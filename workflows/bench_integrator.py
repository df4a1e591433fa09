"""Integrator speed: steps per second of the reduced GCMS pendulum for Nm = 5, 10, 20, 50.

The case is the flexible pendulum of ``gcms_fenicsx.pendulum`` (revolute joint, gravity,
h = 1 ms, 1 s), in its soft polymer (E = 0.1 GPa: the validation case, strains ~1e-3) and in
a stiff one (E = 3 GPa: strains 30× smaller, so Newton converges faster). For each Nm, with
the default selection and (soft) without any (all 4 + 3 Nm fields, plain basis: the
reference's rank-deficient Φ), it times the run with

- the default Newton ("rotated": β'Mr + γ'D + Kr factorised once, turned with the frame;
  change-of-frame terms added by Woodbury where a step converges slowly), and
- the baseline in the same run: textbook Newton with the exact iteration matrix assembled
  and LU-factorised in every iteration ("assembled"), on the same steps.

One BLAS thread (small dense algebra gains nothing from threads). Each timing is the best
of ``--repeat`` runs; the ratio of the two is the figure to read, since this machine is
shared and its absolute speed varies.

    python workflows/bench_integrator.py [--out docs/bench_integrator] [--repeat 3]

writes OUT.json, OUT.png and prints the table recorded in README.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import argparse
import json
import logging
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

MODE_COUNTS = (5, 10, 20, 50)
MATERIALS_E_PA = {"soft": 1.0e8, "stiff": 3.0e9}
BASELINE_TIME_S = 0.1   # the assembled baseline is slow: its rate is measured on 100 steps


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def bodies():
    """(material, Nm, selection, body or failure message) for every case, one mesh and one
    solve per material."""
    from gcms_fenicsx import pipeline
    from gcms_fenicsx.config.material import parse_material
    from gcms_fenicsx.config.selection import SelectionConfig
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.body import body_from_reduced
    from gcms_fenicsx.reduction.reduce import ReductionError
    from gcms_fenicsx.references import pendulum

    cfg = parse_config(dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)}))
    with tempfile.TemporaryDirectory() as tmp:
        body_mesh = pipeline.body_mesh(pipeline.mesh_stage(cfg.geometry, cfg.mesh, Path(tmp)))
    none = SelectionConfig(cosine_tolerance=0.0, svd_tolerance=0.0, orthonormalize=False)
    for material, E in MATERIALS_E_PA.items():
        steel_or_soft = parse_material(dict(pendulum.STUDY["material"], E=E))
        model = pipeline.assembly_stage(body_mesh.mesh, steel_or_soft).model
        modes = pipeline.modes_stage(model, cfg.modes)
        for nm in MODE_COUNTS:
            variants = (("default", cfg.selection), ("none", none))
            for label, settings in variants[:2 if material == "soft" else 1]:
                try:
                    reduction = pipeline.reduction_stage(model, modes.lowest(nm), body_mesh,
                                                         settings)
                except ReductionError as exc:
                    yield material, nm, label, None, str(exc)
                    continue
                body = body_from_reduced(pipeline.reduced_model(reduction))
                yield material, nm, label, body, reduction.selection


def timed(body, scene, jacobian: str, repeat: int) -> dict:
    """Best of ``repeat`` runs: steps/s, µs per step, Newton iterations; or the failure."""
    from gcms_fenicsx.dynamics.errors import IntegrationError
    from gcms_fenicsx.dynamics.simulate import simulate_body

    sc = replace(scene, solver=replace(scene.solver, jacobian=jacobian),
                 end_time_s=scene.end_time_s if jacobian == "rotated" else BASELINE_TIME_S)
    best = None
    for _ in range(repeat):
        try:
            traj, summary = simulate_body(body, sc)
        except IntegrationError as exc:
            return {"failed": str(exc)}
        if not summary["complete"]:
            return {"failed": summary["message"]}
        if best is None or summary["steps_per_second"] > best["steps_per_second"]:
            best = {"steps_per_second": summary["steps_per_second"],
                    "time_per_step_us": summary["time_per_step_us"],
                    "newton_iterations_mean": summary["newton_iterations_mean"],
                    "steps": summary["steps"], "tip": traj.groups["end_xL"]["position"][-1].tolist()}
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/bench_integrator"))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    logging.disable(logging.INFO)
    from gcms_fenicsx.dynamics.scene import parse_scene
    from gcms_fenicsx.references import pendulum

    scene = parse_scene(pendulum.STUDY["scene"])
    rows = []
    for material, nm, label, body, report in bodies():
        row = {"material": material, "modes": nm, "selection": label}
        if body is None:
            row["failed"] = report
        else:
            row.update(reduced_dofs=body.dofs, cond_mr=report["cond_mr_after"],
                       pruning_error=report["max_rel_frequency_error"])
            row["rotated"] = timed(body, scene, "rotated", args.repeat)
            row["assembled"] = timed(body, scene, "assembled", args.repeat)
        rows.append(row)
        log(f"{material}, Nm = {nm}, selection {label}: "
            f"{json.dumps({k: v for k, v in row.items() if k in ('reduced_dofs', 'failed')})}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{args.out}.json").write_text(json.dumps(rows, indent=1))
    plot(rows, Path(f"{args.out}.png"))
    print(table(rows))


def _cell(run: dict) -> tuple[str, str, str]:
    if "failed" in run:
        return "failed", "", ""
    return (f"{run['steps_per_second']:,.0f}", f"{run['time_per_step_us']:,.0f}",
            f"{run['newton_iterations_mean']:.2f}")


def table(rows: list[dict]) -> str:
    lines = ["| pendulum | Nm | selection | reduced DOFs | cond(Mr) | steps/s | µs/step "
             "| Newton it. | baseline steps/s | baseline it. | speedup |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "failed" in r:
            lines.append(f"| {r['material']} | {r['modes']} | {r['selection']} | — | — | "
                         f"reduction failed: {r['failed'][:70]} | | | | | |")
            continue
        fast, base = r["rotated"], r["assembled"]
        sps, us, it = _cell(fast)
        bsps, _, bit = _cell(base)
        ratio = (f"{fast['steps_per_second'] / base['steps_per_second']:.1f}×"
                 if "failed" not in fast and "failed" not in base else "")
        note = f" ({fast['failed'][:60]})" if "failed" in fast else ""
        lines.append(f"| {r['material']} | {r['modes']} | {r['selection']} | {r['reduced_dofs']} "
                     f"| {r['cond_mr']:.1e} | {sps}{note} | {us} | {it} | {bsps} | {bit} | {ratio} |")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for material, marker in (("soft", "o"), ("stiff", "s")):
        for method, style in (("rotated", "-"), ("assembled", "--")):
            pts = [(r["reduced_dofs"], r[method]["steps_per_second"]) for r in rows
                   if r["material"] == material and r["selection"] == "default"
                   and "failed" not in r[method]]
            if pts:
                x, y = zip(*pts)
                ax.loglog(x, y, marker + style, label=f"{material}, {method}")
    ax.axhline(4000, color="k", lw=0.7, ls=":", label="target 4000 steps/s")
    ax.set_xlabel("reduced DOFs")
    ax.set_ylabel("steps per second")
    ax.set_title("GCMS flexible pendulum, one core")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
