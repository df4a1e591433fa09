"""The rotor basis on the default crankshaft scene at the fewest coordinates that still hold
its response: the static shapes of its twelve load patterns (46 rotor coordinates) and of
the ten left without gravity's two (40), each against the full basis on the same shapes
(120 and 102 coordinates) and against the full basis on all twelve.

Issue 15 asks, with the rotor basis, for at most 40 coordinates, the nose whirl and bearing
forces within 1 % of the full basis on the same fields, and the simulation twice as fast.
Forty rotor coordinates are ten fields (3 × 10 + the 10 rigid columns); of the twelve
patterns, the ten without gravity's two keep the gas forces and the spin's two inertia
fields (leaving the two spin patterns out instead put the nose whirl 70 % off, scratch run).
The rows are ``bench_rotor``'s (the same runs, alternating, best of ``--repeat``, both bases
again at half the step, the floor of each), so the speed and the floor read as there.

    python workflows/rotor_fewest.py [--out docs/rotor_fewest] [--repeat 3]

writes OUT.json and prints the tables recorded in README.md (about 2 minutes). One BLAS
thread.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import json
from dataclasses import replace

from common import log, parser, quiet, table_head, temporary_folder, write_record
from common.crankshaft import BASES, default_study, errors, percents
from common.rotor import case, table

#: The default study's mode count: the static shapes with attachment modes do not depend on
#: it (``dynamics.bases.static_shapes``), only the reduced model they are solved in does.
MODES = 10


def main() -> None:
    args = parser(__doc__, out="docs/rotor_fewest", repeat=3).parse_args()
    quiet()
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.basis import scene_patterns
    from gcms_fenicsx.config.study import parse_config

    raw = default_study(basis={"attachment": "scene"})
    cfg = parse_config(dict(raw, modes={"count": MODES}))
    patterns = scene_patterns(replace(cfg.basis, shapes="static"), cfg.scene)
    variants = {"static, 12 patterns": patterns.loads,
                "static, without gravity": tuple(ld for ld in patterns.loads
                                                 if ld.kind != "gravity")}
    with temporary_folder() as tmp:
        chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, tmp)
        model = pipeline.reduction_stage(
            pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body), cfg.selection)
    rows, runs = [], {}
    for name, loads in variants.items():
        row, runs[name] = case(model, cfg.scene, args.repeat, cfg.plan.body.modes.attachment,
                               replace(patterns, loads=loads))
        rows.append(dict(modes=MODES, attachment="scene", shapes=name,
                         patterns=[f"{ld.kind} {ld.group} {list(ld.direction)}" for ld in loads],
                         **row))
        log(json.dumps({k: rows[-1][k] for k in ("shapes", "coordinates", "speedup")}))
    reference = runs["static, 12 patterns"]["outputs"]["full"]
    for row, name in zip(rows, variants):
        row["against_twelve"] = {b: errors(runs[name]["outputs"][b], reference)
                                 for b in BASES}
    write_record(args.out.with_suffix(".json"), {"rows": rows})
    print(table(rows))
    print("\n" + "\n".join(table_head("shapes", "basis", "coordinates",
                                      "difference from the full basis on 12 patterns")))
    for r in rows:
        for b in BASES:
            print(f"| {r['shapes']} | {b} | {r['coordinates'][b]} | "
                  f"{percents(r['against_twelve'][b], 2)} |")


if __name__ == "__main__":
    main()
