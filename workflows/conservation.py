"""Conservation and accuracy of the standalone integrator on a free flexible body.

The body: a steel beam, rectangle 30 × 20 mm, 0.5 m, six elastic modes (``gcms reduce``,
cosine_tolerance = 1e-12). Two cases, both free-floating, no damping, no gravity, ρ∞ = 1:

1. Spinning: ω = 60·(0.3, 1, 0.5) rad/s, drift velocity (0.1, 0.2, −0.3) m/s, started in
   elastic mode 1 (2 mm), 20 ms, Newton to 1e-13 of the body size, for h = 1e-4, 5e-5 and
   2.5e-5 s: the drift of the energy T + V and of the angular momentum (max over the run,
   relative), their observed orders log2(e_h / e_{h/2}) (generalized-α: 2), and the change
   of linear momentum (round-off: the co-rotated forces have no net part).
2. Free vibration in modes 1 and 2 (1 mm), 50 periods at 80 steps per period, without spin
   and spinning at 1 Hz about a skew axis: the FFT peak (Hann window, ×8 zero padding,
   parabolic interpolation of the log-magnitude) of the co-rotated modal coordinate against
   the reduced model's eigenfrequency and against the trapezoidal rule's discrete frequency
   (2/h) arctan(ωh/2) / 2π.

    python workflows/conservation.py [--out docs/conservation.json]

prints both tables and writes the numbers as JSON (well under a minute).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy: one core

import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from common import REPO, log, parser, temporary_folder, write_record

sys.path.insert(0, str(REPO))

from gcms_fenicsx.dynamics.bodies.body import Body, body_from_reduced  # noqa: E402
from gcms_fenicsx.config.scene import parse_scene  # noqa: E402
from gcms_fenicsx.dynamics.run.simulate import modal_history, simulate_body  # noqa: E402
from gcms_fenicsx.references.spectra import peak_frequency_hz  # noqa: E402
from gcms_fenicsx.files.reduced_model import ReducedModel, read_reduced  # noqa: E402

STUDY = """
[geometry]
kind = "beam"
section = "rectangle"
width = 0.03
height = 0.02
length = 0.5

[mesh]
size = 0.012

[modes]
count = 6

[selection]
cosine_tolerance = 1e-12
"""
STEPS_S = (1e-4, 5e-5, 2.5e-5)
SPIN_AXIS = np.array([0.3, 1.0, 0.5])
SPIN_RAD_S = 60.0
VIBRATION_CASES = ((1, 0.0), (1, 1.0), (2, 0.0), (2, 1.0))   # (mode, spin in Hz)
PERIODS, STEPS_PER_PERIOD = 50, 80


def reduced_beam(folder: Path) -> ReducedModel:
    config = folder / "beam.toml"
    config.write_text(STUDY)
    run = subprocess.run([sys.executable, "-m", "gcms_fenicsx.cli", "reduce", str(config),
                          "--out", str(folder)], cwd=REPO, capture_output=True, text=True)
    if run.returncode:
        sys.exit(f"gcms reduce failed:\n{run.stderr}")
    return read_reduced(folder / "reduced.h5")


def spinning(body: Body) -> list[dict]:
    rows = []
    for h in STEPS_S:
        scene = parse_scene({
            "end_time": 0.02, "time_step": h, "rho_inf": 1.0,
            "initial": {"velocity": [0.1, 0.2, -0.3],
                        "angular_velocity": list(SPIN_RAD_S * SPIN_AXIS),
                        "mode": 1, "amplitude": 2e-3},
            "solver": {"tolerance": 1e-13, "max_iterations": 100}})
        t0 = time.perf_counter()
        traj, summary = simulate_body(body, scene)
        wall = time.perf_counter() - t0
        if not summary["complete"]:
            sys.exit(f"spinning body, h = {h:g}: {summary['message']}")
        total = traj.energy["kinetic"] + traj.energy["elastic"]
        p, L = traj.momentum["linear"], traj.momentum["angular"]
        rows.append({
            "time_step_s": h,
            "energy_drift_rel": float(np.abs(total - total[0]).max() / total[0]),
            "angular_momentum_drift_rel": float(np.linalg.norm(L - L[0], axis=1).max()
                                                / np.linalg.norm(L[0])),
            "linear_momentum_change_rel": float(np.linalg.norm(p - p[0], axis=1).max()
                                                / np.linalg.norm(p[0])),
            "newton_iterations_mean": summary["newton_iterations_mean"],
            "wall_time_s": wall,
        })
    for coarse, fine in zip(rows, rows[1:]):
        for key in ("energy_drift_rel", "angular_momentum_drift_rel"):
            fine[key.replace("drift_rel", "order")] = math.log2(coarse[key] / fine[key])
    return rows


def vibration(model: ReducedModel, body: Body) -> list[dict]:
    axis = np.array([0.3, 0.5, 1.0]) / np.linalg.norm([0.3, 0.5, 1.0])
    rows = []
    for mode, spin_hz in VIBRATION_CASES:
        f = float(model.reduced_frequencies_hz[mode - 1])
        h = 1.0 / (STEPS_PER_PERIOD * f)
        scene = parse_scene({
            "end_time": PERIODS / f, "time_step": h, "rho_inf": 1.0,
            "initial": {"angular_velocity": list(2 * math.pi * spin_hz * axis), "mode": mode,
                        "amplitude": 1e-3},
            "outputs": {"coordinates": True}})
        traj, summary = simulate_body(body, scene)
        if not summary["complete"]:
            sys.exit(f"free vibration, mode {mode}: {summary['message']}")
        eta = modal_history(body, traj.coordinates["q"], mode)
        peak = peak_frequency_hz(eta, h)
        discrete = math.atan(math.pi * f * h) / (math.pi * h)
        rows.append({
            "mode": mode, "spin_hz": spin_hz,
            "full_model_hz": float(model.frequencies_hz[mode - 1]),
            "reduced_hz": f, "fft_peak_hz": peak, "rel_error": peak / f - 1,
            "trapezoidal_hz": discrete, "rel_error_vs_trapezoidal": peak / discrete - 1,
            "time_step_s": h, "periods": PERIODS,
        })
    return rows


def main() -> None:
    args = parser(__doc__, out=REPO / "docs" / "conservation.json").parse_args()
    t0 = time.perf_counter()
    with temporary_folder() as tmp:
        log("reducing the beam (gcms reduce)")
        model = reduced_beam(tmp)
    body = body_from_reduced(model)
    log("spinning free body, three time steps")
    spin = spinning(body)
    log("free vibration")
    vib = vibration(model, body)

    print(f"Spinning free body ({body.dofs} coordinates), ω = {SPIN_RAD_S:g}·(0.3, 1, 0.5) "
          "rad/s, mode 1 at 2 mm, 20 ms, ρ∞ = 1")
    print(f"{'h [s]':>9} {'energy drift':>13} {'order':>6} {'ang. mom. drift':>16} {'order':>6} "
          f"{'lin. mom. change':>17} {'Newton it.':>10}")
    for r in spin:
        orders = [f"{r[k]:6.2f}" if k in r else f"{'-':>6}"
                  for k in ("energy_order", "angular_momentum_order")]
        print(f"{r['time_step_s']:9.2e} {r['energy_drift_rel']:13.3e} {orders[0]} "
              f"{r['angular_momentum_drift_rel']:16.3e} {orders[1]} "
              f"{r['linear_momentum_change_rel']:17.2e} {r['newton_iterations_mean']:10.2f}")
    print()
    print(f"Free vibration, {PERIODS} periods, {STEPS_PER_PERIOD} steps per period, ρ∞ = 1")
    print(f"{'mode':>4} {'spin Hz':>7} {'full Hz':>11} {'reduced Hz':>11} {'FFT Hz':>11} "
          f"{'rel. error':>11} {'trapezoid Hz':>12} {'FFT/trap. - 1':>13}")
    for r in vib:
        print(f"{r['mode']:4d} {r['spin_hz']:7.1f} {r['full_model_hz']:11.4f} "
              f"{r['reduced_hz']:11.4f} {r['fft_peak_hz']:11.4f} {r['rel_error']:11.2e} "
              f"{r['trapezoidal_hz']:12.4f} {r['rel_error_vs_trapezoidal']:13.2e}")
    write_record(args.out, {
        "body": {"study": STUDY, "coordinates": body.dofs, "mass_kg": body.total_mass_kg,
                 "max_rel_frequency_error_pruning": model.selection["max_rel_frequency_error"]},
        "spinning": spin, "vibration": vib,
        "wall_time_s": time.perf_counter() - t0}, indent=2, newline=True)
    log(f"wrote {args.out} in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
