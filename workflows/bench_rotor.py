"""The rotor basis against the full one on the default crankshaft scene: coordinates, steps
per second (the ratio in the same run is the figure to read) and how far the outputs of the
two bases are apart, beside how far each is from itself at half the time step.

For Nm = 5, 10, 20 and 40 (``--modes``) the default study's modes are solved once, with the
scene's attachment modes (``[basis] attachment = "scene"``, the default), and reduced with and
without them (``pipeline``); each reduced model runs the built-in scene in both bases,
alternating, ``--repeat`` times each (best time kept); then the same with
stiffness-proportional damping β = 1e-4 s, whose outputs the 50 µs step resolves. The model
with attachment modes also runs on its static shapes (``[basis] shapes = "static"``: the
held body's static responses to the scene's load patterns, in both bases), compared besides
with the full basis on the model's modes (``against_modes``: steps/s ratio and differences).
The
outputs are the nose's whirl, the bearing forces and the drive torque
(``auto_modes.outputs``), compared as the flexible pendulum compares its tip:
max_t |y − y_ref| / max_t |y_ref|, over the whole run and from 1 ms on
(``auto_modes.START_S``).

    python workflows/bench_rotor.py [--out docs/bench_rotor] [--repeat 3] [--modes 10 ...]

writes OUT.json and prints the table recorded in README.md. One BLAS thread.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import argparse
import json
import logging
import sys
import tempfile
import tomllib
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from auto_modes import after_start, errors, outputs  # noqa: E402

MODE_COUNTS = (5, 10, 20, 40)
ATTACHMENT = ("none", "scene")
DAMPED_BETA_S = 1e-4


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run(model, scene, basis: str, attachment: tuple, static=None) -> tuple[dict, dict]:
    """(outputs and their times, summary) of one run of ``scene`` in ``basis`` (on the static
    shapes of the scene's ``static`` patterns, if given)."""
    from gcms_fenicsx.dynamics.simulate import simulate

    traj, summary = simulate(model, scene, basis=basis, attachment=attachment, static=static)
    if not summary["complete"]:
        raise SystemExit(f"{basis} basis: {summary['message']}")
    return dict(outputs(traj), time=traj.time), summary


def case(model, scene, repeat: int, attachment: tuple, static=None) -> tuple[dict, dict]:
    """Both bases on ``scene``, alternating, the fastest of ``repeat`` runs each kept; and
    both once at half the step: (row, the fastest runs' outputs and summaries).
    ``attachment``: the loads of the model's attachment modes (the rotor basis makes its own
    from them); ``static``: the scene's patterns of the static shapes, if the bases are on
    them (``config.basis.ScenePatterns``)."""
    half = replace(scene, time_step_s=scene.time_step_s / 2)
    out, summaries = {}, {}
    for _ in range(repeat):
        for basis in ("full", "rotor"):
            o, s = run(model, scene, basis, attachment, static)
            if basis not in summaries or s["wall_time_s"] < summaries[basis]["wall_time_s"]:
                out[basis], summaries[basis] = o, s
    halves = {basis: run(model, half, basis, attachment, static)[0]
              for basis in ("full", "rotor")}
    thinned = {b: {k: v[::2] for k, v in o.items()} for b, o in halves.items()}
    full, rotor = summaries["full"], summaries["rotor"]
    late = {b: after_start(o, o["time"]) for b, o in out.items()}
    return {
        "coordinates": {"full": full["reduced_dofs"], "rotor": rotor["reduced_dofs"]},
        "steps_per_second": {"full": full["steps_per_second"],
                             "rotor": rotor["steps_per_second"]},
        "speedup": rotor["steps_per_second"] / full["steps_per_second"],
        "rotor_vs_full": errors(out["rotor"], out["full"]),
        "rotor_vs_full_after_start": errors(late["rotor"], late["full"]),
        "full_vs_half_step": errors(out["full"], thinned["full"]),
        "rotor_vs_half_step": errors(out["rotor"], thinned["rotor"]),
    }, {"outputs": out, "summaries": summaries}


def against_modes(static: dict, modes: dict) -> dict:
    """How the runs on the static shapes compare with the full basis on the model's modes
    (the same model, the same scene): its steps/s over theirs, the differences from 1 ms on."""
    reference = modes["summaries"]["full"]["steps_per_second"]
    late = after_start(modes["outputs"]["full"], modes["outputs"]["full"]["time"])
    return {b: {"speedup": static["summaries"][b]["steps_per_second"] / reference,
                "difference_after_start": errors(after_start(static["outputs"][b],
                                                             static["outputs"][b]["time"]),
                                                 late)}
            for b in ("full", "rotor")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/bench_rotor"))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--modes", type=int, nargs="+", default=list(MODE_COUNTS))
    args = parser.parse_args()
    logging.disable(logging.INFO)
    from gcms_fenicsx import pipeline
    from gcms_fenicsx.config.basis import scene_patterns
    from gcms_fenicsx.config.study import default_config_text, parse_config

    raw = dict(tomllib.loads(default_config_text()), basis={"attachment": "scene"})
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for nm in args.modes:
            cfg = parse_config(dict(raw, modes={"count": nm}))
            static = scene_patterns(replace(cfg.basis, shapes="static"), cfg.scene)
            chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.modes,
                                       Path(tmp))
            damped = replace(cfg.scene, damping_beta=DAMPED_BETA_S)
            for attachment in ATTACHMENT:
                loads = cfg.modes.attachment if attachment == "scene" else ()
                modes = chain.modes if loads else replace(chain.modes, attachment_labels=())
                basis = pipeline.basis_stage(chain.assembly.model, modes, chain.body)
                model = pipeline.reduction_stage(basis, cfg.selection)
                for name, scene in (("default", cfg.scene),
                                    (f"beta {DAMPED_BETA_S:g} s", damped)):
                    result, runs = case(model, scene, args.repeat, loads)
                    rows.append(dict(modes=nm, attachment=attachment, shapes="modes",
                                     scene=name, **result))
                    log(json.dumps(rows[-1]))
                    if not loads:
                        continue
                    result, shaped = case(model, scene, args.repeat, loads, static)
                    rows.append(dict(modes=nm, attachment=attachment, shapes="static",
                                     scene=name, **result,
                                     against_modes=against_modes(shaped, runs)))
                    log(json.dumps(rows[-1]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps({"rows": rows}, indent=1))
    print(table(rows))


def table(rows: list[dict]) -> str:
    lines = ["| scene | Nm | attachment | shapes | coordinates full → rotor | steps/s full | "
             "steps/s rotor | speedup | rotor vs full (whirl, forces, torque) | the same from "
             "1 ms on | full: h vs h/2 | rotor: h vs h/2 |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def three(e: dict) -> str:
        return ", ".join(f"{100 * e[k]:.1f} %" for k in ("nose whirl", "bearing forces",
                                                          "drive torque"))

    for r in rows:
        c, s = r["coordinates"], r["steps_per_second"]
        lines.append(f"| {r['scene']} | {r['modes']} | {r['attachment']} | {r['shapes']} | "
                     f"{c['full']} → {c['rotor']} | "
                     f"{s['full']:,.0f} | {s['rotor']:,.0f} | {r['speedup']:.2f}× | "
                     f"{three(r['rotor_vs_full'])} | {three(r['rotor_vs_full_after_start'])} | "
                     f"{three(r['full_vs_half_step'])} | {three(r['rotor_vs_half_step'])} |")
    static = [r for r in rows if "against_modes" in r]
    if static:
        lines += ["", "| scene | Nm | static shapes in | coordinates | steps/s against the full "
                  "basis on the modes | difference from it from 1 ms on |",
                  "|---|---|---|---|---|---|"]
    for r in static:
        for b in ("full", "rotor"):
            a = r["against_modes"][b]
            lines.append(f"| {r['scene']} | {r['modes']} | {b} | {r['coordinates'][b]} | "
                         f"{a['speedup']:.2f}× | {three(a['difference_after_start'])} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
