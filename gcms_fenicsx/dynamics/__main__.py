"""``python -m gcms_fenicsx.dynamics REDUCED.h5 STUDY.toml --out DIR``: the [scene] of a study
on an exported reduced model, with NumPy and h5py only (no dolfinx, PETSc, MPI or Gmsh).

Writes DIR/results.h5 and DIR/summary.json; exit status 2 for bad input, 1 when the
simulation stops early (its results up to there are kept, marked incomplete).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gcms_fenicsx.config import load_config
from gcms_fenicsx.dynamics.scene import SceneError
from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.files import SIMULATION_FILES
from gcms_fenicsx.interrupts import Interrupted, interruptible
from gcms_fenicsx.outputs import staged_output
from gcms_fenicsx.progress import progress_printer
from gcms_fenicsx.reduced_model import ReducedModelError, read_reduced
from gcms_fenicsx.simulation import run_scene, simulation_summary
from gcms_fenicsx.validation import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcms_fenicsx.dynamics",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("reduced", type=Path, help="reduced model (reduced.h5)")
    parser.add_argument("config", type=Path, help="study file with a [scene] table (TOML)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    args = parser.parse_args(argv)
    try:
        with interruptible():
            return _run(args)
    except Interrupted as exc:
        print(f"interrupted ({exc}); {args.out} is as it was", file=sys.stderr)
        return exc.exit_status


def _run(args: argparse.Namespace) -> int:
    try:
        cfg = load_config(args.config)
        if cfg.scene is None:
            raise ConfigError.missing("[scene]", f"required in {args.config}")
        model = read_reduced(args.reduced)
        if not model.checksummed:
            print(f"note: {args.reduced} was written before content checksums (schema "
                  f"{model.schema_version}); its contents cannot be verified", file=sys.stderr)
        with staged_output(args.out, owns=SIMULATION_FILES) as folder:
            summary = run_scene(cfg, model, folder, progress_printer(), plots=False)
    except (ConfigError, SceneError, ReducedModelError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ComputationFailed as exc:
        print(f"failed: {exc}", file=sys.stderr)
        return 1
    print(f"{simulation_summary(summary)}\nresults in {args.out}/")
    return 0 if summary["complete"] else 1


if __name__ == "__main__":
    sys.exit(main())
