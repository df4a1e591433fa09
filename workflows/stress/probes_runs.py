"""Probe classes 5 and 7: long runs (2e4 steps of the flexible pendulum, with the co-rotated
and with the Saint Venant–Kirchhoff law; the default
crankshaft scene with its drive ×1, ×3, ×10 on one reduced model, and the fastest with a
quarter of the step) and one against two MPI ranks (`gcms reduce`: frequencies, fields, Mr
and Kr entries)."""
from __future__ import annotations

import shutil
from pathlib import Path

from stress.measures import compare_to, downsample, growth_fit
from stress.readers import (balance_history, both, read_modes, read_selection, read_summary,
                            read_trajectory, reduced_difference)
from stress.runner import Run, gcms
from stress.studies import (DRIVE_FACTORS, LONG_STEPS, STEEL, default_study, driven_crankshaft,
                            flexible_pendulum, material_beam, rotation_per_step)
from stress.suite import Suite


def read_long(out: Path) -> dict:
    """The summary of a long run and its energy balance error over time: fitted growth and a
    downsampled curve."""
    row = read_summary(out)
    t, e = balance_history(read_trajectory(out))
    row.update(growth_fit(t, e), balance=downsample(t, e), end_time_s=float(t[-1]))
    return row


def simulate_on(suite: Suite, reduced: Run, study: dict, name: str, case: str,
                **extra) -> None:
    """`gcms simulate` of the crankshaft ``study`` on a copy of the reduced model of
    ``reduced``: a row marked with whether the model was reused (not rebuilt)."""
    out = suite.path(name)
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(reduced.out, out)
    run = gcms("simulate", study, out)
    row = suite.probe("long", case, run, read_long, body="crankshaft", **extra,
                      rotation_per_step_rad=rotation_per_step(study))
    row["reused_reduced_model"] = "rebuilding" not in run.stderr


def long_runs(suite: Suite) -> None:
    """Class 5: the flexible pendulum for LONG_STEPS steps (co-rotated, SVK, in the rotor
    basis and on its static shapes); the crankshaft reduced once, then simulated at each drive
    speed in both bases and on its static shapes in the rotor basis (and, in a full run, the
    fastest with a quarter of the step: does its error converge as a second-order method's,
    1/16, or not)."""
    run = gcms("run", flexible_pendulum(LONG_STEPS), suite.path("long_pendulum"))
    suite.probe("long", f"flexible pendulum, {LONG_STEPS} steps", run, read_long,
                body="pendulum", drive_factor=None)
    exact = flexible_pendulum(LONG_STEPS)
    exact["scene"]["elasticity"] = "svk"
    run = gcms("run", exact, suite.path("long_pendulum_svk"))
    suite.probe("long", f"flexible pendulum, elasticity svk, {LONG_STEPS} steps", run,
                read_long, body="pendulum", drive_factor=None)
    rotor = dict(flexible_pendulum(LONG_STEPS), basis={"kind": "rotor"})
    run = gcms("run", rotor, suite.path("long_pendulum_rotor"))
    suite.probe("long", f"flexible pendulum, rotor basis, {LONG_STEPS} steps", run, read_long,
                body="pendulum", drive_factor=None)
    static = dict(flexible_pendulum(LONG_STEPS), basis={"kind": "rotor", "shapes": "static"})
    run = gcms("run", static, suite.path("long_pendulum_static"))
    suite.probe("long", f"flexible pendulum, static shapes, rotor basis, {LONG_STEPS} steps",
                run, read_long, body="pendulum", drive_factor=None)
    # with its scene: the attachment modes the runs' studies ask for, so that they reuse it
    reduced = gcms("reduce", default_study(), suite.path("long_crank_reduced"))
    suite.probe("long", "crankshaft, reduce", reduced, read_selection, body="crankshaft",
                drive_factor=None)
    if not reduced.ok:
        return
    steps = None if suite.quick else LONG_STEPS
    for factor in ((1,) if suite.quick else DRIVE_FACTORS):
        simulate_on(suite, reduced, driven_crankshaft(factor, steps), f"long_crank_x{factor}",
                    f"crankshaft, drive ×{factor}", drive_factor=factor)
        simulate_on(suite, reduced, dict(driven_crankshaft(factor, steps),
                                         basis={"kind": "rotor"}),
                    f"long_crank_rotor_x{factor}", f"crankshaft, drive ×{factor}, rotor basis",
                    drive_factor=factor)
        simulate_on(suite, reduced, dict(driven_crankshaft(factor, steps),
                                         basis={"kind": "rotor", "shapes": "static"}),
                    f"long_crank_static_x{factor}",
                    f"crankshaft, drive ×{factor}, static shapes, rotor basis",
                    drive_factor=factor)
    if not suite.quick:
        fastest = DRIVE_FACTORS[-1]
        simulate_on(suite, reduced, driven_crankshaft(fastest, steps, step_factor=0.25),
                    "long_crank_fine", f"crankshaft, drive ×{fastest}, step / 4",
                    drive_factor=fastest, step_factor=0.25)


def mpi(suite: Suite) -> None:
    """Class 7: `gcms reduce` of the material beam with eight modes on 1 and 2 ranks."""
    size = 0.012 if suite.quick else 0.008
    study = material_beam(STEEL, size)
    study["modes"] = {"count": 8}
    reader = both(read_modes, read_selection)
    one = gcms("reduce", study, suite.path("mpi_1"))
    ref = suite.probe("mpi", "1 rank", one, reader, ranks=1)
    two = gcms("reduce", study, suite.path("mpi_2"), ranks=2)
    row = suite.probe("mpi", "2 ranks", two, reader, ranks=2)
    if not (one.ok and two.ok) or "read_error" in ref or "read_error" in row:
        return
    compare_to(row, ref)
    try:
        row.update(reduced_difference(one.out / "reduced.h5", two.out / "reduced.h5"))
    except Exception as exc:  # noqa: BLE001
        row["read_error"] = f"reduced.h5: {type(exc).__name__}: {exc}"
