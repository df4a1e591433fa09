"""Integrator speed: steps per second of the reduced GCMS pendulum for Nm = 5, 10, 20, 50,
and of the default scene, against the code before a change.

The case is the flexible pendulum of ``gcms_fenicsx.pendulum`` (revolute joint, gravity,
h = 1 ms, 1 s), in its soft polymer (E = 0.1 GPa: the validation case, strains ~1e-3) and in
a stiff one (E = 3 GPa: strains 30× smaller, so Newton converges faster). For each Nm, with
the default selection and (soft) without any (all 4 + 3 Nm fields, plain basis: the
reference's rank-deficient Φ), it times the run with

- the default Newton ("rotated": β'Mr + γ'D + Kr factorised once, turned with the frame;
  change-of-frame terms added by Woodbury where a step converges slowly), and
- the baseline in the same run: textbook Newton with the exact iteration matrix assembled
  and LU-factorised in every iteration ("assembled"), on the same steps.

With ``--before DIR`` (a checkout of an earlier commit: ``git worktree add DIR <commit>``),
every default-selection case, the soft Nm = 10 pendulum with every Newton matrix exact, with
Rayleigh damping and as a free spinning body (``VARIANTS``), and the default scene of
``gcms run`` (the crankshaft spun up in its bearings while its cylinders fire) are also run
with that code on the same reduced model, alternating with this one, each run in a fresh
process (``--worker``): the table gives µs per step before and after, their ratio, whether
every step's Newton iterations agree, and the largest differences of q and λ over the run,
relative to their largest values.

One BLAS thread (small dense algebra gains nothing from threads). Each timing is the best
of ``--repeat`` runs; ratios are the figures to read, since this machine is shared and its
absolute speed varies.

    python workflows/bench_integrator.py [--out docs/bench_integrator] [--repeat 3]
                                         [--before DIR]

writes OUT.json (``pendulum``: a row a case; ``variants`` with ``--before``), OUT.png and prints
the tables recorded in README.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import argparse
import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

from common import REPO, checkout, log, parser, pyplot, quiet, save_figure, table_head
from common import table_row, temporary_folder, worker_options, write_record
from common.crankshaft import default_study

MODE_COUNTS = (5, 10, 20, 50)
MATERIALS_E_PA = {"soft": 1.0e8, "stiff": 3.0e9}
VARIANT_MODES = 10      # the variants run on the soft pendulum with this Nm
BASELINE_TIME_S = 0.1   # the assembled baseline is slow: its rate is measured on 100 steps


def bodies():
    """(material, Nm, selection, reduced model or None, body or failure message) for every
    case, one mesh and one solve per material."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.material import parse_material
    from gcms_fenicsx.config.selection import SelectionConfig
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.reduction.reduce import ReductionError
    from gcms_fenicsx.references import pendulum

    cfg = parse_config(dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)},
                            basis={"attachment": "none"}))
    with temporary_folder() as tmp:
        body_mesh = pipeline.body_mesh(pipeline.mesh_stage(cfg.geometry, cfg.mesh, tmp))
    none = SelectionConfig(cosine_tolerance=0.0, svd_tolerance=0.0, orthonormalize=False)
    for material, E in MATERIALS_E_PA.items():
        steel_or_soft = parse_material(dict(pendulum.STUDY["material"], E=E))
        model = pipeline.assembly_stage(body_mesh.mesh, steel_or_soft).model
        every = pipeline.basis_stage(model, pipeline.modes_stage(model, cfg.plan.body.modes), body_mesh)
        for nm in MODE_COUNTS:
            variants = (("default", cfg.selection), ("none", none))
            for label, settings in variants[:2 if material == "soft" else 1]:
                try:
                    reduced = pipeline.reduction_stage(every.lowest(nm), settings)
                except ReductionError as exc:
                    yield material, nm, label, None, None, str(exc)
                    continue
                yield (material, nm, label, reduced, body_from_reduced(reduced),
                       reduced.selection)


def timed(body, scene, jacobian: str, repeat: int) -> dict:
    """Best of ``repeat`` runs in this process: steps/s, µs per step, Newton iterations; or
    the failure."""
    from gcms_fenicsx.dynamics.stepping.errors import IntegrationError
    from gcms_fenicsx.dynamics.run.simulate import simulate_body

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


#: Scenes a ``--worker`` runs, as tables both codes parse: the pendulum, its variants with
#: every iteration exact, with Rayleigh damping and a free body spinning (soft Nm = 10 model),
#: and "default", the built-in study's scene.
VARIANTS = {"pendulum": {},
            "exact Newton matrix": {"solver": {"jacobian": "exact"}},
            "damped": {"damping": {"alpha": 0.5, "beta": 4e-3}, "end_time": 0.3},
            "free spin": {"end_time": 0.2, "joints": [], "gravity": [0.0, 0.0, 0.0],
                          "initial": {"angular_velocity": [1.0, 2.0, 3.0], "mode": 1,
                                      "amplitude": 1e-3}}}


def worker(model_path: str, scene_name: str, runs: int, save: str) -> None:
    """Run ``scene_name`` (a key of VARIANTS or "default") on the reduced model ``runs`` times
    with the ``gcms_fenicsx`` this process imports and print the best timing as JSON; then
    once more recording q and save q, λ and the Newton iterations of every step to ``save``
    (.npz)."""
    from dataclasses import replace

    import numpy as np

    from gcms_fenicsx.dynamics import parse_scene, read_reduced, simulate

    if scene_name == "default":
        from gcms_fenicsx.config.study import parse_config
        scene = parse_config(default_study()).scene
    else:
        from gcms_fenicsx.references import pendulum
        scene = parse_scene(dict(pendulum.STUDY["scene"], **VARIANTS[scene_name]))
    model = read_reduced(model_path)
    best = None
    for _ in range(runs):
        _, summary = simulate(model, scene)
        if not summary["complete"]:
            print(json.dumps({"failed": summary["message"]}))
            return
        if best is None or summary["time_per_step_us"] < best["time_per_step_us"]:
            best = {k: summary[k] for k in ("time_per_step_us", "steps_per_second",
                                            "newton_iterations_mean", "steps", "wall_time_s")}
    every = replace(scene.outputs, coordinates=True, every=1)
    traj, _ = simulate(model, replace(scene, outputs=every))
    np.savez(save, iterations=traj.newton_iterations, q=traj.coordinates["q"],
             multipliers=traj.multipliers)
    print(json.dumps(dict(best, reduced_dofs=int(traj.coordinates["q"].shape[1]))))


def run_worker(code: Path, model_path: Path, scene_name: str, save: Path) -> dict:
    """One ``--worker`` process importing ``gcms_fenicsx`` from the checkout ``code``."""
    env = dict(os.environ, PYTHONPATH=str(code), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker",
                          str(model_path), "--scene", scene_name, "--save", str(save)],
                         env=env, cwd=code, capture_output=True, text=True)
    if out.returncode:
        return {"failed": out.stderr.strip().splitlines()[-1]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def before_after(model_path: Path, scene_name: str, before: Path, rounds: int) -> dict:
    """µs per step with the code in ``before`` and with this checkout, alternating, best of
    ``rounds`` each; whether every step's Newton iterations agree, and the largest difference
    of q (relative to the largest |q|) and of λ (relative to the largest |λ|) over the run."""
    import numpy as np

    best: dict[str, dict] = {}
    saves = {"before": model_path.with_suffix(f".{scene_name}.before.npz"),
             "after": model_path.with_suffix(f".{scene_name}.after.npz")}
    for _ in range(rounds):
        for label, code in (("before", before), ("after", REPO)):
            run = run_worker(code, model_path, scene_name, saves[label])
            if "failed" in run:
                return {label: run}
            if label not in best or run["time_per_step_us"] < best[label]["time_per_step_us"]:
                best[label] = run
    a, b = np.load(saves["before"]), np.load(saves["after"])
    lam = np.abs(a["multipliers"]).max() if a["multipliers"].size else 0.0
    best["same_iterations"] = bool(np.array_equal(a["iterations"], b["iterations"]))
    best["max_rel_q_difference"] = float(np.abs(a["q"] - b["q"]).max() / np.abs(a["q"]).max())
    best["max_rel_multiplier_difference"] = (
        float(np.abs(a["multipliers"] - b["multipliers"]).max() / lam) if lam else 0.0)
    best["speedup"] = best["before"]["time_per_step_us"] / best["after"]["time_per_step_us"]
    return best


def default_scene_model(folder: Path) -> tuple[Path, int]:
    """The reduced model of ``gcms run``'s built-in study, through the pipeline's stages, and
    its mode count."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.files.reduced_model import write_reduced

    cfg = parse_config(default_study(basis={"attachment": "none"}))
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    reduction = pipeline.reduction_stage(
        pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body), cfg.selection)
    path = folder / "default_scene.h5"
    write_reduced(path, reduction)
    return path, cfg.plan.body.modes.count


def main() -> None:
    options = parser(__doc__, out="docs/bench_integrator", repeat=3)
    options.add_argument("--before", type=Path, default=None,
                         help="a checkout of the code to compare against")
    worker_options(options, "--worker", "--save")
    options.add_argument("--scene", default="pendulum", help=argparse.SUPPRESS)
    args = options.parse_args()
    if args.worker:
        worker(args.worker, args.scene, 2, args.save)
        return
    checkout(options, args.before)
    quiet()
    from gcms_fenicsx.config.scene import parse_scene
    from gcms_fenicsx.files.reduced_model import write_reduced
    from gcms_fenicsx.references import pendulum

    scene = parse_scene(pendulum.STUDY["scene"])
    rows: list[dict] = []
    variants: dict[str, dict] = {}
    with temporary_folder() as tmp:
        for material, nm, label, model, body, report in bodies():
            row = {"material": material, "modes": nm, "selection": label}
            if body is None:
                row["failed"] = report
            else:
                row.update(reduced_dofs=body.dofs, cond_mr=report["cond_mr_after"],
                           pruning_error=report["max_rel_frequency_error"])
                row["rotated"] = timed(body, scene, "rotated", args.repeat)
                row["assembled"] = timed(body, scene, "assembled", args.repeat)
                if args.before is not None and label == "default":
                    path = tmp / f"{material}{nm}.h5"
                    write_reduced(path, model)
                    row["before_after"] = before_after(path, "pendulum", args.before,
                                                       args.repeat)
            rows.append(row)
            log(f"{material}, Nm = {nm}, selection {label}: "
                f"{json.dumps({k: v for k, v in row.items() if k in ('reduced_dofs', 'failed')})}")
        if args.before is not None:
            for name in list(VARIANTS)[1:]:
                log(f"soft, Nm = {VARIANT_MODES}, {name}: before and after")
                variants[name] = dict(before_after(tmp / f"soft{VARIANT_MODES}.h5", name,
                                                   args.before, args.repeat),
                                      modes=VARIANT_MODES)
            log("default scene: meshing and solving the crankshaft")
            path, modes = default_scene_model(tmp)
            variants["default scene (crankshaft)"] = dict(
                before_after(path, "default", args.before, args.repeat), modes=modes)
    write_record(Path(f"{args.out}.json"), {"pendulum": rows, "variants": variants}
                 if args.before is not None else {"pendulum": rows})
    plot(rows, Path(f"{args.out}.png"))
    print(table(rows))
    if args.before is not None:
        print()
        print(before_after_table(rows, variants))


def _cell(run: dict) -> tuple[str, str, str]:
    if "failed" in run:
        return "failed", "", ""
    return (f"{run['steps_per_second']:,.0f}", f"{run['time_per_step_us']:,.0f}",
            f"{run['newton_iterations_mean']:.2f}")


def before_after_table(rows: list[dict], variants: dict[str, dict]) -> str:
    """µs per step before and after, with the trajectories' agreement, per case."""
    lines = table_head("case", "Nm", "reduced DOFs", "µs/step before", "µs/step after",
                       "speedup", "same Newton iterations", "max rel. q difference",
                       "max rel. λ difference")
    cases = [(f"{r['material']} pendulum", r["modes"], r["reduced_dofs"], r["before_after"])
             for r in rows if "before_after" in r]
    cases += [(f"soft pendulum, {name}" if name in VARIANTS else name, ba["modes"],
               ba.get("after", {}).get("reduced_dofs", ""), ba) for name, ba in variants.items()]
    for name, nm, dofs, ba in cases:
        if "speedup" not in ba:
            lines.append(f"| {name} | {nm} | {dofs} | failed: {json.dumps(ba)[:80]} | | | | | |")
            continue
        lines.append(table_row(
            name, nm, dofs, *(f"{ba[k]['time_per_step_us']:,.0f}" for k in ("before", "after")),
            f"{ba['speedup']:.2f}×", "yes" if ba["same_iterations"] else "NO",
            *(f"{ba[f'max_rel_{k}_difference']:.1e}" for k in ("q", "multiplier"))))
    return "\n".join(lines)


def table(rows: list[dict]) -> str:
    lines = table_head("pendulum", "Nm", "selection", "reduced DOFs", "cond(Mr)", "steps/s",
                       "µs/step", "Newton it.", "baseline steps/s", "baseline it.", "speedup")
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
        note = f" ({fast['failed'].split(' (')[0]})" if "failed" in fast else ""
        lines.append(f"| {r['material']} | {r['modes']} | {r['selection']} | {r['reduced_dofs']} "
                     f"| {r['cond_mr']:.1e} | {sps}{note} | {us} | {it} | {bsps} | {bit} | {ratio} |")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
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
    save_figure(fig, path)


if __name__ == "__main__":
    main()
