"""Numerical-stability stress suite: the ``gcms`` command on perturbed, rescaled, slender, large,
long, extreme and parallel studies.

It drives the tool as a user does: every probe writes a study TOML file into a temporary
folder, runs ``python -m gcms_fenicsx.cli`` (under ``mpirun -n 2`` for the parallel class)
and reads the files the command wrote (``modes.json``, ``selection.json``, ``summary.json``,
``results.h5`` through ``gcms_fenicsx.dynamics.read_results``, ``reduced.h5`` through
``gcms_fenicsx.dynamics.read_reduced``), so it keeps working while the package inside is
reorganised. The probe classes (``--only``):

  symmetry     a square steel beam widened by ε = 0 … 0.1: fields kept, smallest singular
               values, cond(Mr), pruning error, pendulum tip trajectory against ε = 0
  units        SI against mm-t-s, and the body scaled by 1e-3 and 1e3
  slenderness  10 mm square steel beams of L/h = 10 … 1000: verification margins, first
               bending frequency against Euler–Bernoulli and Timoshenko, solve time
  modes        Nm = 10 … 100 on a beam and the default crankshaft: selection, conditioning,
               cost, Newton iterations and steps/s of a short scene
  long         2e4 steps of the flexible pendulum; the default crankshaft scene with its
               drive ×1, ×3, ×10: energy balance over time (fitted growth), Newton iterations
  material     ν up to 0.499 (locking), E over ten decades (frequencies ∝ √E, same selection)
  mpi          ``gcms reduce`` on 1 and 2 ranks: frequencies, fields, Mr and Kr entries
  assembly     the crank train (coarse meshes) as written, undamped, damped ×5, at 2700 and
               3600 rpm, at half and double the step, in the rotor basis, for four cycles,
               and with a user's mistakes: energy balance, drive torque, step convergence

Every command's row records its exit status, its last stderr line and its wall time, and the
suite checks the command's contract (README, "Using it"): it ends in a result (exit status 0,
its files written, strict JSON) or in one line with exit status 1 or 2 and ``--out`` exactly
as it was (a snapshot of the folder before and after) and no staging folder left behind. The
one documented exception, a simulation that stops early, keeps ``results.h5`` marked
incomplete (exit status 1; it prints the run's summary, its last line says so). Anything
else (a traceback, another exit status, more lines, a changed ``--out``, a time-out, a file
that is not strict JSON) is reported as BROKEN with the study to reproduce it, and the script
then exits with status 1.

    python workflows/stability.py [--quick] [--only CLASS ...] [--out docs/stability]
                                  [--keep DIR] [--redraw]

``--quick`` runs the smallest members of each class (about 2 minutes); the full run took 6
minutes on the 2-core development machine (allow up to half an hour on a busy one). Writes
OUT.json (every row; with ``--only`` the other classes' rows of an existing OUT.json are
kept, each class with its date and mode), OUT.png and OUT.md (the tables and a paragraph per
class for the README's "Numerical stability", numbers taken from the rows), and prints a
table per class; ``--redraw`` rewrites OUT.md and OUT.png from OUT.json alone. Child
processes run with one BLAS thread.

This file parses the options and runs the classes; the suite itself is the package
``workflows/stress`` (studies, runner, readers, measures, suite, probes, tables,
paragraphs, report, figure, document).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the package ``stress`` beside this

from common import parser, temporary_folder
from stress import CLASSES, REPO, log
from stress.document import merged, redraw, write
from stress.probes_assembly import assembly
from stress.probes_runs import long_runs, mpi
from stress.probes_solver import many_modes, material, slenderness
from stress.probes_symmetry import symmetry, units
from stress.suite import Probe, run_class
from stress.tables import broken, table

PROBES: dict[str, Probe] = {
    "symmetry": symmetry, "units": units, "slenderness": slenderness, "modes": many_modes,
    "long": long_runs, "material": material, "mpi": mpi, "assembly": assembly}


def options(argv: list[str] | None) -> argparse.Namespace:
    """The command line: --quick, --only, --out, --keep, --redraw."""
    options = parser(__doc__, quick="the smallest members of each class (a few minutes)",
                     out=REPO / "docs" / "stability",
                     out_help="OUT.json, OUT.png and OUT.md (default docs/stability)")
    options.add_argument("--only", action="append", choices=CLASSES, metavar="CLASS",
                         help=f"run only this class (repeatable): {', '.join(CLASSES)}")
    options.add_argument("--keep", type=Path, default=None,
                         help="work in this folder and keep every study and --out there")
    options.add_argument("--redraw", action="store_true",
                         help="run nothing: rewrite OUT.md and OUT.png from OUT.json")
    return options.parse_args(argv)


def run_classes(chosen: list[str], quick: bool, keep: Path | None) -> dict[str, dict]:
    """Run each chosen class in a temporary folder (``keep`` instead, kept), printing its
    table: each class's record by name."""
    runs: dict[str, dict] = {}
    with temporary_folder(prefix="gcms-stability-") as tmp:
        folder = tmp if keep is None else keep.resolve()
        folder.mkdir(parents=True, exist_ok=True)
        for cls in chosen:
            runs[cls] = run_class(cls, PROBES[cls], quick, folder)
            print(f"\n{cls} ({runs[cls]['mode']}, {runs[cls]['wall_s']:.0f} s)\n")
            print(table(cls, runs[cls]["rows"]), flush=True)
    return runs


def tell_problems(runs: dict[str, dict], out: Path) -> int:
    """Print every BROKEN row with the study to reproduce it and every row not read: the
    number of BROKEN rows."""
    rows = [r for c in runs.values() for r in c["rows"]]
    bad = broken(rows)
    unread = [r for r in rows if "read_error" in r]
    for r in bad:
        print(f"\nBROKEN: {r['class']}, {r['case']}: {r['problem']}\n  {r['command']}\n"
              f"  last stderr line: {r['last_stderr']}\n  study:\n{r['study']}")
    for r in unread:
        print(f"\nnot read: {r['class']}, {r['case']}: {r['read_error']}")
    log(f"wrote {out}.json, .md, .png; {len(bad)} broken, {len(unread)} unread")
    return len(bad)


def main(argv: list[str] | None = None) -> int:
    """Run the chosen classes and write OUT.json, OUT.md, OUT.png (or only redraw the last
    two): exit status 1 when a command broke its contract."""
    args = options(argv)
    if args.redraw:
        redraw(json.loads(Path(f"{args.out}.json").read_text()), args.out)
        return 0
    chosen = [c for c in CLASSES if c in (args.only or CLASSES)]
    runs = run_classes(chosen, args.quick, args.keep)
    write(merged(Path(f"{args.out}.json"), runs), args.out)
    return 1 if tell_problems(runs, args.out) else 0


if __name__ == "__main__":
    sys.exit(main())
