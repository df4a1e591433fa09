"""Flexible pendulum: the GCMS integrator against two full-order references on the same mesh.

The case (``gcms_fenicsx.pendulum``): a soft 1 m beam, pinned at one end face by a revolute
joint, released horizontally under gravity; compared is the tip's deviation from the rigid
pendulum over the first half period of the swing. References, on every FE node:

(a) the same co-rotated linear-elastic model on all 3N DOFs (SciPy sparse, same integrator);
(b) geometrically nonlinear Saint Venant–Kirchhoff, internal forces assembled by dolfinx.

GCMS runs for Nm = 5 … 30 elastic modes and several selection tolerances, with the
co-rotated linear elastic law and (undamped) the geometrically exact Saint Venant–Kirchhoff
law of ``[scene] elasticity = "svk"`` (docs/design.md §7.2), each without and with the
attachment modes at the pin (``[basis] attachment = "scene"``); the error is
max_t |d − d_ref| / max_t |d_ref|. Every row carries ``elasticity``, ``modes``,
``attachment``, ``error_vs_a``, ``error_vs_b`` and ``steps_per_second``; an SVK row also the
time and memory of its coefficients. The same study is repeated with co-rotated Rayleigh
damping (β = 4 ms: about 5 % of critical in the first pinned bending mode, typical of a
soft polymer), against (a) only: co-rotated damping is not combined with SVK. Wall times of every simulation are measured in the same run (one BLAS
thread), and the speedups are their ratios.

A stiffness sweep (E from 3 GPa down to the study's 0.1 GPa, undamped) shows what decides
the agreement with (b): the swing stretches the beam (axial force N ≈ 2.5 m g at the
bottom), and in SVK that tension stiffens bending — by N L² / EI ≈ 2.5 Λ with
Λ = ρ g L³ / (E r²) (r the section's radius of gyration) — which no co-rotated linear
model, reduced or full, contains. The tip deviation grows with Λ too (≈ 0.6 % of L per
unit Λ), so a pendulum soft enough to deviate by 1 % of its length is deep in the
stiffening regime.

    python workflows/flexible_pendulum.py [--out docs/flexible_pendulum] [--quick]

writes OUT.json, OUT.png and prints the tables recorded in docs/flexible_pendulum.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: timings of one core

import time
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

from common import fmt, log, parser, pyplot, quiet, save_figure, table_head, temporary_folder
from common import write_record

MODE_COUNTS = (5, 10, 15, 20, 30)
#: Eigenmode counts of the SVK rows (with and without attachment modes; the coefficients of
#: Nm = 30 with attachment modes would hold 36 M numbers).
SVK_MODE_COUNTS = (5, 10, 15, 20)
TOLERANCES = (1e-10, 1e-6, 1e-4, 1e-3)   # cosine and SVD tolerance together
DAMPING_BETA_S = 4e-3
SWEEP_E_PA = (3e9, 1e9, 3e8)       # with the study's 1e8 from the main table
#: Newton tolerance of reference (b): its tangent differs from the co-rotated one by stress
#: stiffening, so Newton converges linearly; 1e-8 of the body size leaves a few µm.
SVK_TOLERANCE = 1e-8


def setup(quick: bool):
    """Mesh, assembly, the free-free modes (largest Nm), node groups: everything shared."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references import pendulum

    study = dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)})
    cfg = parse_config(dict(study, basis={"attachment": "none"}), "flexible pendulum")
    attached = parse_config(dict(study, basis={"attachment": "scene"}), "flexible pendulum")
    with temporary_folder() as tmp:
        body_mesh = pipeline.body_mesh(pipeline.mesh_stage(cfg.geometry, cfg.mesh, tmp))
    t0 = time.perf_counter()
    model = pipeline.assembly_stage(body_mesh.mesh, cfg.material).model
    modes = {"none": pipeline.modes_stage(model, cfg.plan.body.modes),
             "scene": pipeline.modes_stage(model, attached.plan.body.modes, body=body_mesh)}
    offline_s = time.perf_counter() - t0
    groups = group_weights(body_mesh, model.Vs)
    scene = cfg.scene if not quick else replace(cfg.scene, end_time_s=0.3)
    return cfg, body_mesh, model, modes, groups, scene, offline_s


def gcms_body(model, modes, body_mesh, nm: int, tolerance: float | None, svk: bool = False):
    """(body, reduction report, reduction wall time, SVK law and its report) for nm modes at
    one tolerance; the law only for ``svk``, its coefficients' time inside the wall time."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.selection import SelectionConfig
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
    from gcms_fenicsx.dynamics.bodies.svk import SVKLaw
    from gcms_fenicsx.fe.svk_coefficients import svk_coefficients

    selection = SelectionConfig() if tolerance is None else \
        SelectionConfig(cosine_tolerance=tolerance ** 2, svd_tolerance=tolerance)
    t0 = time.perf_counter()
    reduction = pipeline.reduction_stage(
        pipeline.basis_stage(model, modes.lowest(nm), body_mesh), selection)
    body = body_from_reduced(reduction)
    law, report = None, {}
    if svk:
        coefficients, report = svk_coefficients(body_mesh.mesh, reduction.fields,
                                                model.material)
        law = SVKLaw.of(coefficients, body)
    return body, reduction.selection, time.perf_counter() - t0, law, report


def run(body, scene, law=None, **kwargs) -> dict:
    from gcms_fenicsx.dynamics.run.simulate import simulate_body
    from gcms_fenicsx.dynamics.bodies.svk import svk_state

    if law is not None:
        kwargs["elastic"] = partial(svk_state, body, law)
        scene = replace(scene, elasticity="svk", solver=replace(
            scene.solver, tolerance=SVK_TOLERANCE, max_iterations=60))
    t0 = time.perf_counter()
    traj, summary = simulate_body(body, scene, **kwargs)
    wall = time.perf_counter() - t0
    if not summary["complete"]:
        raise RuntimeError(summary["message"])
    return {"time": traj.time, "tip": traj.groups["end_xL"]["position"], "wall_s": wall,
            "summary": summary}


def references(full, model, scene) -> dict:
    """Runs of the full-order body: (a) co-rotated linear, and (b) Saint Venant–Kirchhoff
    unless ``scene`` is damped (co-rotated damping is not combined with SVK)."""
    from gcms_fenicsx.references.full_order import sparse_factorization, svk_elastic

    refs = {"a": run(full, scene, factorize=sparse_factorization)}
    log(f"  reference (a), co-rotated linear on {full.dofs} DOFs: {refs['a']['wall_s']:.0f} s")
    if not scene.damping_beta:
        svk_scene = replace(scene, elasticity="svk", solver=replace(
            scene.solver, tolerance=SVK_TOLERANCE, max_iterations=60))
        refs["b"] = run(full, svk_scene, factorize=sparse_factorization,
                        elastic=svk_elastic(model, full))
        log(f"  reference (b), Saint Venant–Kirchhoff: {refs['b']['wall_s']:.0f} s")
    return refs


def reductions(model, modes, body_mesh, quick: bool) -> list[dict]:
    """Every GCMS case of the study: the co-rotated law for each Nm and tolerance without
    attachment modes and at the default tolerance with them; the SVK law at the default
    tolerance, without and with them."""
    counts = (5, 10, 20) if quick else MODE_COUNTS
    svk_counts = (5, 10) if quick else SVK_MODE_COUNTS
    plan = [("corotated", "none", nm, tol) for nm in counts
            for tol in (None, *((1e-4,) if quick else TOLERANCES))]
    plan += [("corotated", "scene", nm, None) for nm in counts]
    plan += [("svk", attachment, nm, None) for attachment in ("none", "scene")
             for nm in svk_counts]
    cases = []
    for elasticity, attachment, nm, tol in plan:
        body, report, reduce_s, law, svk_report = gcms_body(
            model, modes[attachment], body_mesh, nm, tol, svk=elasticity == "svk")
        cases.append({"elasticity": elasticity, "attachment": attachment, "modes": nm,
                      "tolerance": tol, "body": body, "report": report,
                      "reduce_s": reduce_s, "law": law, "svk": svk_report})
        if elasticity == "svk":
            log(f"  SVK coefficients, Nm = {nm} + attachment {attachment}: "
                f"{svk_report['fields']} fields, {svk_report['bytes'] / 1e6:.1f} MB, "
                f"{svk_report['seconds']:.1f} s")
    return cases


def study(damping: float, model, full, rigid, cases: list[dict], scene) -> dict:
    from gcms_fenicsx.references import pendulum

    scene = replace(scene, damping_beta=damping)
    until = min(rigid.half_period_s, scene.end_time_s)
    log(f"[damping {damping:g} s]")
    refs = references(full, model, scene)
    dev = {k: pendulum.tip_deviation(rigid, r["time"], r["tip"]) for k, r in refs.items()}
    k = refs["a"]["time"] <= until + 1e-12
    out = {"damping_beta_s": damping, "half_period_s": rigid.half_period_s, "until_s": until,
           "full_dofs": full.dofs,
           "max_deviation_over_length": {key: float(np.linalg.norm(d[k], axis=1).max()
                                                    / pendulum.LENGTH_M)
                                         for key, d in dev.items()},
           "a_vs_b": (pendulum.deviation_error(refs["a"]["time"], dev["a"], dev["b"], until)
                      if "b" in dev else None),
           "references": {key: {"wall_s": r["wall_s"],
                                "newton_iterations_mean": r["summary"]["newton_iterations_mean"],
                                "energy_drift_rel": r["summary"]["energy_drift_rel"]}
                          for key, r in refs.items()},
           "gcms": [], "curves": {"time": refs["a"]["time"].tolist(),
                                  **{key: d.tolist() for key, d in dev.items()}}}
    for case in cases:
        if case["elasticity"] == "svk" and damping:
            continue    # co-rotated damping is not combined with SVK
        body, report, tol, nm = case["body"], case["report"], case["tolerance"], case["modes"]
        r = run(body, scene, case["law"])
        d = pendulum.tip_deviation(rigid, r["time"], r["tip"])
        row = {"elasticity": case["elasticity"], "modes": nm, "attachment": case["attachment"],
               "tolerance": "default" if tol is None else tol,
               "reduced_dofs": body.dofs, "columns_before": report["columns_before"],
               "pruning_error": report["max_rel_frequency_error"],
               "error_vs_a": pendulum.deviation_error(r["time"], d, dev["a"], until),
               "error_vs_b": (pendulum.deviation_error(r["time"], d, dev["b"], until)
                              if "b" in dev else None),
               "wall_s": r["wall_s"], "reduction_s": case["reduce_s"],
               "steps_per_second": r["summary"]["steps_per_second"],
               "newton_iterations_mean": r["summary"]["newton_iterations_mean"],
               "speedup_vs_a": refs["a"]["wall_s"] / r["wall_s"],
               "speedup_vs_b": (refs["b"]["wall_s"] / r["wall_s"] if "b" in refs else None)}
        if case["svk"]:
            row.update(coefficients_s=case["svk"]["seconds"],
                       coefficients_bytes=case["svk"]["bytes"],
                       coefficient_fields=case["svk"]["fields"])
        out["gcms"].append(row)
        if tol is None and nm == 10 and case["attachment"] == "none":
            out["curves"][f"gcms10_{case['elasticity']}"] = d.tolist()
        log(f"  {case['elasticity']}, Nm = {nm:2d}, attachment {case['attachment']}, tolerance "
            f"{row['tolerance']}: {body.dofs} DOFs, error vs (a) {row['error_vs_a']:.2%}, "
            f"vs (b) {fmt(row['error_vs_b'])}, {row['steps_per_second']:.0f} steps/s")
    return out


def stiffness_sweep(cfg, body_mesh, groups, scene, quick: bool) -> list[dict]:
    """(a), (b) and GCMS (Nm = 10, 20) at stiffer materials: where GCMS meets SVK."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.references import pendulum
    from gcms_fenicsx.references.full_order import full_order_body
    from gcms_fenicsx.config.material import Material

    rows = []
    for E in (SWEEP_E_PA[:1] if quick else SWEEP_E_PA):
        log(f"[sweep] E = {E:.0e} Pa")
        material = Material(E=E, nu=cfg.material.nu, rho=cfg.material.rho)
        model = pipeline.assembly_stage(body_mesh.mesh, material).model
        modes = pipeline.modes_stage(model, replace(cfg.plan.body.modes, count=20))
        full = full_order_body(model, groups)
        rigid = pendulum.rigid_pendulum(full, np.array(scene.gravity), scene.end_time_s)
        until = min(rigid.half_period_s, scene.end_time_s)
        refs = references(full, model, scene)
        dev = {k: pendulum.tip_deviation(rigid, r["time"], r["tip"]) for k, r in refs.items()}
        k = refs["a"]["time"] <= until + 1e-12
        r2 = float(np.sort(np.linalg.eigvalsh(full.second_moment))[1]) / full.total_mass_kg
        # the section's r² in the bending plane
        lam = cfg.material.rho * 9.81 * pendulum.LENGTH_M ** 3 / (E * r2)
        row = {"E_pa": E, "lambda": lam, "tension_parameter": 2.5 * lam,
               "max_deviation_over_length": float(np.linalg.norm(dev["a"][k], axis=1).max()
                                                  / pendulum.LENGTH_M),
               "a_vs_b": pendulum.deviation_error(refs["a"]["time"], dev["a"], dev["b"], until),
               "reference_wall_s": {key: r["wall_s"] for key, r in refs.items()}}
        for nm in (10, 20):
            body, *_ = gcms_body(model, modes, body_mesh, nm, None)
            r = run(body, scene)
            d = pendulum.tip_deviation(rigid, r["time"], r["tip"])
            row[f"gcms{nm}_vs_a"] = pendulum.deviation_error(r["time"], d, dev["a"], until)
            row[f"gcms{nm}_vs_b"] = pendulum.deviation_error(r["time"], d, dev["b"], until)
        rows.append(row)
        log(f"  Λ = {lam:.2f}, deviation {row['max_deviation_over_length']:.3%} of L, "
            f"(a) vs (b) {row['a_vs_b']:.2%}, GCMS10 vs (a) {row['gcms10_vs_a']:.2%}, "
            f"vs (b) {row['gcms10_vs_b']:.2%}")
    return rows


def sweep_table(rows: list[dict]) -> str:
    lines = table_head("E GPa", "Λ = ρgL³/(Er²)", "tension N L²/EI", "tip deviation / L",
                       "(a) vs (b)", "GCMS Nm=10 vs (a)", "vs (b)", "GCMS Nm=20 vs (a)", "vs (b)")
    for r in rows:
        lines.append(f"| {r['E_pa'] / 1e9:g} | {r['lambda']:.3f} | {r['tension_parameter']:.2f} "
                     f"| {r['max_deviation_over_length']:.3%} | {r['a_vs_b']:.2%} "
                     f"| {r['gcms10_vs_a']:.2%} | {r['gcms10_vs_b']:.2%} "
                     f"| {r['gcms20_vs_a']:.2%} | {r['gcms20_vs_b']:.2%} |")
    return "\n".join(lines)


def table(result: dict) -> str:
    ref = result["references"]
    dev = result["max_deviation_over_length"]
    b_text = (f", {dev['b']:.2%} (b); (a) vs (b) differ by {result['a_vs_b']:.2%}"
              if "b" in ref else " (no SVK reference with damping)")
    times = ", ".join(f"({k}) {v['wall_s']:.0f} s" for k, v in ref.items())
    lines = [f"damping β = {result['damping_beta_s']:g} s: tip deviation up to "
             f"{dev['a']:.2%} of L (a){b_text}; references: {times} "
             f"({result['full_dofs']:,} DOFs)", "",
             *table_head("elasticity", "Nm", "attachment", "tolerance", "reduced DOFs",
                         "pruning error", "error vs (a)", "error vs (b)", "GCMS s", "steps/s",
                         "speedup vs (a)", "speedup vs (b)")]
    for r in result["gcms"]:
        tol = r["tolerance"] if isinstance(r["tolerance"], str) else f"{r['tolerance']:.0e}"
        speedup_b = "" if r["speedup_vs_b"] is None else f"{r['speedup_vs_b']:.0f}×"
        lines.append(f"| {r['elasticity']} | {r['modes']} | {r['attachment']} | {tol} "
                     f"| {r['reduced_dofs']} | {r['pruning_error']:.1e} "
                     f"| {r['error_vs_a']:.2%} | {fmt(r['error_vs_b'])} | {r['wall_s']:.2f} "
                     f"| {r['steps_per_second']:.0f} | {r['speedup_vs_a']:.0f}× "
                     f"| {speedup_b} |")
    return "\n".join(lines)


def plot(results: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(len(results), 2, figsize=(13, 4.4 * len(results)), squeeze=False)
    for (curve_ax, err_ax), res in zip(axes, results):
        c = res["curves"]
        t = np.array(c["time"])
        for key, style, label in (("a", "-", "(a) co-rotated, all DOFs"),
                                  ("b", "--", "(b) Saint Venant–Kirchhoff, all DOFs"),
                                  ("gcms10_corotated", ":", "GCMS co-rotated, Nm = 10"),
                                  ("gcms10_svk", "-.", "GCMS SVK, Nm = 10")):
            if key not in c:
                continue
            d = np.array(c[key])
            curve_ax.plot(t, 1e3 * d[:, 0], style, color="C0", lw=1.2)
            curve_ax.plot(t, 1e3 * d[:, 2], style, color="C1", lw=1.2, label=label)
        curve_ax.axvline(res["until_s"], color="k", lw=0.6)
        curve_ax.set_xlabel("time [s]")
        curve_ax.set_ylabel("tip deviation from rigid pendulum [mm]  (x blue, z orange)")
        curve_ax.set_title(f"damping β = {res['damping_beta_s']:g} s")
        curve_ax.legend(fontsize=8)
        curve_ax.grid(alpha=0.3)
        for elasticity, attachment, marker in (("corotated", "none", "o"),
                                               ("corotated", "scene", "^"),
                                               ("svk", "none", "s"), ("svk", "scene", "D")):
            rows = [r for r in res["gcms"] if r["tolerance"] == "default"
                    and r["elasticity"] == elasticity and r["attachment"] == attachment]
            if not rows:
                continue
            nms = [r["modes"] for r in rows]
            reference = "b" if elasticity == "svk" else "a"
            err_ax.semilogy(nms, [r[f"error_vs_{reference}"] for r in rows], marker + "-",
                            label=f"{elasticity}, attachment {attachment}, vs ({reference})")
        err_ax.axhline(0.01, color="C0", lw=0.7, ls=":")
        err_ax.axhline(0.03, color="C1", lw=0.7, ls=":")
        err_ax.set_xlabel("elastic modes Nm")
        err_ax.set_ylabel("max |d − d_ref| / max |d_ref|")
        err_ax.set_title("GCMS error against its own law's reference (default selection)")
        err_ax.legend()
        err_ax.grid(alpha=0.3, which="both")
    save_figure(fig, path, dpi=100)


def main() -> None:
    options = parser(__doc__, out="docs/flexible_pendulum",
                     quick="0.3 s, fewer cases (smoke run)")
    options.add_argument("--sweep-only", action="store_true", help="only the stiffness sweep")
    args = options.parse_args()
    quiet()
    from gcms_fenicsx.references import pendulum
    from gcms_fenicsx.references.full_order import full_order_body

    cfg, body_mesh, model, modes, groups, scene, offline_s = setup(args.quick)
    if args.sweep_only:
        rows = stiffness_sweep(cfg, body_mesh, groups, scene, args.quick)
        write_record(Path(f"{args.out}_sweep.json"), {"sweep": rows})
        print(sweep_table(rows))
        return
    log(f"setup: {model.ndofs} DOFs, {len(modes['none'].elastic_eigenvalues)} modes (and "
        f"{len(modes['scene'].attachment_labels)} attachment modes) in {offline_s:.1f} s")
    full = full_order_body(model, groups)
    rigid = pendulum.rigid_pendulum(full, np.array(scene.gravity), scene.end_time_s)
    cases = reductions(model, modes, body_mesh, args.quick)
    results = [study(beta, model, full, rigid, cases, scene) for beta in (0.0, DAMPING_BETA_S)]
    for r in results:
        r["eigensolve_and_assembly_s"] = offline_s
    sweep = stiffness_sweep(cfg, body_mesh, groups, scene, args.quick)
    write_record(Path(f"{args.out}.json"), {"studies": results, "sweep": sweep})
    plot(results, Path(f"{args.out}.png"))
    for r in results:
        print(table(r))
        print()
    print(sweep_table(sweep))


if __name__ == "__main__":
    main()
