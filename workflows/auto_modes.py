"""How many modes the default crankshaft scene needs: its outputs against Nm, and what
``[modes] count = "auto"`` chooses.

One mesh and one solve of 20 elastic modes; for Nm = 1 … 20 the reduced model of the lowest
Nm (a leading block of the same solve, the default selection) runs the built-in scene. Each
output is compared with the Nm = 20 run as the flexible pendulum compares its tip: the
largest difference over time divided by the reference's largest value, for the nose's
whirl (``end_x0`` position across the shaft, y and z), the bearing forces (both bearings,
three components each) and the drive torque. Then ``count = "auto"`` on the same study:
its band (``config.scene_band``), the modes it takes, and the same errors. Last, whether the
reference is converged in the time step: Nm = 10 and 20 again with h/2, compared with h at
the recorded times of the h run.

    python workflows/auto_modes.py [--out docs/auto_modes]

writes OUT.json and prints the table recorded in README.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

from dataclasses import replace
from pathlib import Path

from common import parser, quiet, table_head, temporary_folder, write_record
from common.crankshaft import OUTPUTS, default_study, errors, outputs

REFERENCE_MODES = 20


def main() -> None:
    args = parser(__doc__, out="docs/auto_modes").parse_args()
    quiet()
    import numpy as np

    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.run.simulate import simulate_to_file

    raw = default_study(basis={"attachment": "none"})
    cfg = parse_config(raw)
    auto = parse_config(dict(raw, modes={"count": "auto"}))
    band = auto.plan.body.modes.band
    with temporary_folder() as tmp:
        chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material,
                                   replace(cfg.plan.body.modes, count=REFERENCE_MODES), tmp)
        every = pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body)
        hz = every.elastic_frequencies_hz
        chosen = max(1, int(np.count_nonzero(hz < band.max_frequency_hz)))
        runs = {}
        for nm in range(1, REFERENCE_MODES + 1):
            model = pipeline.reduction_stage(every.lowest(nm), cfg.selection)
            summary = simulate_to_file(model, cfg.scene, tmp / f"r{nm}.h5")
            runs[nm] = (outputs(tmp / f"r{nm}.h5"), summary, model.dofs)
        half = replace(cfg.scene, time_step_s=cfg.scene.time_step_s / 2)
        step_check = {}
        for nm in (10, REFERENCE_MODES):
            model = pipeline.reduction_stage(every.lowest(nm), cfg.selection)
            simulate_to_file(model, half, tmp / f"h{nm}.h5")
            finer = {k: v[::2] for k, v in outputs(tmp / f"h{nm}.h5").items()}  # h's times
            step_check[nm] = errors(runs[nm][0], finer)
    reference = runs[REFERENCE_MODES][0]
    rows = [{"modes": nm, "coordinates": dofs, "highest_frequency_hz": float(hz[nm - 1]),
             "online_s": summary["wall_time_s"], **errors(out, reference)}
            for nm, (out, summary, dofs) in runs.items()]
    document = {"band": band.to_json(), "auto_modes": chosen,
                "auto_errors": next(r for r in rows if r["modes"] == chosen),
                "frequencies_hz": hz.tolist(), "rows": rows,
                "h_against_half_h": {str(nm): e for nm, e in step_check.items()}}
    write_record(Path(f"{args.out}.json"), document)
    print(f"band: {band.max_frequency_hz:.1f} Hz, set by {band.set_by} "
          f"(excitation {band.excitation_hz:.1f} Hz × {band.factor:g}, the time step resolves "
          f"{band.resolved_hz:.0f} Hz): {chosen} modes")
    print("\n" + "\n".join(table_head("Nm", "coordinates", "f_Nm Hz", *OUTPUTS)))
    for r in rows:
        mark = " (auto)" if r["modes"] == chosen else ""
        print(f"| {r['modes']}{mark} | {r['coordinates']} | {r['highest_frequency_hz']:.0f} | "
              f"{r['nose whirl']:.2e} | {r['bearing forces']:.2e} | {r['drive torque']:.2e} |")
    for nm, e in step_check.items():
        print(f"Nm = {nm}, h against h/2: " + ", ".join(f"{k} {e[k]:.2e}" for k in OUTPUTS))


if __name__ == "__main__":
    main()
