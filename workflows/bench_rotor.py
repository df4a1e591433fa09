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
(``common.crankshaft.outputs``), compared as the flexible pendulum compares its tip:
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

import json
from dataclasses import replace

from common import log, parser, quiet, temporary_folder, write_record
from common.crankshaft import BASES, default_study, errors
from common.rotor import case, table

MODE_COUNTS = (5, 10, 20, 40)
ATTACHMENT = ("none", "scene")


def against_modes(static: dict, modes: dict) -> dict:
    """How the runs on the static shapes compare with the full basis on the model's modes
    (the same model, the same scene): its steps/s over theirs, the differences."""
    reference = modes["summaries"]["full"]["steps_per_second"]
    return {b: {"speedup": static["summaries"][b]["steps_per_second"] / reference,
                "difference": errors(static["outputs"][b], modes["outputs"]["full"])}
            for b in BASES}


def main() -> None:
    options = parser(__doc__, out="docs/bench_rotor", repeat=3)
    options.add_argument("--modes", type=int, nargs="+", default=list(MODE_COUNTS))
    args = options.parse_args()
    quiet()
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.basis import scene_patterns
    from gcms_fenicsx.config.study import parse_config

    raw = default_study(basis={"attachment": "scene"})
    rows = []
    with temporary_folder() as tmp:
        for nm in args.modes:
            cfg = parse_config(dict(raw, modes={"count": nm}))
            static = scene_patterns(replace(cfg.basis, shapes="static"), cfg.scene)
            chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes,
                                       tmp)
            for attachment in ATTACHMENT:
                loads = cfg.plan.body.modes.attachment if attachment == "scene" else ()
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
    write_record(args.out.with_suffix(".json"), {"rows": rows})
    print(table(rows))


if __name__ == "__main__":
    main()
