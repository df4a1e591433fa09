"""Where a time step's time goes: the integrator's per-step profile, before and after a change.

On the soft flexible pendulum (the validation case of docs/flexible_pendulum.md: 1 ms steps,
1 s, default outputs) with Nm = 5 and 10:

1. cProfile of a whole run, in a fresh process for each code: Python function calls per
   step, NumPy calls per step (functions and methods cProfile sees: ``dot``, ``reshape``,
   ``copy``, NumPy's Python-level functions; the arithmetic operators ``a − b``, ``a += b``
   and direct calls of LAPACK gufuncs are not function calls to it) and the share of the
   profiled step time in the elastic forces, the Newton matrix (``prepare``), the linear
   solve and the recorder. With ``--before DIR`` (``git worktree add DIR <commit>``), the
   same for that checkout.
2. For this code, each stage timed alone (best of 5 × 20,000 calls, hot caches) on the
   state 300 steps into the run, and timed around each call in a run of the bare stepping
   loop, with its calls per step: what is left of the loop's µs per step is the step's own
   lines (residual, constraints, turning r, Newton norm, update, predictor, Python), and
   what the simulation takes beyond the loop is the recorder's.

    python workflows/profile_step.py [--before DIR] [--out docs/integrator_profile]

writes OUT.json and prints the tables recorded in docs/integrator_profile.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: one core

import json
import subprocess
import sys
from pathlib import Path

from common import REPO, checkout, fmt, parser, table_head, temporary_folder, worker_options
from common import write_record

MODE_COUNTS = (5, 10)
#: cProfile entries whose cumulative time is a stage's, by (file name end, function name).
STAGES = {"elastic forces": ("corotated.py", "elastic_state"),
          "Newton matrix": ("kkt.py", "prepare"),
          "linear solve": ("kkt.py", "solve"),
          "recorder": ("recorder.py", "step")}


def profile_worker(model_path: str) -> None:
    """cProfile one run of the pendulum scene with the ``gcms_fenicsx`` this process imports;
    print the per-step counts and stage shares as JSON."""
    import cProfile
    import pstats

    from gcms_fenicsx.dynamics import parse_scene, read_reduced, simulate
    from gcms_fenicsx.references import pendulum

    model, scene = read_reduced(model_path), parse_scene(pendulum.STUDY["scene"])
    simulate(model, scene)                                        # warm
    best = min(simulate(model, scene)[1]["time_per_step_us"] for _ in range(3))
    profiler = cProfile.Profile()
    profiler.enable()
    _, summary = simulate(model, scene)
    profiler.disable()
    stats = pstats.Stats(profiler).stats
    steps = summary["steps"]
    numpy_calls = python_calls = 0
    step_time = None
    shares: dict[str, float] = {}
    for (path, _, name), (_, calls, _, cumulative, _) in stats.items():
        if path == "~" and ("numpy" in name or "of 'numpy" in name):
            numpy_calls += calls
        elif "/numpy/" in path:
            numpy_calls += calls
        elif "gcms_fenicsx" in path:
            python_calls += calls
        if path.endswith("integrator.py") and name == "step":
            step_time = cumulative
        for label, (file, function) in STAGES.items():
            if path.endswith(file) and name == function:
                shares[label] = shares.get(label, 0.0) + cumulative
    stage = {label: t / step_time for label, t in shares.items()} if step_time else {}
    print(json.dumps({"time_per_step_us": best, "steps": steps,
                      "newton_iterations_mean": summary["newton_iterations_mean"],
                      "numpy_calls_per_step": numpy_calls / steps,
                      "python_calls_per_step": python_calls / steps,
                      "stage_share_of_step": stage}))


def run_profile(code: Path, model_path: Path) -> dict:
    """:func:`profile_worker` in a process importing ``gcms_fenicsx`` from ``code``."""
    env = dict(os.environ, PYTHONPATH=str(code), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker",
                          str(model_path)], env=env, cwd=code, capture_output=True, text=True)
    if out.returncode:
        return {"failed": out.stderr.strip().splitlines()[-1]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def stage_timings(model_path: Path) -> dict:
    """Each stage of this code timed alone on the state 300 steps into the run, with its
    calls per step counted in a run (module docstring, 2); µs per step of the whole run."""
    import itertools
    import time
    import timeit

    import numpy as np

    from gcms_fenicsx.dynamics import parse_scene, read_reduced, simulate_body
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.run.capacity import memory_capacity
    from gcms_fenicsx.dynamics.bodies.corotated import elastic_state
    from gcms_fenicsx.numerics.lapack import inverse, svd
    from gcms_fenicsx.dynamics.run.recorder import Recorder
    from gcms_fenicsx.files.results import MemorySink
    from gcms_fenicsx.dynamics.run.simulate import prepare_run
    from gcms_fenicsx.references import pendulum

    body = body_from_reduced(read_reduced(str(model_path)))
    scene = parse_scene(pendulum.STUDY["scene"])
    total = min(simulate_body(body, scene)[1]["time_per_step_us"] for _ in range(3))
    run = prepare_run(body, scene, memory_capacity())
    it, linear = run.integrator, run.integrator.linear
    original = {"prepare": linear.prepare, "solve": linear.solve,
                "relinearise": linear._relinearise, "elastic": it.elastic}
    counts, spent = dict.fromkeys(original, 0), dict.fromkeys(original, 0.0)

    def counting(name):
        def call(*args, **kwargs):
            counts[name] += 1
            start = time.perf_counter()
            out = original[name](*args, **kwargs)
            spent[name] += time.perf_counter() - start
            return out
        return call

    linear.prepare, linear.solve = counting("prepare"), counting("solve")
    linear._relinearise, it.elastic = counting("relinearise"), counting("elastic")
    s, info, kept = run.state, run.info, None
    start = time.perf_counter()
    for index in range(1, scene.steps + 1):
        s, info = it.step(s)
        if index == 300:
            kept = (s, info)
    in_run = {k: 1e6 * v / scene.steps for k, v in spent.items()}
    in_run["step"] = 1e6 * (time.perf_counter() - start) / scene.steps
    in_run["prepare"] -= in_run["relinearise"]
    calls = {k: v / scene.steps for k, v in counts.items()}
    s, info = kept
    q, es = s.Z[0], info.elastic
    U, C, _ = it.rows
    original["prepare"](es, U, C, True, relinearise=True)
    sized = linear.minus_inverse          # a matrix of the capacitance matrix's size
    r_l, g = np.ones(body.dofs), np.zeros(it.constraints.count)
    recorder = Recorder(body, run.constraints, run.forces, scene.outputs, run.plan,
                        scene.time_step_s, MemorySink(run.plan.layout, 10 ** 6, None))
    steps = itertools.count(1)

    def best(f):
        return min(timeit.repeat(f, number=20000, repeat=5)) / 20000 * 1e6

    A = q.reshape(-1, 3).T.dot(body.affine)
    rows = [("elastic forces (elastic_state)", best(lambda: elastic_state(body, q)),
             calls["elastic"], in_run["elastic"]),
            ("  of which the 3 × 3 SVD (LAPACK)", best(lambda: svd(A)), calls["elastic"], None),
            ("Newton matrix (prepare, rank-9 term kept)",
             best(lambda: original["prepare"](es, U, C, True, relinearise=False)),
             calls["prepare"], in_run["prepare"]),
            (f"  of which the {len(sized)}-square inverse (LAPACK)",
             best(lambda: inverse(sized)), calls["prepare"], None),
            ("rank-9 term re-linearised (local_frame_update, S₀⁻¹ X)",
             best(lambda: original["relinearise"](es)), calls["relinearise"],
             in_run["relinearise"]),
            ("linear solve (solve)", best(lambda: original["solve"](r_l, g)), calls["solve"],
             in_run["solve"])]
    table = [{"stage": name, "us_per_call": us, "calls_per_step": n, "us_per_step": us * n,
              "us_per_step_in_run": run_us} for name, us, n, run_us in rows]
    stages_in_run = sum(r["us_per_step_in_run"] for r in table
                        if r["us_per_step_in_run"] is not None)
    table.append({"stage": "the step's own lines: residual, constraints, turning r, Newton "
                  "norm, update, predictor, Python", "us_per_call": None, "calls_per_step": 1.0,
                  "us_per_step": None, "us_per_step_in_run": in_run["step"] - stages_in_run})
    table.append({"stage": "recorder (step, one row, flushes)",
                  "us_per_call": best(lambda: recorder.step(next(steps), s, info)),
                  "calls_per_step": 1.0, "us_per_step": None,
                  "us_per_step_in_run": total - in_run["step"]})
    return {"time_per_step_us": total, "stages": table}


def profile_table(profiles: dict) -> str:
    """cProfile summary per case and code."""
    lines = table_head("case", "code", "µs/step", "Newton it.", "NumPy calls/step",
                       "Python calls/step", *STAGES)
    for case, by_code in profiles.items():
        for code, p in by_code.items():
            if "failed" in p:
                lines.append(f"| {case} | {code} | failed: {p['failed'][:60]} |")
                continue
            shares = " | ".join(f"{100 * p['stage_share_of_step'].get(k, 0.0):.0f} %"
                                for k in STAGES)
            lines.append(f"| {case} | {code} | {p['time_per_step_us']:.0f} | "
                         f"{p['newton_iterations_mean']:.3f} | {p['numpy_calls_per_step']:.0f} "
                         f"| {p['python_calls_per_step']:.0f} | {shares} |")
    return "\n".join(lines)


def stage_table(case: str, timing: dict) -> str:
    """Per stage: alone (hot caches) and in the run (timed around each call, ~0.2 µs of
    timer per call included); the recorder in the run is the simulation's µs per step minus
    the bare stepping loop's."""
    lines = [f"{case}: {timing['time_per_step_us']:.0f} µs per step", "",
             *table_head("stage", "µs per call, alone", "calls per step", "µs per step, alone",
                         "µs per step, in the run", "share of the step")]

    for row in timing["stages"]:
        in_run = row["us_per_step_in_run"]
        share = "" if in_run is None else f"{100 * in_run / timing['time_per_step_us']:.0f} %"
        lines.append(f"| {row['stage']} | {fmt(row['us_per_call'], '.1f')} | "
                     f"{row['calls_per_step']:.3f} | {fmt(row['us_per_step'], '.1f')} | "
                     f"{fmt(in_run, '.1f')} | {share} |")
    return "\n".join(lines)


def models(folder: Path) -> dict[str, Path]:
    """The soft pendulum's reduced models for MODE_COUNTS, written to ``folder``."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.files.reduced_model import write_reduced
    from gcms_fenicsx.references import pendulum

    cfg = parse_config(dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)},
                            basis={"attachment": "none"}))
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    paths = {}
    every = pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body)
    for nm in MODE_COUNTS:
        reduction = pipeline.reduction_stage(every.lowest(nm), cfg.selection)
        paths[f"soft, Nm = {nm}"] = folder / f"soft{nm}.h5"
        write_reduced(paths[f"soft, Nm = {nm}"], reduction)
    return paths


def main() -> None:
    options = parser(__doc__, out="docs/integrator_profile")
    options.add_argument("--before", type=Path, default=None,
                         help="a checkout of the code to compare against")
    worker_options(options, "--worker")
    args = options.parse_args()
    if args.worker:
        profile_worker(args.worker)
        return
    checkout(options, args.before)
    codes = {"after": REPO} | ({"before": args.before} if args.before is not None else {})
    with temporary_folder() as tmp:
        paths = models(tmp)
        profiles = {case: {label: run_profile(code, path) for label, code in codes.items()}
                    for case, path in paths.items()}
        timings = {case: stage_timings(path) for case, path in paths.items()}
    write_record(Path(f"{args.out}.json"), {"profiles": profiles, "stages": timings})
    print(profile_table(profiles))
    for case, timing in timings.items():
        print()
        print(stage_table(case, timing))


if __name__ == "__main__":
    main()
