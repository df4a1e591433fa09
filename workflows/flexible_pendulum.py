"""Flexible pendulum: the GCMS integrator against two full-order references on the same mesh.

The case (``gcms_fenicsx.pendulum``): a soft 1 m beam, pinned at one end face by a revolute
joint, released horizontally under gravity; compared is the tip's deviation from the rigid
pendulum over the first half period of the swing. References, on every FE node:

(a) the same co-rotated linear-elastic model on all 3N DOFs (SciPy sparse, same integrator);
(b) geometrically nonlinear Saint Venant–Kirchhoff, internal forces assembled by dolfinx.

GCMS runs for Nm = 5 … 30 elastic modes and several selection tolerances; the error is
max_t |d − d_ref| / max_t |d_ref|. The same study is repeated with co-rotated Rayleigh
damping (β = 4 ms: about 5 % of critical in the first pinned bending mode, typical of a
soft polymer). Wall times of every simulation are measured in the same run (one BLAS
thread), and the speedups are their ratios.

    python workflows/flexible_pendulum.py [--out docs/flexible_pendulum] [--quick]

writes OUT.json, OUT.png and prints the tables recorded in docs/flexible_pendulum.md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: timings of one core

import argparse
import json
import logging
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

MODE_COUNTS = (5, 10, 15, 20, 30)
TOLERANCES = (1e-10, 1e-6, 1e-4, 1e-3)   # cosine and SVD tolerance together
DAMPING_BETA_S = 4e-3
#: Newton tolerance of reference (b): its tangent differs from the co-rotated one by stress
#: stiffening, so Newton converges linearly; 1e-8 of the body size leaves a few µm.
SVK_TOLERANCE = 1e-8


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def setup(quick: bool):
    """Mesh, assembly, the free-free modes (largest Nm), node groups: everything shared."""
    from geometry import build_msh

    from gcms_fenicsx import eigen, fe, pendulum
    from gcms_fenicsx.config import parse_config
    from gcms_fenicsx.mesh import read_mesh
    from gcms_fenicsx.node_groups import group_weights

    study = dict(pendulum.STUDY, modes={"count": max(MODE_COUNTS)})
    cfg = parse_config(study, "flexible pendulum")
    with tempfile.TemporaryDirectory() as tmp:
        info = build_msh(cfg.geometry, cfg.mesh, Path(tmp) / "pendulum.msh")
        body_mesh = read_mesh(Path(tmp) / "pendulum.msh", info.groups)
    t0 = time.perf_counter()
    model = fe.assemble(body_mesh.mesh, cfg.material)
    modes = eigen.solve_free_free(model, cfg.modes)
    offline_s = time.perf_counter() - t0
    groups = group_weights(body_mesh, model.Vs)
    scene = cfg.scene if not quick else replace(cfg.scene, end_time_s=0.3)
    return cfg, body_mesh, model, modes, groups, scene, offline_s


def gcms_body(cfg, model, modes, body_mesh, nm: int, tolerance: float | None):
    """(body, reduction report, reduction wall time) for nm modes at one tolerance."""
    from gcms_fenicsx.config import parse_config
    from gcms_fenicsx.dynamics.body import body_from_reduced
    from gcms_fenicsx.pendulum import STUDY
    from gcms_fenicsx.reduce import reduce_body

    table = dict(STUDY, modes={"count": nm})
    if tolerance is not None:
        table["selection"] = {"cosine_tolerance": tolerance ** 2, "svd_tolerance": tolerance}
    cfg_t = parse_config(table)
    t0 = time.perf_counter()
    reduced, report = reduce_body(model, modes.lowest(nm), body_mesh, cfg_t, {})
    return body_from_reduced(reduced), report, time.perf_counter() - t0


def run(body, scene, **kwargs) -> dict:
    from gcms_fenicsx.dynamics.simulate import simulate_body

    t0 = time.perf_counter()
    traj, summary = simulate_body(body, scene, **kwargs)
    wall = time.perf_counter() - t0
    if not summary["complete"]:
        raise RuntimeError(summary["message"])
    return {"time": traj.time, "tip": traj.groups["end_xL"]["position"], "wall_s": wall,
            "summary": summary}


def study(damping: float, cfg, body_mesh, model, modes, groups, scene, quick: bool) -> dict:
    from gcms_fenicsx import pendulum
    from gcms_fenicsx.full_order import full_order_body, sparse_factorization, svk_elastic

    scene = replace(scene, damping_beta=damping)
    full = full_order_body(model, groups)
    rigid = pendulum.rigid_pendulum(full, np.array(scene.gravity), scene.end_time_s)
    until = min(rigid.half_period_s, scene.end_time_s)
    log(f"[damping {damping:g} s] reference (a): co-rotated linear, {full.dofs} DOFs")
    refs = {"a": run(full, scene, factorize=sparse_factorization)}
    log(f"  {refs['a']['wall_s']:.0f} s; reference (b): Saint Venant–Kirchhoff")
    svk_scene = replace(scene, solver=replace(scene.solver, tolerance=SVK_TOLERANCE,
                                              max_iterations=60))
    refs["b"] = run(full, svk_scene, factorize=sparse_factorization,
                    elastic=svk_elastic(model, full))
    log(f"  {refs['b']['wall_s']:.0f} s")
    dev = {k: pendulum.tip_deviation(rigid, r["time"], r["tip"]) for k, r in refs.items()}
    k = refs["a"]["time"] <= until + 1e-12
    out = {"damping_beta_s": damping, "half_period_s": rigid.half_period_s, "until_s": until,
           "full_dofs": full.dofs,
           "max_deviation_over_length": {key: float(np.linalg.norm(d[k], axis=1).max()
                                                    / pendulum.LENGTH_M)
                                         for key, d in dev.items()},
           "a_vs_b": pendulum.deviation_error(refs["a"]["time"], dev["a"], dev["b"], until),
           "references": {key: {"wall_s": r["wall_s"],
                                "newton_iterations_mean": r["summary"]["newton_iterations_mean"],
                                "energy_drift_rel": r["summary"]["energy_drift_rel"]}
                          for key, r in refs.items()},
           "gcms": [], "curves": {"time": refs["a"]["time"].tolist(),
                                  "a": dev["a"].tolist(), "b": dev["b"].tolist()}}
    counts = (5, 10, 20) if quick else MODE_COUNTS
    for nm in counts:
        for tol in (None, *((1e-4,) if quick else TOLERANCES)):
            body, report, reduce_s = gcms_body(cfg, model, modes, body_mesh, nm, tol)
            r = run(body, scene)
            d = pendulum.tip_deviation(rigid, r["time"], r["tip"])
            row = {"modes": nm, "tolerance": "default" if tol is None else tol,
                   "reduced_dofs": body.dofs, "columns_before": report["columns_before"],
                   "pruning_error": report["max_rel_frequency_error"],
                   "error_vs_a": pendulum.deviation_error(r["time"], d, dev["a"], until),
                   "error_vs_b": pendulum.deviation_error(r["time"], d, dev["b"], until),
                   "wall_s": r["wall_s"], "reduction_s": reduce_s,
                   "steps_per_second": r["summary"]["steps_per_second"],
                   "newton_iterations_mean": r["summary"]["newton_iterations_mean"],
                   "speedup_vs_a": refs["a"]["wall_s"] / r["wall_s"],
                   "speedup_vs_b": refs["b"]["wall_s"] / r["wall_s"]}
            out["gcms"].append(row)
            if tol is None and nm == 10:
                out["curves"]["gcms10"] = d.tolist()
            log(f"  Nm = {nm:2d}, tolerance {row['tolerance']}: {body.dofs} DOFs, error vs "
                f"(a) {row['error_vs_a']:.2%}, vs (b) {row['error_vs_b']:.2%}")
    return out


def table(result: dict) -> str:
    ref = result["references"]
    lines = [f"damping β = {result['damping_beta_s']:g} s: tip deviation up to "
             f"{result['max_deviation_over_length']['a']:.2%} of L (a), "
             f"{result['max_deviation_over_length']['b']:.2%} (b); (a) vs (b) differ by "
             f"{result['a_vs_b']:.2%}; references: (a) {ref['a']['wall_s']:.0f} s, "
             f"(b) {ref['b']['wall_s']:.0f} s ({result['full_dofs']:,} DOFs)", "",
             "| Nm | tolerance | reduced DOFs | pruning error | error vs (a) | error vs (b) "
             "| GCMS s | steps/s | speedup vs (a) | speedup vs (b) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["gcms"]:
        tol = r["tolerance"] if isinstance(r["tolerance"], str) else f"{r['tolerance']:.0e}"
        lines.append(f"| {r['modes']} | {tol} | {r['reduced_dofs']} | {r['pruning_error']:.1e} "
                     f"| {r['error_vs_a']:.2%} | {r['error_vs_b']:.2%} | {r['wall_s']:.2f} "
                     f"| {r['steps_per_second']:.0f} | {r['speedup_vs_a']:.0f}× "
                     f"| {r['speedup_vs_b']:.0f}× |")
    return "\n".join(lines)


def plot(results: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 2, figsize=(13, 4.4 * len(results)), squeeze=False)
    for (curve_ax, err_ax), res in zip(axes, results):
        c = res["curves"]
        t = np.array(c["time"])
        for key, style, label in (("a", "-", "(a) co-rotated, all DOFs"),
                                  ("b", "--", "(b) Saint Venant–Kirchhoff"),
                                  ("gcms10", ":", "GCMS, Nm = 10")):
            d = np.array(c[key])
            curve_ax.plot(t, 1e3 * d[:, 0], style, color="C0", lw=1.2)
            curve_ax.plot(t, 1e3 * d[:, 2], style, color="C1", lw=1.2, label=label)
        curve_ax.axvline(res["until_s"], color="k", lw=0.6)
        curve_ax.set_xlabel("time [s]")
        curve_ax.set_ylabel("tip deviation from rigid pendulum [mm]  (x blue, z orange)")
        curve_ax.set_title(f"damping β = {res['damping_beta_s']:g} s")
        curve_ax.legend(fontsize=8)
        curve_ax.grid(alpha=0.3)
        default = [r for r in res["gcms"] if r["tolerance"] == "default"]
        nms = [r["modes"] for r in default]
        err_ax.semilogy(nms, [r["error_vs_a"] for r in default], "o-", label="vs (a)")
        err_ax.semilogy(nms, [r["error_vs_b"] for r in default], "s-", label="vs (b)")
        err_ax.axhline(0.01, color="C0", lw=0.7, ls=":")
        err_ax.axhline(0.03, color="C1", lw=0.7, ls=":")
        err_ax.set_xlabel("elastic modes Nm")
        err_ax.set_ylabel("max |d − d_ref| / max |d_ref|")
        err_ax.set_title("GCMS error (default selection)")
        err_ax.legend()
        err_ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/flexible_pendulum"))
    parser.add_argument("--quick", action="store_true", help="0.3 s, fewer cases (smoke run)")
    args = parser.parse_args()
    logging.disable(logging.INFO)
    cfg, body_mesh, model, modes, groups, scene, offline_s = setup(args.quick)
    log(f"setup: {model.ndofs} DOFs, {len(modes.elastic_eigenvalues)} modes in {offline_s:.1f} s")
    results = [study(beta, cfg, body_mesh, model, modes, groups, scene, args.quick)
               for beta in (0.0, DAMPING_BETA_S)]
    for r in results:
        r["eigensolve_and_assembly_s"] = offline_s
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{args.out}.json").write_text(json.dumps(results, indent=1))
    plot(results, Path(f"{args.out}.png"))
    for r in results:
        print(table(r))
        print()


if __name__ == "__main__":
    main()
