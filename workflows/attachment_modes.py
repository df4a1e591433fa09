"""Attachment modes on the flexible pendulum: the tip's error against the full-order model (a)
for Nm eigenmodes with and without the scene's attachment modes.

The case of docs/flexible_pendulum.md (the soft 1 m beam pinned at end_x0 by a revolute
joint, released horizontally, undamped), one mesh and one solve of the largest Nm with the
attachment modes of ``[basis] attachment = "scene"``: unit forces along x, y, z and unit
moments about the two axes the joint holds, at end_x0 (docs/design.md §3.7). For each Nm,
the reduced body of the lowest Nm eigenmodes alone and with the attachment modes runs the
scene; the error is reference (a)'s: max_t |d − d_a| / max_t |d_a| over the first half
period (d the tip's deviation from the rigid pendulum), as the flexible-pendulum study
measures it.

    python workflows/attachment_modes.py [--out docs/attachment_modes]

writes OUT.json and prints the table recorded in README.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: timings of one core

import time
from dataclasses import replace
from pathlib import Path

from common import parser, quiet, table_head, temporary_folder, write_record

MODE_COUNTS = (5, 10, 15, 20)


def main() -> None:
    args = parser(__doc__, out="docs/attachment_modes").parse_args()
    quiet()
    import numpy as np

    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references import pendulum
    from gcms_fenicsx.references.full_order import full_order_body, sparse_factorization

    cfg = parse_config(dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)},
                            basis={"attachment": "scene"}), "flexible pendulum")
    with temporary_folder() as tmp:
        chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, tmp)
    model, body = chain.assembly.model, chain.body
    full = full_order_body(model, group_weights(body, model.Vs))
    rigid = pendulum.rigid_pendulum(full, np.array(cfg.scene.gravity), cfg.scene.end_time_s)

    def deviation(b, **kwargs):
        t0 = time.perf_counter()
        traj, summary = simulate_body(b, cfg.scene, **kwargs)
        assert summary["complete"], summary["message"]
        return (traj.time, pendulum.tip_deviation(rigid, traj.time,
                                                  traj.groups["end_xL"]["position"]),
                time.perf_counter() - t0)

    t_ref, d_ref, ref_s = deviation(full, factorize=sparse_factorization)
    with_attachment = pipeline.basis_stage(model, chain.modes, body)
    plain = pipeline.basis_stage(model, pipeline.modes_stage(
        model, replace(cfg.plan.body.modes, attachment=None)), body)
    rows = []
    for nm in MODE_COUNTS:
        for label, basis in (("none", plain), ("scene", with_attachment)):
            reduced = pipeline.reduction_stage(basis.lowest(nm), cfg.selection)
            t, d, wall = deviation(body_from_reduced(reduced))
            rows.append({"modes": nm, "attachment": label, "coordinates": reduced.dofs,
                         "error_vs_a": pendulum.deviation_error(t, d, d_ref, rigid.half_period_s),
                         "online_s": wall})
    document = {"attachment_modes": list(chain.modes.attachment_labels),
                "reference_a_s": ref_s, "rows": rows}
    write_record(Path(f"{args.out}.json"), document)
    print(f"attachment modes: {', '.join(chain.modes.attachment_labels)}; reference (a) "
          f"{ref_s:.1f} s")
    print("\n" + "\n".join(table_head("Nm", "attachment", "coordinates", "error vs (a)",
                                      "simulation s")))
    for r in rows:
        print(f"| {r['modes']} | {r['attachment']} | {r['coordinates']} | "
              f"{100 * r['error_vs_a']:.3f} % | {r['online_s']:.2f} |")


if __name__ == "__main__":
    main()
