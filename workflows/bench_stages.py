"""What a rerun of the default study costs: the stage cache measured end to end.

Runs ``gcms run`` on the built-in study in fresh processes, as a user would:

- cold: an empty --out and an empty form cache (the forms are compiled: XDG_CACHE_HOME
  points at an empty folder);
- warm: an empty --out, forms compiled;
- unchanged: the same study again in the warm run's --out;
- only [scene]: end_time 0.12 → 0.10 s;
- only [selection]: svd_tolerance 1e-6 → 1e-5;
- fewer modes: count 10 → 8 (the cached solve restricted);
- --fresh: the study as it was, nothing reused;
- mode shapes asked: ``[outputs] mode_shapes = true`` (the cached modes written for ParaView).

For each: the wall time of the whole command (process start to exit), each stage's
status and seconds (the ``stages`` block of summary.json) and the solve's own timings
(modes.json) where the modes were computed. With ``--before DIR`` (a checkout of an
earlier commit) its warm run is timed too, alternating with this code's, for the ratio.

    python workflows/bench_stages.py [--before DIR] [--out docs/bench_stages]

writes OUT.json and prints the table recorded in README.md.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from common import REPO, checkout, parser, table_head, temporary_folder, write_record

STAGES = ("mesh", "modes", "mode_shapes", "reduction", "simulation")
SOLVE_TIMINGS = ("geometry_and_mesh", "assembly", "shift_estimate", "eigensolve",
                 "inertia_check", "verification")


def gcms_run(code: Path, config: Path | None, out: Path, *extra: str,
             env: dict | None = None) -> dict:
    """``gcms run`` with the package in ``code``: wall seconds and the reports it wrote."""
    args = [sys.executable, "-m", "gcms_fenicsx.cli", "run", *([str(config)] if config else []),
            "--out", str(out), *extra]
    t0 = time.perf_counter()
    run = subprocess.run(args, cwd=code, capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(code), **(env or {})))
    wall = time.perf_counter() - t0
    if run.returncode:
        raise RuntimeError(f"{' '.join(args)} failed:\n{run.stderr}")
    summary = json.loads((out / "summary.json").read_text())
    modes = json.loads((out / "modes.json").read_text())
    return {"wall_s": wall, "stages": summary.get("stages", {}),
            "solve_s": {k: modes["timings_s"].get(k) for k in SOLVE_TIMINGS},
            "output_mb": sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) / 1e6}


def variant(tmp: Path, name: str, old: str, new: str) -> Path:
    from gcms_fenicsx.config.study import default_config_text
    text = default_config_text()
    assert old in text, old
    path = tmp / f"{name}.toml"
    path.write_text(text.replace(old, new))
    tomllib.loads(path.read_text())
    return path


def main() -> None:
    options = parser(__doc__, out="docs/bench_stages")
    options.add_argument("--before", type=Path, default=None)
    args = options.parse_args()
    checkout(options, args.before)
    rows: dict[str, dict] = {}
    with temporary_folder() as tmp:
        rows["cold"] = gcms_run(REPO, None, tmp / "cold",
                                env={"XDG_CACHE_HOME": str(tmp / "empty_cache")})
        out = tmp / "warm"
        rows["warm"] = gcms_run(REPO, None, out)
        rows["unchanged"] = gcms_run(REPO, None, out)
        rows["only [scene]"] = gcms_run(REPO, variant(
            tmp, "scene", "end_time = 0.12 ", "end_time = 0.10 "), out)
        rows["only [selection]"] = gcms_run(REPO, variant(
            tmp, "selection", "[modes]\ncount = 10\n",
            "[modes]\ncount = 10\n\n[selection]\nsvd_tolerance = 1e-5\n"), out)
        rows["fewer modes (10 → 8)"] = gcms_run(REPO, variant(
            tmp, "fewer", "[modes]\ncount = 10\n", "[modes]\ncount = 8\n"), out)
        rows["--fresh"] = gcms_run(REPO, None, out, "--fresh")
        rows["mode shapes asked"] = gcms_run(REPO, variant(
            tmp, "shapes", "[modes]\ncount = 10\n",
            "[modes]\ncount = 10\n\n[outputs]\nmode_shapes = true\n"), out)
        if args.before is not None:
            for label, code in (("before, warm", args.before), ("warm, again", REPO)):
                rows[label] = gcms_run(code, None, tmp / label.replace(" ", "_").replace(",", ""))
    write_record(Path(f"{args.out}.json"), rows)
    print(table(rows))


def table(rows: dict[str, dict]) -> str:
    lines = table_head("run", "wall s", *STAGES, "--out MB")
    for name, r in rows.items():
        cells = []
        for stage in STAGES:
            s = r["stages"].get(stage)
            cells.append("" if s is None else
                         "reused" if s["status"] == "reused" else f"{s['seconds']:.1f}")
        lines.append(f"| {name} | {r['wall_s']:.1f} | " + " | ".join(cells)
                     + f" | {r['output_mb']:.1f} |")
    lines += ["", *table_head("run (modes computed)", *SOLVE_TIMINGS)]
    for name, r in rows.items():
        if not r["stages"] or r["stages"].get("modes", {}).get("status") == "computed":
            lines.append(f"| {name} | " + " | ".join(
                "" if r["solve_s"][k] is None else f"{r['solve_s'][k]:.2f}"
                for k in SOLVE_TIMINGS) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
