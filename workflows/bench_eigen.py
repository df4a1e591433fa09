"""Benchmark of the free-free eigen-solve: time against error, SLEPc against SciPy, 1 against 2 ranks.

For a slender rectangular beam and the default crankshaft, at mesh sizes from about 1e4 to
3e5 DOFs with P1 and P2 elements, each case runs in a fresh process (clean timings) and
reports: assembly time, eigen-solve time (SLEPc shift-invert Krylov–Schur, ten elastic
modes), the time of one MUMPS Cholesky factorisation of K − σM at the same shift (the
floor of shift-invert), SciPy's ``eigsh`` (ARPACK shift-invert, SuperLU) on the same K, M,
shift and mode count (up to --scipy-max DOFs, it is slow), the eigen-solve on 2 MPI ranks
(P2 cases), the frequency error against the finest P2 mesh of the same body, and (P2, one
rank) the time of selection plus reduction (``reduce_body``: GCMS fields, default selection,
Mr, Kr) beside the eigen-solve's.

BLAS threads are pinned to one per process (OPENBLAS_NUM_THREADS=1), so "2 ranks" is the
only parallelism compared.

    python workflows/bench_eigen.py [--out docs/bench_eigen] [--quick]

writes OUT.json and OUT.png (frequency error against eigen-solve time, P1 against P2) and
prints a Markdown table (the one in README.md).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

from common import log, parser, fmt as _fmt, pyplot, quiet, save_figure, temporary_folder
from common import table_head, table_row, worker_options, write_record

COUNT = 10
BODIES = {
    "beam": {"kind": "beam", "section": "rectangle", "width": 0.05, "height": 0.04, "length": 1.0},
    "crankshaft": {"kind": "crankshaft"},
}
# (body, order, mesh size in m): ~1e4 .. 3e5 DOFs; the last P2 size of a body is its reference
CASES = [
    ("beam", 1, 0.008), ("beam", 1, 0.005), ("beam", 1, 0.0035), ("beam", 1, 0.0028),
    ("beam", 2, 0.022), ("beam", 2, 0.012), ("beam", 2, 0.008), ("beam", 2, 0.0055),
    ("crankshaft", 1, 0.01), ("crankshaft", 1, 0.006), ("crankshaft", 1, 0.004),
    ("crankshaft", 1, 0.003),
    ("crankshaft", 2, 0.016), ("crankshaft", 2, 0.0100), ("crankshaft", 2, 0.0075),
    ("crankshaft", 2, 0.0062),
]
QUICK = [("beam", 1, 0.008), ("beam", 2, 0.022), ("beam", 2, 0.012)]


def worker(body: str, order: int, size: float, scipy_max: int) -> dict:
    """One case in this process (serial or under mpirun): timings and frequencies."""
    import numpy as np
    from mpi4py import MPI

    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.fe import factor

    quiet()
    comm = MPI.COMM_WORLD
    cfg = parse_config({"geometry": BODIES[body], "mesh": {"size": size, "order": order},
                        "modes": {"count": COUNT}})
    with temporary_folder() as tmp:
        folder = Path(comm.bcast(str(tmp) if comm.rank == 0 else None))  # rank 0's, for every rank
        body_mesh = pipeline.body_mesh(pipeline.mesh_stage(cfg.geometry, cfg.mesh, folder,
                                                           comm=comm), comm)
        comm.barrier()  # every rank has read the mesh before rank 0 removes the folder
    assembled = pipeline.assembly_stage(body_mesh.mesh, cfg.material)
    model, assembly = assembled.model, assembled.wall_time_s
    modes = pipeline.modes_stage(model, cfg.plan.body.modes)
    t0 = time.perf_counter()
    factor.inertia_below(model, modes.shift)
    factorization = time.perf_counter() - t0
    out = {"body": body, "order": order, "size_m": size, "ranks": comm.size,
           "ndofs": model.ndofs, "assembly_s": assembly,
           "eigensolve_s": modes.timings_s["eigensolve"], "factorization_s": factorization,
           "shift": modes.shift, "frequencies_hz": modes.elastic_frequencies_hz.tolist(),
           "solver_timings_s": modes.timings_s}
    if comm.size == 1 and order == 2:  # what ``gcms reduce`` adds: default selection, Mr, Kr
        t0 = time.perf_counter()  # the GCMS fields with their matrices, then the selection
        pipeline.reduction_stage(pipeline.basis_stage(model, modes, body_mesh), cfg.selection)
        out["selection_and_reduction_s"] = time.perf_counter() - t0
    if comm.size == 1 and model.ndofs <= scipy_max:
        out.update(_scipy(model, modes, np))
    return out


def _scipy(model, modes, np) -> dict:
    """ARPACK shift-invert (SuperLU) on the same K, M, shift and number of modes (rigid included)."""
    import scipy.sparse.linalg

    from gcms_fenicsx.references.full_order import to_scipy

    K, M = to_scipy(model.K), to_scipy(model.M)
    t0 = time.perf_counter()
    values = scipy.sparse.linalg.eigsh(K, k=6 + COUNT, M=M, sigma=modes.shift, which="LM",
                                       return_eigenvectors=False)
    elapsed = time.perf_counter() - t0
    elastic = np.sort(values)[6:]
    freq = np.sqrt(elastic) / (2 * np.pi)
    agree = float(np.max(np.abs(freq / modes.elastic_frequencies_hz - 1)))
    return {"scipy_eigsh_s": elapsed, "scipy_max_rel_difference": agree}


def run_case(case: tuple, ranks: int, scipy_max: int) -> dict:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = [sys.executable, __file__, "--worker", json.dumps(list(case)),
           "--scipy-max", str(scipy_max)]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"case {case} on {ranks} rank(s) failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def table(rows: list[dict]) -> str:
    lines = table_head("body", "P", "DOFs", "assembly s", "eigen-solve s", "factorisation s",
                       "solve/factor", "SciPy eigsh s", "SciPy/SLEPc", "2 ranks s", "1/2 ranks",
                       "max freq. error", "selection + reduction s", "/ eigen-solve")
    for r in rows:
        scipy_s, two = r.get("scipy_eigsh_s"), r.get("two_ranks_eigensolve_s")
        reduction = r.get("selection_and_reduction_s")
        cells = [r["body"], str(r["order"]), f"{r['ndofs']:,}", _fmt(r["assembly_s"], ".1f"),
                 _fmt(r["eigensolve_s"], ".1f"), _fmt(r["factorization_s"], ".1f"),
                 _fmt(r["eigensolve_s"] / r["factorization_s"], ".1f"), _fmt(scipy_s, ".1f"),
                 _fmt(scipy_s and scipy_s / r["eigensolve_s"], ".1f"), _fmt(two, ".1f"),
                 _fmt(two and r["eigensolve_s"] / two, ".2f"),
                 "ref." if r["error"] is None else _fmt(r["error"], ".1e"),
                 _fmt(reduction, ".2f"), _fmt(reduction and reduction / r["eigensolve_s"], ".1%")]
        lines.append(table_row(*cells))
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, body in zip(axes, BODIES):
        for order, style in ((1, "s--"), (2, "o-")):
            sel = [r for r in rows if r["body"] == body and r["order"] == order
                   and r["error"] is not None]
            if sel:
                ax.loglog([r["eigensolve_s"] + r["assembly_s"] for r in sel],
                          [r["error"] for r in sel], style, label=f"P{order}")
                for r in sel:
                    ax.annotate(f"{r['ndofs'] / 1e3:.0f}k", (r["eigensolve_s"] + r["assembly_s"],
                                                              r["error"]), fontsize=7)
        ax.set_title(f"{body}: {COUNT} lowest elastic frequencies")
        ax.set_xlabel("assembly + eigen-solve time [s] (1 rank)")
        ax.set_ylabel("max relative frequency error vs finest P2")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    save_figure(fig, path, dpi=130)


def main() -> None:
    options = parser(__doc__, out="docs/bench_eigen", quick="three small cases (a smoke run)")
    options.add_argument("--scipy-max", type=int, default=110_000,
                         help="largest DOF count SciPy eigsh is run on")
    worker_options(options, "--worker")
    args = options.parse_args()
    if args.worker:
        body, order, size = json.loads(args.worker)
        result = worker(body, order, size, args.scipy_max)
        from mpi4py import MPI
        if MPI.COMM_WORLD.rank == 0:
            print(json.dumps(result))
        return

    rows = []
    for case in QUICK if args.quick else CASES:
        t0 = time.perf_counter()
        row = run_case(case, 1, args.scipy_max)
        if case[1] == 2:
            two = run_case(case, 2, 0)
            row["two_ranks_eigensolve_s"] = two["eigensolve_s"]
            row["two_ranks_max_rel_difference"] = max(
                abs(a / b - 1) for a, b in zip(two["frequencies_hz"], row["frequencies_hz"]))
        rows.append(row)
        log(f"{case}: {row['ndofs']} DOFs, eigen-solve {row['eigensolve_s']:.1f} s "
            f"({time.perf_counter() - t0:.0f} s for the case)")
    for body in BODIES:
        finest = [r for r in rows if r["body"] == body and r["order"] == 2]
        if not finest:
            continue
        ref = max(finest, key=lambda r: r["ndofs"])
        for r in rows:
            if r["body"] == body:
                r["error"] = None if r is ref else max(
                    abs(a / b - 1) for a, b in zip(r["frequencies_hz"], ref["frequencies_hz"]))
    write_record(Path(f"{args.out}.json"), {"count": COUNT, "rows": rows}, indent=2)
    plot(rows, Path(f"{args.out}.png"))
    print(table(rows))


if __name__ == "__main__":
    main()
