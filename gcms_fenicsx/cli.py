"""The ``gcms`` command: ``gcms SUBCOMMAND [CONFIG.toml] --out DIR``.

Each subcommand runs the stages it needs and writes its files into DIR only when all
of them succeeded; a stage whose product in DIR was made from the same inputs is reused
(``--fresh``: none is). Errors in the input end the command with one line naming the key,
the value and what is allowed (exit status 2); a failed computation ends it with the
numbers that failed (exit status 1). A simulation that stops early is the exception to
"nothing written": its results up to there are kept, marked incomplete (exit status 1).
"""
from __future__ import annotations

import argparse
import logging
import signal
import sys
import time
from pathlib import Path

from gcms_fenicsx.config.table import ConfigError


def _common(parser: argparse.ArgumentParser, config_required: bool = True) -> None:
    if config_required:
        parser.add_argument("config", type=Path, help="study file (TOML)")
    else:
        parser.add_argument("config", type=Path, nargs="?", default=None,
                            help="study file (TOML); without one, the built-in default: the "
                            "inline-4 crank train")
    parser.add_argument("--out", type=Path, required=True, help="output folder (it also "
                        "keeps each stage's product for the next command to reuse)")
    parser.add_argument("--fresh", action="store_true",
                        help="compute every stage: reuse nothing in the output folder")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gcms", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="SUBCOMMAND")
    _common(sub.add_parser("mesh", help="build and mesh the geometry: mesh.msh, mesh.json"))
    _common(sub.add_parser("modes", help="free-free modes: modes.h5, modes.json (and "
                           "mode_shapes/ when [outputs] mode_shapes = true)"))
    _common(sub.add_parser("reduce", help="GCMS selection and reduced model: reduced.h5, "
                           "selection.json"))
    _common(sub.add_parser("simulate", help="the [scene] on the reduced model: results.h5, "
                           "summary.json, plots"))
    _common(sub.add_parser("run", help="every stage, on CONFIG or the built-in default (the "
                           "inline-4 crank train)"),
            config_required=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.disable(logging.INFO)  # the JIT's C build logs every compiler call at INFO
    try:
        return _run(args)
    except KeyboardInterrupt:  # before the command's own handlers: nothing written yet
        print(f"gcms {args.command}: interrupted (SIGINT) while starting; {args.out} is as it "
              "was", file=sys.stderr)
        return 128 + signal.SIGINT


def _run(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from gcms_fenicsx.app import commands  # light: the FE verbs import dolfinx when they run
    from gcms_fenicsx.app.commands import PicturesInterrupted
    from gcms_fenicsx.dynamics.run.study_run import SimulationIncomplete
    from gcms_fenicsx.config.scene import SceneError
    from gcms_fenicsx.files.reduced_model import ReducedModelError
    from gcms_fenicsx.runtime.errors import ComputationFailed
    from gcms_fenicsx.runtime.interrupts import Interrupted, interruptible

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    try:
        with interruptible():
            summary = getattr(commands, args.command)(args.config, args.out, args.fresh)
    except PicturesInterrupted as exc:
        if comm.rank == 0:
            print(f"gcms {args.command}: interrupted ({signal.Signals(exc.signum).name}) while "
                  f"drawing the pictures; the results are in {args.out}/ ({exc.files}), a "
                  "picture not finished is not", file=sys.stderr)
        return exc.exit_status
    except (Interrupted, KeyboardInterrupt) as exc:
        signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
        if comm.rank == 0:
            print(f"gcms {args.command}: interrupted ({signal.Signals(signum).name}); "
                  f"{args.out} is as it was", file=sys.stderr)
        return 128 + signum
    except (ConfigError, SceneError, ReducedModelError) as exc:
        if comm.rank == 0:
            print(f"gcms {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except SimulationIncomplete as exc:
        if comm.rank == 0:
            print(f"{exc}\ngcms {args.command}: failed: the simulation stopped early; its "
                  f"results up to there are in {args.out}/ (marked incomplete)", file=sys.stderr)
        return 1
    except ComputationFailed as exc:
        if comm.rank == 0:
            print(f"gcms {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    if comm.rank == 0:
        print(summary)
        print(f"gcms {args.command}: done in {time.perf_counter() - t0:.1f} s; "
              f"results in {args.out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
