"""Integrator speed: the compiled step against the NumPy step and against the code before a
change, on the flexible pendulum for Nm = 5, 10, 20, 50 and on the default crankshaft scene
in every basis.

The pendulum is the case of ``gcms_fenicsx.pendulum`` (revolute joint, gravity, h = 1 ms,
1 s), in its soft polymer (E = 0.1 GPa: the validation case, strains ~1e-3) and in a stiff one
(E = 3 GPa). For each Nm, with the default selection and (soft) without any, the run is timed
with the compiled step (``[scene.solver] kernel``, default "auto": Numba), with the NumPy step
("numpy", the reference), and with the baseline, textbook Newton with the exact iteration
matrix assembled and LU-factorised in every iteration ("assembled", NumPy, 100 steps).

The default scene of ``gcms run`` (the crankshaft spun up in its bearings while its
cylinders fire; its reduced model: ten modes with attachment modes, 282 coordinates) runs in
the four bases of ``[basis]``: full and rotor, on the modes and on the scene's static shapes
(282, 100, 120 and 46 coordinates), with either step: µs per step against coordinates.

The compile: a run in a fresh process with an empty Numba cache (``NUMBA_CACHE_DIR``), then
again with the cache it left: what the run's summary says of the kernel, and the wall time.

With ``--before DIR`` (a checkout of an earlier commit: ``git worktree add DIR <commit>``),
every default-selection pendulum case, the soft Nm = 10 pendulum with every Newton matrix
exact, with Rayleigh damping and as a free spinning body, the soft pendulum with the Saint
Venant–Kirchhoff law on 18 and 47 fields (Nm = 5; Nm = 10 with attachment modes), and the
default scene in the full basis (282) and on the rotor static shapes (46) are also run with
that code on the same reduced model, alternating with this one, each run in a fresh process
(``--worker``): µs per step before and after, their ratio, whether every step's Newton
iterations agree, and the largest differences of q and λ over the run, relative to their
largest values.

One BLAS thread (small dense algebra gains nothing from threads). Each timing is the best
of ``--repeat`` runs; ratios are the figures to read, since this machine is shared and its
absolute speed varies.

    python workflows/bench_integrator.py [--out docs/bench_integrator] [--repeat 3]
                                         [--before DIR]

writes OUT.json (``pendulum``: a row a case; ``coordinates``; ``compile``; ``variants`` with
``--before``), OUT.png and prints the tables of docs/compiled-step.md.
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


def timed(body, scene, jacobian: str, repeat: int, kernel: str = "auto") -> dict:
    """Best of ``repeat`` runs in this process: steps/s, µs per step, Newton iterations; or
    the failure. ``kernel``: the step (``[scene.solver] kernel``)."""
    from gcms_fenicsx.dynamics.stepping.errors import IntegrationError
    from gcms_fenicsx.dynamics.run.simulate import simulate_body

    sc = replace(scene, solver=replace(scene.solver, jacobian=jacobian, kernel=kernel),
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
                    "steps": summary["steps"], "kernel": summary["kernel"]["name"],
                    "tip": traj.groups["end_xL"]["position"][-1].tolist()}
    return best


#: Scenes a ``--worker`` runs, as tables both codes parse: the pendulum, its variants with
#: every iteration exact, with Rayleigh damping and a free body spinning (soft Nm = 10 model),
#: the Saint Venant–Kirchhoff law (its own models), and the built-in study's scene in the full
#: basis ("default") and on the rotor static shapes (DEFAULT_ROTOR_STATIC).
VARIANTS = {"pendulum": {},
            "exact Newton matrix": {"solver": {"jacobian": "exact"}},
            "damped": {"damping": {"alpha": 0.5, "beta": 4e-3}, "end_time": 0.3},
            "free spin": {"end_time": 0.2, "joints": [], "gravity": [0.0, 0.0, 0.0],
                          "initial": {"angular_velocity": [1.0, 2.0, 3.0], "mode": 1,
                                      "amplitude": 1e-3}},
            "svk": {"elasticity": "svk", "end_time": 0.1,
                    "solver": {"tolerance": 1e-8, "max_iterations": 60}}}
DEFAULT_ROTOR_STATIC = "default, rotor static shapes"
#: The SVK variant's models: (label, Nm, [basis] attachment) of the soft pendulum.
SVK_MODELS = (("18 fields", 5, "none"), ("47 fields", 10, "scene"))


def worker(model_path: str, scene_name: str, runs: int, save: str) -> None:
    """Run ``scene_name`` (a key of VARIANTS or "default") on the reduced model ``runs`` times
    with the ``gcms_fenicsx`` this process imports and print the best timing as JSON; then
    once more recording q and save q, λ and the Newton iterations of every step to ``save``
    (.npz)."""
    from dataclasses import replace

    import numpy as np

    from gcms_fenicsx.dynamics import parse_scene, read_reduced, simulate

    options: dict = {}
    if scene_name in ("default", DEFAULT_ROTOR_STATIC):
        from gcms_fenicsx.config.study import parse_config
        shapes = {"kind": "rotor", "shapes": "static"} if scene_name != "default" else {}
        plan = parse_config(default_study(basis=shapes)).plan.scene
        scene = plan.scene
        options = dict(basis=plan.basis, attachment=plan.attachment, static=plan.shapes)
    else:
        from gcms_fenicsx.references import pendulum
        scene = parse_scene(dict(pendulum.STUDY["scene"], **VARIANTS[scene_name]))
    model = read_reduced(model_path)
    best = None
    for _ in range(runs):
        _, summary = simulate(model, scene, **options)
        if not summary["complete"]:
            print(json.dumps({"failed": summary["message"]}))
            return
        if best is None or summary["time_per_step_us"] < best["time_per_step_us"]:
            best = {k: summary[k] for k in ("time_per_step_us", "steps_per_second",
                                            "newton_iterations_mean", "steps", "wall_time_s",
                                            "reduced_dofs")}
    every = replace(scene.outputs, coordinates=True, every=1)
    traj, _ = simulate(model, replace(scene, outputs=every), **options)
    np.savez(save, iterations=traj.newton_iterations, q=traj.coordinates["q"],
             multipliers=traj.multipliers)
    print(json.dumps(best))


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


#: The default scene's bases: (label, [basis] kind, shapes).
BASES = (("full, modes", "full", "modes"), ("rotor, modes", "rotor", "modes"),
         ("full, static shapes", "full", "static"), ("rotor, static shapes", "rotor", "static"))


def default_scene_model(folder: Path) -> Path:
    """The reduced model of ``gcms run``'s built-in study (ten modes with attachment modes),
    through the pipeline's stages, written to ``folder``."""
    from gcms_fenicsx.files.reduced_model import write_reduced
    from common.crankshaft import run_chain

    _, reduced, _ = run_chain(default_study(), folder)
    path = folder / "default_scene.h5"
    write_reduced(path, reduced)
    return path


def coordinates_rows(path: Path, repeat: int) -> list[dict]:
    """The default scene in every basis with either step, alternating, best of ``repeat``:
    µs per step against coordinates."""
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.run.simulate import simulate
    from gcms_fenicsx.files.reduced_model import read_reduced

    model = read_reduced(path)
    rows = []
    for label, kind, shapes in BASES:
        plan = parse_config(default_study(basis={"kind": kind, "shapes": shapes})).plan.scene
        row: dict = {"basis": label}
        for _ in range(repeat):
            for name in ("numba", "numpy"):
                scene = replace(plan.scene, solver=replace(plan.scene.solver, kernel=name))
                _, summary = simulate(model, scene, basis=plan.basis, attachment=plan.attachment,
                                      static=plan.shapes)
                if not summary["complete"]:
                    raise SystemExit(f"{label}, {name}: {summary['message']}")
                if name not in row or summary["time_per_step_us"] < row[name]["time_per_step_us"]:
                    row[name] = {k: summary[k] for k in ("time_per_step_us", "steps_per_second",
                                                         "newton_iterations_mean")}
                row["coordinates"] = summary["reduced_dofs"]
        row["compiled_speedup"] = (row["numpy"]["time_per_step_us"]
                                   / row["numba"]["time_per_step_us"])
        rows.append(row)
        log(f"default scene, {label}: {row['coordinates']} coordinates, "
            f"{row['numba']['time_per_step_us']:.0f} µs/step compiled, "
            f"{row['numpy']['time_per_step_us']:.0f} in NumPy")
    return rows


def compile_times(path: Path, folder: Path) -> dict:
    """The default scene (full basis) in a fresh process with an empty Numba cache, then again
    with the cache that run left: each run's kernel block and wall time."""
    cache = folder / "numba-cache"
    out = {}
    for label in ("first run", "cached"):
        env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), OPENBLAS_NUM_THREADS="1",
                   PYTHONPATH=str(REPO))
        script = ("import json, sys, time; t = time.perf_counter(); "
                  "from gcms_fenicsx.config.study import parse_config; "
                  "from gcms_fenicsx.dynamics import read_reduced, simulate; "
                  f"sys.path.insert(0, {str(Path(__file__).parent)!r}); "
                  "from common.crankshaft import default_study; "
                  "_, s = simulate(read_reduced(sys.argv[1]), parse_config(default_study()).scene); "
                  "print(json.dumps(dict(s['kernel'], wall_s=time.perf_counter() - t, "
                  "simulation_s=s['wall_time_s'])))")
        run = subprocess.run([sys.executable, "-c", script, str(path)], env=env,
                             capture_output=True, text=True, cwd=REPO)
        if run.returncode:
            raise SystemExit(run.stderr.strip().splitlines()[-1])
        out[label] = json.loads(run.stdout.strip().splitlines()[-1])
        log(f"compile, {label}: {out[label]}")
    return out


def svk_models(folder: Path) -> dict[str, Path]:
    """The soft pendulum's reduced models with their SVK coefficients (``SVK_MODELS``)."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.material import parse_material
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.fe.svk_coefficients import svk_coefficients
    from gcms_fenicsx.files.reduced_model import write_reduced
    from gcms_fenicsx.references import pendulum

    paths = {}
    for label, nm, attachment in SVK_MODELS:
        cfg = parse_config(dict(pendulum.STUDY, modes={"count": nm},
                                basis={"attachment": attachment}))
        material = parse_material(dict(pendulum.STUDY["material"], E=MATERIALS_E_PA["soft"]))
        where = folder / label.replace(" ", "_")
        where.mkdir()
        chain = pipeline.free_free(cfg.geometry, cfg.mesh, material, cfg.plan.body.modes, where)
        reduced = pipeline.reduction_stage(
            pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body), cfg.selection)
        coefficients, _ = svk_coefficients(chain.body.mesh, reduced.fields, material)
        paths[label] = folder / f"svk_{nm}.h5"
        write_reduced(paths[label], replace(reduced, svk=coefficients))
        log(f"SVK model {label}: {reduced.fields.shape[1]} fields")
    return paths


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
                row["numpy"] = timed(body, scene, "rotated", args.repeat, kernel="numpy")
                row["assembled"] = timed(body, scene, "assembled", args.repeat)
                if args.before is not None and label == "default":
                    path = tmp / f"{material}{nm}.h5"
                    write_reduced(path, model)
                    row["before_after"] = before_after(path, "pendulum", args.before,
                                                       args.repeat)
            rows.append(row)
            log(f"{material}, Nm = {nm}, selection {label}: "
                f"{json.dumps({k: v for k, v in row.items() if k in ('reduced_dofs', 'failed')})}")
        log("default scene: meshing and solving the crankshaft")
        default = default_scene_model(tmp)
        coordinates = coordinates_rows(default, args.repeat)
        compile_record = compile_times(default, tmp)
        if args.before is not None:
            for name in ("exact Newton matrix", "damped", "free spin"):
                log(f"soft, Nm = {VARIANT_MODES}, {name}: before and after")
                variants[name] = dict(before_after(tmp / f"soft{VARIANT_MODES}.h5", name,
                                                   args.before, args.repeat),
                                      modes=VARIANT_MODES)
            for label, path in svk_models(tmp).items():
                log(f"SVK, {label}: before and after")
                variants[f"SVK, {label}"] = dict(before_after(path, "svk", args.before,
                                                              args.repeat),
                                                 modes=dict((m[0], m[1]) for m in SVK_MODELS)[label])
            for name in ("default", DEFAULT_ROTOR_STATIC):
                log(f"{name}: before and after")
                variants[name] = dict(before_after(default, name, args.before, args.repeat),
                                      modes=10)
    document = {"pendulum": rows, "coordinates": coordinates, "compile": compile_record}
    if args.before is not None:
        document["variants"] = variants
    write_record(Path(f"{args.out}.json"), document)
    plot(rows, coordinates, Path(f"{args.out}.png"))
    print(table(rows))
    print()
    print(coordinates_table(coordinates))
    print()
    print(compile_table(compile_record))
    if args.before is not None:
        print()
        print(before_after_table(rows, variants))


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
            name, nm, dofs, *(f"{ba[k]['time_per_step_us']:,.1f}" for k in ("before", "after")),
            f"{ba['speedup']:.2f}×", "yes" if ba["same_iterations"] else "NO",
            *(f"{ba[f'max_rel_{k}_difference']:.1e}" for k in ("q", "multiplier"))))
    return "\n".join(lines)


def _cell(run: dict) -> tuple[str, str, str]:
    if "failed" in run:
        return "failed", "", ""
    return (f"{run['steps_per_second']:,.0f}", f"{run['time_per_step_us']:,.1f}",
            f"{run['newton_iterations_mean']:.2f}")


def table(rows: list[dict]) -> str:
    """The pendulum: the compiled step, the NumPy step and the assembled baseline."""
    lines = table_head("pendulum", "Nm", "selection", "reduced DOFs", "cond(Mr)", "steps/s",
                       "µs/step", "Newton it.", "NumPy µs/step", "compiled speedup",
                       "baseline steps/s", "over baseline")
    for r in rows:
        if "failed" in r:
            lines.append(f"| {r['material']} | {r['modes']} | {r['selection']} | — | — | "
                         f"reduction failed: {r['failed'][:70]} | | | | | | |")
            continue
        fast, numpy, base = r["rotated"], r["numpy"], r["assembled"]
        sps, us, it = _cell(fast)
        _, nus, _ = _cell(numpy)
        bsps, _, _ = _cell(base)
        ok = not any("failed" in x for x in (fast, numpy, base))
        lines.append(table_row(
            r["material"], r["modes"], r["selection"], r["reduced_dofs"], f"{r['cond_mr']:.1e}",
            sps, us, it, nus,
            f"{numpy['time_per_step_us'] / fast['time_per_step_us']:.1f}×" if ok else "",
            bsps, f"{fast['steps_per_second'] / base['steps_per_second']:.0f}×" if ok else ""))
    return "\n".join(lines)


def coordinates_table(rows: list[dict]) -> str:
    """The default scene: µs per step against coordinates, with either step."""
    lines = table_head("default scene, basis", "coordinates", "compiled µs/step",
                       "compiled steps/s", "NumPy µs/step", "compiled speedup",
                       "Newton it.", "µs/step over the 46-coordinate one")
    smallest = min(rows, key=lambda r: r["coordinates"])["numba"]["time_per_step_us"]
    for r in sorted(rows, key=lambda r: r["coordinates"]):
        c, n = r["numba"], r["numpy"]
        lines.append(table_row(r["basis"], r["coordinates"], f"{c['time_per_step_us']:,.1f}",
                               f"{c['steps_per_second']:,.0f}", f"{n['time_per_step_us']:,.1f}",
                               f"{r['compiled_speedup']:.1f}×",
                               f"{c['newton_iterations_mean']:.2f}",
                               f"{c['time_per_step_us'] / smallest:.2f}×"))
    return "\n".join(lines)


def compile_table(record: dict) -> str:
    """The kernel's compile in a fresh process, and its load from the cache that left."""
    lines = table_head("run", "kernel", "compile or load (s)", "from the cache",
                       "simulation (s)", "process wall time (s)")
    for label, r in record.items():
        lines.append(table_row(label, r["name"], f"{r['compile_s']:.2f}",
                               r["loaded_from_cache"], f"{r['simulation_s']:.2f}",
                               f"{r['wall_s']:.1f}"))
    return "\n".join(lines)


def plot(rows: list[dict], coordinates: list[dict], path: Path) -> None:
    """µs per step against coordinates: the pendulum (default selection) and the default
    scene's bases, the compiled and the NumPy step."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for material, marker in (("soft", "o"), ("stiff", "s")):
        for method, style, name in (("rotated", "-", "compiled"), ("numpy", "--", "NumPy")):
            pts = sorted((r["reduced_dofs"], r[method]["time_per_step_us"]) for r in rows
                         if r["material"] == material and r["selection"] == "default"
                         and "failed" not in r[method])
            if pts:
                x, y = zip(*pts)
                ax.loglog(x, y, marker + style, label=f"pendulum {material}, {name}")
    for kernel, style, name in (("numba", "-", "compiled"), ("numpy", "--", "NumPy")):
        pts = sorted((r["coordinates"], r[kernel]["time_per_step_us"]) for r in coordinates)
        x, y = zip(*pts)
        ax.loglog(x, y, "^" + style, color="k", label=f"crankshaft scene, {name}")
    ax.axhline(50.0, color="k", lw=0.7, ls=":", label="50 µs (20,000 steps/s)")
    ax.set_xlabel("coordinates")
    ax.set_ylabel("µs per step")
    ax.set_title("Generalized-α step, one core")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    save_figure(fig, path)


if __name__ == "__main__":
    main()
