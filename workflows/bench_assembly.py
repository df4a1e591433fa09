"""What an assembly's step costs: identical members against one, and the crank train.

The crank train's reduced models (workflows/crank_train.toml: the crankshaft, 507
coordinates; the conrod, 138) are built once; then, one process, one BLAS thread, the best
of ``--repeat`` runs of 200 steps of 50 µs each:

- N = 1, 2, 4, 8 conrods, each hinged at its big end to the ground (a revolute joint about its
  bore's axis) and swinging under gravity: µs per step and its ratio to one conrod — what N
  identical members cost (issue 31 asks four at most twice one: they are stepped as one
  batch, ``dynamics.system.blocks``);
- the crank train as written (1,071 coordinates) and its rigid twin (72), from rest.

    python workflows/bench_assembly.py [--out docs] [--repeat 3]

Writes OUT/bench_assembly.json and OUT/bench_assembly.md (the table, with the record's
provenance).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import time
from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, quiet, run_interruptibly, table_head, table_row
from common import temporary_folder, write_markdown, write_record

HERE = Path(__file__).resolve().parent
STEP_S, STEPS = 5e-5, 200
COUNTS = (1, 2, 4, 8)


def arguments() -> Any:
    return parser(__doc__, out="docs", out_help="folder of bench_assembly.json and .md",
                  repeat=3).parse_args()


def best_us_per_step(stepper: Any, start: Any, repeat: int) -> tuple[float, float]:
    """(the best µs per step over ``repeat`` marches of STEPS steps, Newton iterations a
    step)."""
    from gcms_fenicsx.dynamics.system.march import march

    best, iterations = np.inf, 0.0
    for _ in range(repeat):
        begun = time.perf_counter()
        run = march(stepper, start, STEPS * STEP_S, every=STEPS)
        best = min(best, (time.perf_counter() - begun) / run.steps)
        iterations = run.newton_iterations / run.steps
    return best * 1e6, iterations


def pendulums(model: Any, count: int) -> tuple[Any, Any]:
    """``count`` conrods hinged at their big ends to the ground, 0.2 m apart, under gravity:
    (the stepper, its initial state)."""
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.system import joint_types
    from gcms_fenicsx.dynamics.system.assembly import assemble
    from gcms_fenicsx.dynamics.system.members import Flexible, placed_coordinates
    from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state

    body = body_from_reduced(model)
    rods = tuple(Flexible(f"conrod{k}", body, placed_coordinates(body, position=[0, 0.2 * k, 0]))
                 for k in range(count))
    rows = tuple(r for rod in rods for r in joint_types.to_ground(
        f"pin{rod.name}", "revolute", rod, "big_end", np.array([0.0, 0.0, 1.0])))
    stepper = AssemblyStepper(assemble(rods, rows, np.array([0.0, -9.81, 0.0])),
                              StepSettings(STEP_S))
    return stepper, initial_state(stepper)


def train(cfg: Any, models: dict) -> tuple[Any, Any]:
    from gcms_fenicsx.app.system_run import build_system, start_velocity
    from gcms_fenicsx.dynamics.system.stepper import initial_state

    made, _, stepper = build_system(cfg, models)
    return stepper, initial_state(stepper, start_velocity(cfg, made))


def main() -> None:
    args = arguments()
    quiet()
    from mpi4py import MPI

    from gcms_fenicsx.app.commands import system_models
    from gcms_fenicsx.app.system_run import load_system, rigid_twin_study, system_file

    study = HERE / "crank_train.toml"
    cfg = load_system(study, system_file(study))
    with temporary_folder("bench_assembly_") as work, \
            system_models(cfg, work, False, MPI.COMM_WORLD, log) as built:
        models = built[0]
    rows = []
    for count in COUNTS:
        stepper, start = pendulums(models["conrod1"], count)
        us, newton = best_us_per_step(stepper, start, args.repeat)
        rows.append({"case": f"{count} conrod{'s' if count > 1 else ''}, hinged",
                     "members": count, "coordinates": stepper.assembly.dofs,
                     "us_per_step": us, "newton_per_step": newton})
        log(f"{rows[-1]['case']}: {us:.0f} µs a step")
    for label, study_cfg in (("crank train", cfg),
                             ("crank train, rigid twin", rigid_twin_study(cfg))):
        stepper, start = train(study_cfg, models)
        us, newton = best_us_per_step(stepper, start, args.repeat)
        rows.append({"case": label, "members": len(stepper.assembly.members),
                     "coordinates": stepper.assembly.dofs, "us_per_step": us,
                     "newton_per_step": newton})
        log(f"{label}: {us:.0f} µs a step")
    one = rows[0]["us_per_step"]
    for row in rows[:len(COUNTS)]:
        row["ratio_to_one"] = row["us_per_step"] / one
    write(rows, args)


def write(rows: list[dict], args: Any) -> None:
    out = Path(args.out)
    record = write_record(out / "bench_assembly.json",
                          {"step_s": STEP_S, "steps": STEPS, "repeat": args.repeat,
                           "rows": rows})["record"]
    lines = table_head("case", "members", "coordinates", "µs a step", "× one conrod",
                       "steps/s", "Newton/step")
    for r in rows:
        lines.append(table_row(r["case"], r["members"], r["coordinates"],
                               f"{r['us_per_step']:,.0f}",
                               f"{r['ratio_to_one']:.2f}" if "ratio_to_one" in r else "",
                               f"{1e6 / r['us_per_step']:,.0f}", f"{r['newton_per_step']:.2f}"))
    four = next(r for r in rows if r["members"] == 4 and "ratio_to_one" in r)
    verdict = "within" if four["ratio_to_one"] <= 2.0 else "NOT within"
    text = ("# What an assembly's step costs\n\n" + "\n".join(lines) + "\n\n"
            f"Four identical conrods cost {four['ratio_to_one']:.2f}× one: {verdict} the bound "
            "of 2× (issue 31). Members of one reduced model are stepped as one batch "
            "(`dynamics.system.blocks`): their co-rotated states, mass products, Newton solves "
            "and rows are one NumPy call each for all of them, so another member adds its "
            "arithmetic, not its calls; the crank train's crankshaft, pistons and joints are "
            "still a block each ([assemblies.md](assemblies.md)).\n")
    write_markdown(out / "bench_assembly.md", text, record)
    print(text)


if __name__ == "__main__":
    run_interruptibly(main, "--out")
