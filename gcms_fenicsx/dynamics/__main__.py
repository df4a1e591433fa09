"""``python -m gcms_fenicsx.dynamics REDUCED.h5 STUDY.toml --out DIR``: the [scene] of a study
on an exported reduced model, with NumPy and h5py only (no dolfinx, PETSc, MPI or Gmsh).

A scene asking for stresses reads the stress modes from the stress_modes.h5 beside REDUCED.h5
(``gcms reduce`` of the same study writes it). Writes DIR/results.h5 and DIR/summary.json (``dynamics.run.study_run.simulate_model``); exit status 2 for
bad input, 1 when the simulation stops early (its results up to there are kept, marked
incomplete), 130/143 when interrupted (DIR as it was).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gcms_fenicsx.dynamics.run.study_run import SimulationIncomplete, simulate_model
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.config.scene import SceneError
from gcms_fenicsx.files.reduced_model import ReducedModelError
from gcms_fenicsx.files.stress_nodes import StressNodesError
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.interrupts import Interrupted, interruptible
from gcms_fenicsx.runtime.progress import progress_printer


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcms_fenicsx.dynamics",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("reduced", type=Path, help="reduced model (reduced.h5)")
    parser.add_argument("config", type=Path, help="study file with a [scene] table (TOML)")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    args = parser.parse_args(argv)
    try:
        with interruptible():
            text = simulate_model(args.reduced, args.config, args.out, progress_printer())
    except Interrupted as exc:
        print(f"interrupted ({exc}); {args.out} is as it was", file=sys.stderr)
        return exc.exit_status
    except (ConfigError, SceneError, ReducedModelError, StressNodesError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except SimulationIncomplete as exc:
        print(f"{exc}\nresults in {args.out}/ (incomplete)", file=sys.stderr)
        return 1
    except ComputationFailed as exc:
        print(f"failed: {exc}", file=sys.stderr)
        return 1
    print(f"{text}\nresults in {args.out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
