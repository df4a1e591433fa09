"""The flexible slider crank's speed: the GCMS conrod against Exudyn's floating-frame reduced
conrod (ObjectFFRFreducedOrder) on the same mechanism, mesh and time step, in one run.

The mechanism is ``workflows/slider_crank.py``'s (``references.slider_crank_assembly``): the
conrod's 3 mm P2 mesh, h = 2e-5 s, ρ∞ = 0.8, 0 ≤ t ≤ 0.1 s. Runs, each on one core:

- GCMS, ten free-free modes (96 coordinates) and ten with the pins' attachment modes (159), the
  assembly's NumPy step (``dynamics.system``);
- Exudyn (``workflows/exudyn/slider_crank_ffrf.py``, run by ``--exudyn-python``, a Python that
  imports Exudyn: ``python3 -m venv DIR && DIR/bin/pip install exudyn scipy``), the same mesh's
  matrices exported, ten and thirty free-free modes, its generalized-α (index 3), full Newton.

Accuracy: each run's midpoint deflection against the converged one — the GCMS conrod with
attachment modes, 0.01 % of the peak from the full-order conrod (docs/slider_crank.md) — and
against the test set as published. Speed: steps per second of the time integration alone
(not the modes nor the model's set-up), the best of ``--repeat`` runs.

    python workflows/slider_crank_speed.py --exudyn-python PATH [--out docs] [--repeat 1]

Writes OUT/slider_crank_speed.json and .md.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import json
import subprocess
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from common import log, parser, quiet, table_head, table_row, temporary_folder
from common import run_interruptibly, write_markdown, write_record
from slider_crank import benchmark, conrod_chain, simulate

FFRF = Path(__file__).resolve().parent / "exudyn" / "slider_crank_ffrf.py"
EXUDYN_MODES = (10, 30)
SETTINGS = SimpleNamespace(modes=10, time_step=2e-5, mesh_size=0.003, rho_inf=0.8)


def arguments() -> Any:
    p = parser(__doc__, out="docs", out_help="folder of slider_crank_speed.json and .md",
               repeat=1)
    p.add_argument("--exudyn-python", type=Path, required=True,
                   help="a Python that imports exudyn, numpy and scipy")
    args = p.parse_args()
    probe = subprocess.run([str(args.exudyn_python), "-c", "import exudyn, scipy"],
                           capture_output=True, text=True)
    if probe.returncode:
        p.error(f"--exudyn-python {args.exudyn_python} cannot import exudyn and scipy: "
                f"{probe.stderr.strip().splitlines()[-1] if probe.stderr else 'not runnable'}")
    return args


def export(ff: Any, folder: Path) -> None:
    """The conrod's full mass and stiffness (DOF 3 i + k), nodes and end-face groups, for
    the Exudyn script."""
    import scipy.sparse

    from gcms_fenicsx.fe.node_groups import group_weights
    from gcms_fenicsx.references.full_order import full_order_body

    model = ff.assembly.model
    groups = group_weights(ff.body, model.Vs)
    body = full_order_body(model, groups)
    folder.mkdir(parents=True, exist_ok=True)
    scipy.sparse.save_npz(folder / "M.npz", scipy.sparse.csr_matrix(body.mass))
    scipy.sparse.save_npz(folder / "K.npz", scipy.sparse.csr_matrix(body.stiffness))
    arrays = {"nodes": body.nodes_m}
    for name in ("end_x0", "end_xL"):
        arrays[f"{name}_nodes"], arrays[f"{name}_weights"] = groups[name]
    np.savez(folder / "conrod.npz", **arrays)


def exudyn(python: Path, data: Path, modes: int) -> dict:
    """One Exudyn run (its JSON: time_s, midpoint_deflection_m, wall_time_s, steps, ...)."""
    out = data / f"exudyn_{modes}.json"
    run = subprocess.run([str(python), str(FFRF), "--data", str(data), "--modes", str(modes),
                          "--time-step", str(SETTINGS.time_step), "--rho-inf",
                          str(SETTINGS.rho_inf), "--out", str(out)],
                         capture_output=True, text=True)
    if run.returncode:
        raise SystemExit(f"Exudyn ({modes} modes) failed:\n{run.stderr[-2000:]}")
    return json.loads(out.read_text())


def best(runs: list[dict]) -> dict:
    """The run of least wall time."""
    return min(runs, key=lambda r: r["wall_time_s"])


def measure(args: Any, work: Path) -> list[dict]:
    """Every run (module docstring), with its deflection series and its wall time."""
    from gcms_fenicsx.dynamics.bodies.body import body_from_reduced

    log("conrod: mesh, modes, reductions; finite-element data for Exudyn")
    ff, free_free = conrod_chain(SETTINGS, work / "free_free", attachment=False)
    _, attached = conrod_chain(SETTINGS, work / "attached")
    export(ff, work / "exudyn")
    rows = []
    for name, reduced in (("GCMS, 10 modes", free_free),
                          ("GCMS, 10 modes + attachment", attached)):
        body = body_from_reduced(reduced)
        run = best([simulate(body, SETTINGS) for _ in range(args.repeat)])
        rows.append({"code": name, "coordinates": run["coordinates"], "steps": run["steps"],
                     "wall_time_s": run["wall_time_s"], "time_s": run["time_s"],
                     "deflection_m": run["deflection_m"]})
        log(f"{name}: {run['steps'] / run['wall_time_s']:,.0f} steps/s")
    for modes in EXUDYN_MODES:
        run = best([exudyn(args.exudyn_python, work / "exudyn", modes)
                    for _ in range(args.repeat)])
        rows.append({"code": f"Exudyn {run['exudyn_version']}, {modes} modes",
                     "coordinates": run["coordinates"]["conrod_ode2"], "steps": run["steps"],
                     "wall_time_s": run["wall_time_s"], "time_s": np.array(run["time_s"]),
                     "deflection_m": np.array(run["midpoint_deflection_m"])})
        log(f"Exudyn, {modes} modes: {run['steps'] / run['wall_time_s']:,.0f} steps/s")
    return rows


def main() -> None:
    args = arguments()
    quiet()
    with temporary_folder("slider_crank_speed_") as work:
        rows = measure(args, work)
    times = rows[0]["time_s"]
    converged = rows[1]["deflection_m"]
    published = benchmark(times)
    peak = float(np.abs(published).max())
    for row in rows:
        series = np.interp(times, row["time_s"], row["deflection_m"])
        row["error_vs_converged"] = float(np.abs(series - converged).max() / peak)
        row["error_vs_test_set"] = float(np.abs(series - published).max() / peak)
        row["steps_per_s"] = row["steps"] / row["wall_time_s"]
    write(rows, Path(args.out))


def write(rows: list[dict], out: Path) -> None:
    """slider_crank_speed.json and .md."""
    lines = table_head("run", "conrod coordinates", "steps/s", "µs/step",
                       "error vs converged", "error vs test set")
    for r in rows:
        lines.append(table_row(r["code"], r["coordinates"], f"{r['steps_per_s']:,.0f}",
                               f"{1e6 / r['steps_per_s']:,.0f}", f"{r['error_vs_converged']:.2%}",
                               f"{r['error_vs_test_set']:.2%}"))
    same_modes = rows[0]["steps_per_s"] / rows[2]["steps_per_s"]
    accurate = rows[1]["steps_per_s"] / rows[3]["steps_per_s"]
    lines += ["", f"Ten free-free modes each: GCMS {same_modes:.1f}× Exudyn's steps per second. "
              f"The most accurate of each: GCMS with attachment modes (the reference) "
              f"{accurate:.1f}× Exudyn with thirty modes ({rows[3]['error_vs_converged']:.2%} "
              "from it)."]
    document = {"time_step_s": SETTINGS.time_step, "rho_inf": SETTINGS.rho_inf,
                "runs": [{k: v for k, v in r.items() if k not in ("time_s", "deflection_m")}
                         for r in rows],
                "ratio_same_modes": same_modes, "ratio_most_accurate": accurate}
    record = write_record(out / "slider_crank_speed.json", document)["record"]
    text = "\n".join(lines) + "\n"
    write_markdown(out / "slider_crank_speed.md",
                   "# The flexible slider crank: GCMS against Exudyn\n\n" + text, record)
    print(text)


if __name__ == "__main__":
    run_interruptibly(main, "--out")
