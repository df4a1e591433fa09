"""The rotor basis against the full one on the default crankshaft scene: coordinates, steps
per second (the ratio in the same run is the figure to read) and how far the outputs of the
two bases are apart, beside how far each is from itself at half the time step.

For Nm = 5, 10, 20 and 40 (``--modes``) the default study's modes are solved once, with the
scene's attachment modes (``[basis] attachment = "scene"``, the default), and reduced with and
without them (``pipeline``); each reduced model runs the built-in scene in both bases,
alternating, ``--repeat`` times each (best time kept). The scene starts at rest in its
bearings and its drive and gas forces rise in smoothly, so the 50 µs step resolves its
outputs (the h vs h/2 columns state it). The model
with attachment modes also runs on its static shapes (``[basis] shapes = "static"``: the
held body's static responses to the scene's load patterns, in both bases), compared besides
with the full basis on the model's modes (``against_modes``: steps/s ratio and differences).
The
outputs are the nose's whirl, the bearing forces and the drive torque
(``auto_modes.outputs``), compared as the flexible pendulum compares its tip:
max_t |y − y_ref| / max_t |y_ref| over the whole run.

The floor (``skeleton``): beside each pair of runs, the time per step of the least a
generalized-α Newton step of the same coordinates and constraint rows computes — per
iteration the residual [Mr q̈ + Kr q − f + Cᵀλ; C q], one product with the inverse of the
bordered iteration matrix, the update and the increment's norm, as many iterations as the
runs took; no frame, damping, drive or loads. Its full/rotor ratio is what the rotor basis
would gain if a step cost nothing beyond that arithmetic; and a speedup of 2 with the
overhead both bases share cut alike would need the rotor step at t_full − t_rotor
(``rotor_step_for_2x_us``), to compare with its skeleton.

    python workflows/bench_rotor.py [--out docs/bench_rotor] [--repeat 3] [--modes 10 ...]

writes OUT.json and prints the table recorded in README.md. One BLAS thread.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import argparse
import json
import logging
import math
import sys
import tempfile
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from auto_modes import errors, outputs  # noqa: E402

MODE_COUNTS = (5, 10, 20, 40)
ATTACHMENT = ("none", "scene")


def repeat_count(text: str) -> int:
    """``--repeat``: how many runs of each basis the best is taken of, at least one."""
    count = int(text)
    if count < 1:
        raise argparse.ArgumentTypeError(f"needs at least one run, not {count}")
    return count


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run(model, scene, basis: str, attachment: tuple, static=None) -> tuple[dict, dict]:
    """(outputs and their times, summary) of one run of ``scene`` in ``basis`` (on the static
    shapes of the scene's ``static`` patterns, if given)."""
    from gcms_fenicsx.dynamics.simulate import simulate

    traj, summary = simulate(model, scene, basis=basis, attachment=attachment, static=static)
    if not summary["complete"]:
        raise SystemExit(f"{basis} basis: {summary['message']}")
    return dict(outputs(traj), time=traj.time), summary


def case(model, scene, repeat: int, attachment: tuple, static=None) -> tuple[dict, dict]:
    """Both bases on ``scene``, alternating, the fastest of ``repeat`` runs each kept; and
    both once at half the step: (row, the fastest runs' outputs and summaries).
    ``attachment``: the loads of the model's attachment modes (the rotor basis makes its own
    from them); ``static``: the scene's patterns of the static shapes, if the bases are on
    them (``config.basis.ScenePatterns``)."""
    half = replace(scene, time_step_s=scene.time_step_s / 2)
    out, summaries = {}, {}
    for _ in range(repeat):
        for basis in ("full", "rotor"):
            o, s = run(model, scene, basis, attachment, static)
            if basis not in summaries or s["wall_time_s"] < summaries[basis]["wall_time_s"]:
                out[basis], summaries[basis] = o, s
    halves = {basis: run(model, half, basis, attachment, static)[0]
              for basis in ("full", "rotor")}
    thinned = {b: {k: v[::2] for k, v in o.items()} for b, o in halves.items()}
    full, rotor = summaries["full"], summaries["rotor"]
    return {
        "coordinates": {"full": full["reduced_dofs"], "rotor": rotor["reduced_dofs"]},
        "steps_per_second": {"full": full["steps_per_second"],
                             "rotor": rotor["steps_per_second"]},
        "speedup": rotor["steps_per_second"] / full["steps_per_second"],
        "floor": floor(summaries),
        "rotor_vs_full": errors(out["rotor"], out["full"]),
        "full_vs_half_step": errors(out["full"], thinned["full"]),
        "rotor_vs_half_step": errors(out["rotor"], thinned["rotor"]),
    }, {"outputs": out, "summaries": summaries}


def skeleton(n: int, m: int, iterations: int) -> Callable[[int], float]:
    """The floor (module docstring) for n coordinates, m rows and ``iterations`` Newton
    iterations per step, on random dense matrices: a function of a step count that runs them
    and returns the µs per step."""
    import time

    import numpy as np

    rng = np.random.default_rng(0)
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    K, C = M.copy(), rng.standard_normal((m, n))
    inverse = np.linalg.inv(np.block([[M + K, C.T], [C, np.zeros((m, m))]]))
    predictor, update = 0.9 * np.eye(4), np.array([[1.0], [0.5], [0.2], [0.1]])
    f, rhs = rng.standard_normal(n), np.zeros(n + m)

    def run(steps: int) -> float:
        Z, lam = np.zeros((4, n)), np.zeros(m)
        t0 = time.perf_counter()
        for _ in range(steps):
            Z = predictor.dot(Z)
            q, acc = Z[0], Z[2]
            for _ in range(iterations):
                rhs[:n] = M.dot(acc)
                rhs[:n] += K.dot(q)
                rhs[:n] -= f
                rhs[:n] += C.T.dot(lam)
                rhs[n:] = C.dot(q)
                d = inverse.dot(rhs)
                Z -= update * d[:n]
                lam -= d[n:]
                math.sqrt(d[:n].dot(d[:n]))
        return (time.perf_counter() - t0) / steps * 1e6
    return run


def floor(summaries: dict, repeat: int = 15, steps: int = 2000) -> dict:
    """The measured µs per step of both bases, their floors (best of ``repeat`` runs of
    ``steps``, the two bases alternating), and the rotor step a speedup of 2 would need
    (module docstring)."""
    bases = ("full", "rotor")
    step = {b: 1e6 / summaries[b]["steps_per_second"] for b in bases}
    runs = {b: skeleton(summaries[b]["reduced_dofs"], summaries[b]["constraint_rows"],
                        max(1, round(summaries[b]["newton_iterations_mean"]))) for b in bases}
    best = dict.fromkeys(bases, math.inf)
    for _ in range(repeat):
        for b in bases:
            best[b] = min(best[b], runs[b](steps))
    return {"step_us": step, "skeleton_us": best,
            "skeleton_ratio": best["full"] / best["rotor"],
            "rotor_step_for_2x_us": step["full"] - step["rotor"]}


def against_modes(static: dict, modes: dict) -> dict:
    """How the runs on the static shapes compare with the full basis on the model's modes
    (the same model, the same scene): its steps/s over theirs, the differences."""
    reference = modes["summaries"]["full"]["steps_per_second"]
    return {b: {"speedup": static["summaries"][b]["steps_per_second"] / reference,
                "difference": errors(static["outputs"][b], modes["outputs"]["full"])}
            for b in ("full", "rotor")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/bench_rotor"))
    parser.add_argument("--repeat", type=repeat_count, default=3)
    parser.add_argument("--modes", type=int, nargs="+", default=list(MODE_COUNTS))
    args = parser.parse_args()
    logging.disable(logging.INFO)
    from gcms_fenicsx import pipeline
    from gcms_fenicsx.config.basis import scene_patterns
    from gcms_fenicsx.config.study import default_config_text, parse_config

    raw = dict(tomllib.loads(default_config_text()), basis={"attachment": "scene"})
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for nm in args.modes:
            cfg = parse_config(dict(raw, modes={"count": nm}))
            static = scene_patterns(replace(cfg.basis, shapes="static"), cfg.scene)
            chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.modes,
                                       Path(tmp))
            for attachment in ATTACHMENT:
                loads = cfg.modes.attachment if attachment == "scene" else ()
                modes = chain.modes if loads else replace(chain.modes, attachment_labels=())
                basis = pipeline.basis_stage(chain.assembly.model, modes, chain.body)
                model = pipeline.reduction_stage(basis, cfg.selection)
                result, runs = case(model, cfg.scene, args.repeat, loads)
                rows.append(dict(modes=nm, attachment=attachment, shapes="modes", **result))
                log(json.dumps(rows[-1]))
                if not loads:
                    continue
                result, shaped = case(model, cfg.scene, args.repeat, loads, static)
                rows.append(dict(modes=nm, attachment=attachment, shapes="static", **result,
                                 against_modes=against_modes(shaped, runs)))
                log(json.dumps(rows[-1]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps({"rows": rows}, indent=1))
    print(table(rows))


def table(rows: list[dict]) -> str:
    lines = ["| Nm | attachment | shapes | coordinates full → rotor | steps/s full | "
             "steps/s rotor | speedup | rotor vs full (whirl, forces, torque) | "
             "full: h vs h/2 | rotor: h vs h/2 |",
             "|---|---|---|---|---|---|---|---|---|---|"]

    def three(e: dict) -> str:
        return ", ".join(f"{100 * e[k]:.1f} %" for k in ("nose whirl", "bearing forces",
                                                          "drive torque"))

    for r in rows:
        c, s = r["coordinates"], r["steps_per_second"]
        lines.append(f"| {r['modes']} | {r['attachment']} | {r['shapes']} | "
                     f"{c['full']} → {c['rotor']} | "
                     f"{s['full']:,.0f} | {s['rotor']:,.0f} | {r['speedup']:.2f}× | "
                     f"{three(r['rotor_vs_full'])} | "
                     f"{three(r['full_vs_half_step'])} | {three(r['rotor_vs_half_step'])} |")
    lines += ["", "| Nm | attachment | shapes | coordinates full → rotor | µs/step full, rotor | "
              "floor full, rotor | floor ratio | rotor step a 2× speedup needs |",
              "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        f, c = r["floor"], r["coordinates"]
        lines.append(f"| {r['modes']} | {r['attachment']} | {r['shapes']} | {c['full']} → "
                     f"{c['rotor']} | {f['step_us']['full']:.0f}, {f['step_us']['rotor']:.0f} | "
                     f"{f['skeleton_us']['full']:.0f}, {f['skeleton_us']['rotor']:.0f} | "
                     f"{f['skeleton_ratio']:.2f}× | {f['rotor_step_for_2x_us']:.0f} µs |")
    static = [r for r in rows if "against_modes" in r]
    if static:
        lines += ["", "| Nm | static shapes in | coordinates | steps/s against the full "
                  "basis on the modes | difference from it |", "|---|---|---|---|---|"]
    for r in static:
        for b in ("full", "rotor"):
            a = r["against_modes"][b]
            lines.append(f"| {r['modes']} | {b} | {r['coordinates'][b]} | "
                         f"{a['speedup']:.2f}× | {three(a['difference'])} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
