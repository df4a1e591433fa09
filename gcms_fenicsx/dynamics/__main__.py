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
from gcms_fenicsx.dynamics.results import write_results
from gcms_fenicsx.dynamics.scene import SceneError
from gcms_fenicsx.dynamics.simulate import simulate
from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.outputs import staged_output, write_json
from gcms_fenicsx.progress import progress_printer
from gcms_fenicsx.reduced_model import ReducedModelError, read_reduced
from gcms_fenicsx.validation import ConfigError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcms_fenicsx.dynamics",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("reduced", type=Path, help="reduced model (reduced.h5)")
    parser.add_argument("config", type=Path, help="study file with a [scene] table (TOML)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    args = parser.parse_args(argv)
    try:
        scene = load_config(args.config).scene
        if scene is None:
            raise ConfigError.missing("[scene]", f"required in {args.config}")
        model = read_reduced(args.reduced)
        with staged_output(args.out) as folder:
            traj, summary = simulate(model, scene, progress_printer())
            write_results(folder / "results.h5", traj)
            write_json(folder / "summary.json", summary)
    except (ConfigError, SceneError, ReducedModelError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ComputationFailed as exc:
        print(f"failed: {exc}", file=sys.stderr)
        return 1
    state = "complete" if summary["complete"] else f"INCOMPLETE: {summary['message']}"
    print(f"{summary['steps']} steps to t = {summary['time_reached_s']:.6g} s, {state}; "
          f"results in {args.out}/")
    return 0 if summary["complete"] else 1


if __name__ == "__main__":
    sys.exit(main())
