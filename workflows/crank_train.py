"""The inline-4 crank train (workflows/crank_train.toml) against its rigid twin, with its
crankshaft in the rotor basis and, over a window from the start, with it full order.

Four comparisons of the study as written (GCMS crankshaft and conrods, point-mass pistons;
``gcms run workflows/crank_train.toml`` steps the same):

- its energy balance (``energy_drift_rel``) and a work balance nobody tuned: over the two
  cycles at speed the gas does the indicated work ∮ (p − 1 bar) A dx_p of each cylinder
  (``gas_pressure.indicated_work_j``: the exact slider-crank kinematics), and the
  drive takes it out — its mean torque is −(W_gas − ΔE − W_d)/Δθ, ΔE the change of the
  train's kinetic, elastic and gravity energy, W_d what the crankshaft's damping dissipated;
- the rigid twin (every flexible body ``as_rigid``: its mesh's mass, centre of mass,
  inertia and node groups' centres): the big-end, small-end and side forces per cylinder,
  the crankshaft's total bearing force and the drive torque, max_t |flexible − rigid| over
  the rigid peak — the difference is the elasticity (a rigid shaft in five bearings is
  statically indeterminate: its own bearing forces are not, so only their sum is compared);
- the crankshaft in the rotor basis (``[basis] kind = "rotor"``, ``system.rotor_member``):
  the same forces against the full basis over the run, and the frequency the drive torque
  rings at once at speed in each;
- reference (a) (unless ``--no-full-order``): the train from its start to ``--window`` (the
  spin-up and the first firing) as it is, with the crankshaft in the rotor basis, and with
  it full order (``app.system_run.full_order_body``: every node of its mesh, 82k
  coordinates, a sparse LU) — each main-bearing and big-end force and the drive torque,
  max over the window of |GCMS − (a)| over (a)'s peak there (``--window 0.12``: the whole
  run, about 20 minutes; the record's), for a window past the spin-up also to its end, and
  the drive torque's frequency and rms at speed in each.

    python workflows/crank_train.py [--out docs] [--study workflows/crank_train.toml]
                                    [--window 0.032] [--no-full-order]

Writes OUT/crank_train.json (the runs' settings, speeds and drifts, the comparisons), .md
(the tables) and .png (forces and drive torque, flexible and rigid; the window against (a)).
One BLAS thread; the bodies' stages and the three runs take about a minute, (a) about five more
(twenty with ``--window 0.12``).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, table_row
from common import run_interruptibly, temporary_folder, write_markdown, write_record

HERE = Path(__file__).resolve().parent


def arguments() -> Any:
    p = parser(__doc__, out="docs", out_help="folder of crank_train.json, .md and .png")
    p.add_argument("--study", type=Path, default=HERE / "crank_train.toml",
                   help="the crank train's system study")
    p.add_argument("--window", type=float, default=0.032,
                   help="s: reference (a) runs from the start to here (the first firing "
                        "peaks at 30.6 ms)")
    p.add_argument("--no-full-order", action="store_true", help="skip reference (a)")
    args = p.parse_args()
    if not args.study.is_file():
        p.error(f"--study {args.study}: no such file")
    if not args.window > 0:
        p.error(f"--window must be positive (s), got {args.window}")
    return args


def load(path: Path) -> Any:
    """The system study (refused unless it has an engine driven by a crank drive)."""
    from gcms_fenicsx.app.system_run import load_system, system_file

    raw = system_file(path)
    if raw is None:
        raise SystemExit(f"crank_train: {path} is not a system study")
    cfg = load_system(path, raw)
    if cfg.engine is None:
        raise SystemExit(f"crank_train: {path} has no [engine]")
    return cfg


def series(folder: Path) -> dict:
    """What the comparisons read of a run's system.h5 and summary."""
    import h5py

    with h5py.File(folder / "system.h5", "r") as f:
        out = {"time_s": f["time_s"][()],
               "energy": {k: f[f"energy/{k}"][()] for k in f["energy"]},
               "joints": {name: {k: entry[k][()] for k in entry}
                          for name, entry in f["joints"].items()}}
    return out


def simulate(cfg: Any, models: dict, folder: Path) -> dict:
    """A run of ``cfg`` (``app.system_run.simulate_system``) into ``folder``: its summary and
    series."""
    from gcms_fenicsx.app.system_run import simulate_system

    folder.mkdir(parents=True, exist_ok=True)
    summary = simulate_system(cfg, models, folder, log)
    if not summary["complete"]:
        raise SystemExit(f"crank_train: the run stopped early: {summary['message']}")
    return {"summary": summary, **series(folder)}


def families(joints: dict, stem: str) -> list[str]:
    """The joints of one family (``system_plots.family``: names without their number)."""
    from gcms_fenicsx.app.system_plots import family

    return sorted(name for name in joints if family(name) == stem)


def bearing_total(run: dict) -> np.ndarray:
    """The crankshaft's total bearing force (N): the main bearings' sum."""
    return sum(run["joints"][name]["force_n"] for name in families(run["joints"], "main"))


def error_rel(value: np.ndarray, reference: np.ndarray) -> float:
    """max_t |value − reference| / max_t |reference| (vectors: their norms)."""
    diff, ref = np.asarray(value - reference), np.asarray(reference)
    if ref.ndim == 2:
        diff, ref = np.linalg.norm(diff, axis=1), np.linalg.norm(ref, axis=1)
    return float(np.abs(diff).max() / np.abs(ref).max())


def peak(value: np.ndarray) -> float:
    value = np.asarray(value)
    return float((np.linalg.norm(value, axis=1) if value.ndim == 2 else np.abs(value)).max())


def indicated_work_j(cfg: Any) -> float:
    """One cylinder's gas work over a cycle (``gas_pressure.indicated_work_j``: the exact
    kinematics of the crankshaft's stroke and the conrod's length)."""
    from gcms_fenicsx.app.system_run import pressure_curve
    from gcms_fenicsx.dynamics.system import gas_pressure

    crank = next(b for b in cfg.flexible if b.study.plan.body.geometry.kind == "crankshaft")
    rod = next(b for b in cfg.flexible if b.study.plan.body.geometry.kind == "conrod")
    return gas_pressure.indicated_work_j(pressure_curve(cfg.engine), cfg.engine.bore_m,
                                         crank.study.plan.body.geometry.stroke / 2.0,
                                         rod.study.plan.body.geometry.length)


def at_speed(cfg: Any) -> float:
    """The time the crank drive and the gas forces have risen in."""
    drive = cfg.crank_drive
    return max(drive.ramp_time_s, cfg.engine.ramp_time_s)


def work_balance(cfg: Any, run: dict) -> dict:
    """Gas work and mean drive torque over [at_speed, end] against the indicated work; the
    drive's work is the train's energy change and what damping dissipated, less the gas's."""
    t, e = run["time_s"], run["energy"]
    drive = run["joints"][cfg.engine.crank_drive]["drive_torque_nm"]
    inside = t >= at_speed(cfg) - 1e-12
    i0 = int(np.argmax(inside))
    omega = cfg.crank_drive.angular_velocity
    turned = omega * (t[-1] - t[i0])
    cycles = turned / (4.0 * math.pi)
    gas = float(e["load_work"][-1] - e["load_work"][i0])
    total = e["kinetic"] + e["elastic"] + e["gravity"]
    change = float(total[-1] - total[i0])
    dissipated = float(e["damping_dissipation"][-1] - e["damping_dissipation"][i0])
    expected = len(cfg.engine.pistons) * cycles * indicated_work_j(cfg)
    mean = float(np.trapz(drive[inside], t[inside]) / (t[-1] - t[i0]))
    return {"from_s": float(t[i0]), "cycles": cycles, "gas_work_j": gas,
            "indicated_work_j": expected, "gas_work_error_rel": gas / expected - 1.0,
            "energy_change_j": change, "damping_dissipation_j": dissipated,
            "mean_drive_torque_nm": mean, "expected_mean_drive_torque_nm": -expected / turned,
            "mean_drive_torque_error_rel": mean / (-(gas - change - dissipated) / turned) - 1.0}


def against_rigid(flexible: dict, rigid: dict) -> dict:
    """Each cylinder's joint forces, the total bearing force and the drive torque: peaks of
    both and max_t |flexible − rigid| / rigid peak (the recorded rows are the same times)."""
    rows: dict[str, dict] = {}
    for stem in ("big_end", "small_end", "bore"):
        for name in families(rigid["joints"], stem):
            a, b = flexible["joints"][name]["force_n"], rigid["joints"][name]["force_n"]
            rows[name] = {"flexible_peak": peak(a), "rigid_peak": peak(b),
                          "difference_rel": error_rel(a, b)}
    a, b = bearing_total(flexible), bearing_total(rigid)
    rows["main bearings, total"] = {"flexible_peak": peak(a), "rigid_peak": peak(b),
                                    "difference_rel": error_rel(a, b)}
    drive = next(n for n, j in rigid["joints"].items() if "drive_torque_nm" in j)
    a, b = (flexible["joints"][drive]["drive_torque_nm"], rigid["joints"][drive]["drive_torque_nm"])
    rows[f"{drive} drive torque"] = {"flexible_peak": peak(a), "rigid_peak": peak(b),
                                     "difference_rel": error_rel(a, b), "unit": "N·m"}
    return rows


def crankshaft(cfg: Any) -> str:
    return next(b.name for b in cfg.flexible if b.study.plan.body.geometry.kind == "crankshaft")


def in_rotor_basis(path: Path, cfg: Any) -> Any:
    """The study with its crankshaft in the rotor basis (the same reduced model)."""
    from gcms_fenicsx.app.system_run import load_system, system_file

    raw = system_file(path)
    raw["bodies"][crankshaft(cfg)].setdefault("basis", {})["kind"] = "rotor"
    return load_system(path, raw)


def ringing_hz(run: dict, drive: str, from_s: float) -> float:
    """The frequency of the drive torque's largest peak above 200 Hz at speed (its spectrum
    from ``from_s`` on, Hann-windowed, zero-padded eight-fold)."""
    t = run["time_s"]
    x = run["joints"][drive]["drive_torque_nm"][t >= from_s]
    x = (x - x.mean()) * np.hanning(len(x))
    spectrum = np.abs(np.fft.rfft(x, 8 * len(x)))
    frequency = np.fft.rfftfreq(8 * len(x), t[1] - t[0])
    above = frequency > 200.0
    return float(frequency[above][np.argmax(spectrum[above])])


def against_full_basis(cfg: Any, flexible: dict, rotor: dict) -> dict:
    """The crankshaft in the rotor basis against the full one: each family's largest
    max_t |rotor − full| / full peak, and the frequency the drive torque rings at."""
    rows: dict[str, Any] = {}
    for stem in ("main", "big_end", "small_end", "bore"):
        rows[stem] = max(error_rel(rotor["joints"][n]["force_n"], flexible["joints"][n]["force_n"])
                         for n in families(flexible["joints"], stem))
    drive = cfg.engine.crank_drive
    rows["drive torque"] = error_rel(rotor["joints"][drive]["drive_torque_nm"],
                                     flexible["joints"][drive]["drive_torque_nm"])
    rows["ringing_hz"] = {label: ringing_hz(run, drive, at_speed(cfg))
                          for label, run in (("full", flexible), ("rotor", rotor))}
    return rows


def window(cfg: Any, rotor_cfg: Any, models: dict, folder: Path, end_s: float) -> dict:
    """The train from its start to ``end_s`` as it is, with the crankshaft in the rotor basis
    and with it full order (``app.system_run.full_order_body``), every step recorded."""
    from gcms_fenicsx.app.system_run import (build_system, full_order_body, joint_forces,
                                             start_velocity)
    from gcms_fenicsx.dynamics.system.march import march
    from gcms_fenicsx.dynamics.system.stepper import initial_state

    name = crankshaft(cfg)
    log(f"reference (a): the {name}'s full-order model")
    full = {name: full_order_body(cfg.body(name), folder, log)}
    joints = {j.name for j in cfg.joints}
    runs = {}
    for label, study, replaced in (("gcms", cfg, None), ("rotor", rotor_cfg, None),
                                   ("full", cfg, full)):
        made, assembly, stepper = build_system(study, models, replaced)
        log(f"reference (a): to t = {end_s:g} s, {label} ({assembly.dofs} coordinates)")
        begun = time.perf_counter()
        run = march(stepper, initial_state(stepper, start_velocity(study, made)), end_s,
                    progress=log)
        runs[label] = {"time_s": run.time_s, "coordinates": assembly.dofs,
                       "wall_time_s": time.perf_counter() - begun,
                       "energy_drift_rel": run.energy_drift_rel,
                       "joints": joint_forces(assembly, run.multipliers, joints)}
    return runs


def against_full(runs: dict, spin_up_s: float) -> dict:
    """Each main-bearing and big-end force and the drive torque over the window: (a)'s peak
    and max |GCMS − (a)| / that peak, with the crankshaft in the full and in the rotor basis;
    for a window past the spin-up, the full basis's also to its end (``spin_up_error_rel``)."""
    gcms, rotor, full = (runs[k]["joints"] for k in ("gcms", "rotor", "full"))
    early = runs["full"]["time_s"] <= spin_up_s + 1e-12
    past = not early.all()
    rows: dict[str, dict] = {}
    forces = families(full, "main") + families(full, "big_end")
    torques = [name for name, entry in full.items() if "drive_torque_nm" in entry]
    for name, key in [(n, "force_n") for n in forces] + [(n, "drive_torque_nm") for n in torques]:
        ref = full[name][key]
        row = {"full_peak": peak(ref), "error_rel": error_rel(gcms[name][key], ref),
               "rotor_error_rel": error_rel(rotor[name][key], ref)}
        if past:
            row["spin_up_error_rel"] = error_rel(gcms[name][key][early], ref[early])
        if key == "force_n":
            rows[name] = row
        else:
            rows[f"{name} drive torque"] = row | {"unit": "N·m"}
    return rows


def window_ringing(cfg: Any, runs: dict) -> dict:
    """For a window reaching 20 ms past the spin-up, the drive torque at speed in each run:
    the frequency it rings at (``ringing_hz``) and its rms about its mean ({} otherwise)."""
    start = at_speed(cfg)
    if runs["full"]["time_s"][-1] < start + 0.02:
        return {}
    drive, out = cfg.engine.crank_drive, {}
    for label, run in runs.items():
        torque = run["joints"][drive]["drive_torque_nm"][run["time_s"] >= start]
        out[f"{label}_ringing_hz"] = ringing_hz(run, drive, start)
        out[f"{label}_torque_rms_nm"] = float(np.sqrt(np.mean((torque - torque.mean()) ** 2)))
    return out


def tables(result: dict) -> str:
    """The Markdown of crank_train.md."""
    runs, work = result["runs"], result["work_balance"]
    lines = table_head("run", "coordinates", "steps", "steps/s", "Newton/step", "energy drift",
                       "dropped rows")
    for label, s in runs.items():
        lines.append(table_row(label, s["coordinates"], s["steps"],
                               f"{s['steps_per_second']:,.0f}",
                               f"{s['newton_iterations_mean']:.2f}",
                               f"{s['energy_drift_rel']:.1e}", len(s["dropped_rows"])))
    lines += ["", f"Work over the {work['cycles']:.2f} cycles at speed (from "
              f"{work['from_s'] * 1e3:g} ms): the gas's {work['gas_work_j']:.1f} J against the "
              f"indicated work of the exact kinematics {work['indicated_work_j']:.1f} J "
              f"({work['gas_work_error_rel']:+.1e}); mean drive torque "
              f"{work['mean_drive_torque_nm']:.1f} N·m (−IMEP·V_d/4π: "
              f"{work['expected_mean_drive_torque_nm']:.1f} N·m; with the train's energy "
              f"change {work['energy_change_j']:+.2f} J and its damping's dissipation "
              f"{work['damping_dissipation_j']:.2f} J, −(W_gas − ΔE − W_d)/Δθ to "
              f"{work['mean_drive_torque_error_rel']:+.1e}).", "",
              "Flexible against rigid (the difference is the elasticity):", ""]
    lines += table_head("quantity", "flexible peak", "rigid peak", "max |flexible − rigid| / "
                        "rigid peak")
    for name, row in result["rigid"].items():
        unit = row.get("unit", "kN")
        scale = 1.0 if unit == "N·m" else 1e-3
        lines.append(table_row(name, f"{row['flexible_peak'] * scale:,.2f} {unit}",
                               f"{row['rigid_peak'] * scale:,.2f} {unit}",
                               f"{row['difference_rel']:.2%}"))
    b = result["rotor"]
    lines += ["", f"The crankshaft in the rotor basis ({runs['rotor']['coordinates']:,} "
              f"coordinates of the train's) against the full basis over the run, the largest "
              f"max_t |rotor − full| / full peak of each family: main bearings {b['main']:.1%}, "
              f"big ends {b['big_end']:.1%}, small ends {b['small_end']:.1%}, side thrust "
              f"{b['bore']:.1%}, drive torque {b['drive torque']:.1%}; the drive torque rings "
              f"at {b['ringing_hz']['full']:.0f} Hz in the full basis and "
              f"{b['ringing_hz']['rotor']:.0f} Hz in the rotor basis."]
    if "full" in result:
        lines += window_tables(result)
    return "\n".join(lines) + "\n"


def window_tables(result: dict) -> list[str]:
    """The Markdown lines of the comparison with reference (a)."""
    w, rows = result["window"], result["full"]
    spin_up = any("spin_up_error_rel" in row for row in rows.values())
    lines = ["", f"Reference (a), from the start to {w['end_s'] * 1e3:g} ms: the crankshaft full "
             f"order ({w['full_coordinates']:,} coordinates, {w['full_wall_time_s']:.0f} s) "
             f"against GCMS ({w['gcms_coordinates']:,} coordinates, "
             f"{w['gcms_wall_time_s']:.1f} s); energy drift (a) "
             f"{w['full_energy_drift_rel']:.1e}, GCMS {w['gcms_energy_drift_rel']:.1e}; max_t "
             f"|GCMS − (a)| / (a) peak over the window" +
             (f" and to the end of the spin-up ({result['work_balance']['from_s'] * 1e3:g} ms)"
              if spin_up else "") + ":", ""]
    head = ["quantity", "(a) peak", "GCMS", "GCMS, crankshaft in the rotor basis"]
    lines += table_head(*head, *(["GCMS to the end of the spin-up"] if spin_up else []))
    for name, row in rows.items():
        unit = row.get("unit", "kN")
        scale = 1.0 if unit == "N·m" else 1e-3
        cells = [f"{row['full_peak'] * scale:,.2f} {unit}", f"{row['error_rel']:.2%}",
                 f"{row['rotor_error_rel']:.2%}"]
        lines.append(table_row(name, *cells, *([f"{row['spin_up_error_rel']:.2%}"]
                                                if spin_up else [])))
    if "full_ringing_hz" in w:
        lines += ["", "The drive torque at speed: its largest frequency above 200 Hz and its rms "
                  f"about its mean: (a) {w['full_ringing_hz']:.0f} Hz, "
                  f"{w['full_torque_rms_nm']:.0f} N·m; GCMS {w['gcms_ringing_hz']:.0f} Hz, "
                  f"{w['gcms_torque_rms_nm']:.0f} N·m; rotor basis {w['rotor_ringing_hz']:.0f} "
                  f"Hz, {w['rotor_torque_rms_nm']:.0f} N·m."]
    return lines


def plot(result: dict, path: Path) -> None:
    """Cylinder 1's big-end force, the total bearing force and the drive torque, flexible and
    rigid; over the window of (a), the drive torque and the main-bearing force GCMS is
    furthest from: (a), GCMS and the rotor basis."""
    plt = pyplot()
    panels = 5 if "window_series" in result else 3
    fig, axes = plt.subplots(panels, 1, figsize=(8, 2.3 * panels))
    flexible, rigid = result["series"]["flexible"], result["series"]["rigid"]
    t = flexible["time_s"] * 1e3
    big = families(rigid["joints"], "big_end")[0]
    drive = next(n for n, j in rigid["joints"].items() if "drive_torque_nm" in j)
    for label, run, style in (("flexible", flexible, "C0-"), ("rigid", rigid, "k--")):
        axes[0].plot(t, np.linalg.norm(run["joints"][big]["force_n"], axis=1) / 1e3, style,
                     lw=1, label=label)
        axes[1].plot(t, np.linalg.norm(bearing_total(run), axis=1) / 1e3, style, lw=1,
                     label=label)
        axes[2].plot(t, run["joints"][drive]["drive_torque_nm"], style, lw=1, label=label)
    axes[0].set_ylabel(f"{big} |F| (kN)")
    axes[1].set_ylabel("Σ main |F| (kN)")
    axes[2].set_ylabel(f"{drive} drive\ntorque (N·m)")
    axes[2].set_xlabel("t (ms)")
    if panels == 5:
        runs = result["window_series"]
        mains = families(runs["full"]["joints"], "main")
        worst = max(mains, key=lambda name: result["full"][name]["error_rel"])
        for label, style in (("full", "k-"), ("gcms", "C0-"), ("rotor", "C1:")):
            run = runs[label]
            tw, joints = run["time_s"] * 1e3, run["joints"]
            name = {"full": "(a)", "gcms": "GCMS", "rotor": "GCMS, rotor basis"}[label]
            axes[3].plot(tw, joints[drive]["drive_torque_nm"], style, lw=1, label=name)
            axes[4].plot(tw, np.linalg.norm(joints[worst]["force_n"], axis=1) / 1e3, style,
                         lw=1, label=name)
        axes[3].set_ylabel(f"{drive} drive\ntorque (N·m)")
        axes[4].set_ylabel(f"{worst} |F| (kN)")
        axes[4].set_xlabel("t (ms): the window of reference (a)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=5, loc="upper left")
    save_figure(fig, path)


def summary_row(summary: dict) -> dict:
    keys = ("coordinates", "steps", "wall_time_s", "steps_per_second", "newton_iterations_mean",
            "energy_drift_rel", "velocity_change_rel", "dropped_rows")
    return {k: summary[k] for k in keys}


def main() -> None:
    args = arguments()
    quiet()
    from mpi4py import MPI

    from gcms_fenicsx.app.commands import system_models
    from gcms_fenicsx.app.system_run import rigid_twin_study

    cfg = load(args.study)
    with temporary_folder("crank_train_") as work:
        with system_models(cfg, work, False, MPI.COMM_WORLD, log) as (models, _, _):
            pass                                # the bodies' stages, published in work
        log("the train as written")
        flexible = simulate(cfg, models, work / "flexible")
        log("its rigid twin")
        rigid = simulate(rigid_twin_study(cfg), models, work / "rigid")
        log("the crankshaft in the rotor basis")
        rotor_cfg = in_rotor_basis(args.study, cfg)
        rotor = simulate(rotor_cfg, models, work / "rotor")
        result: dict = {
            "runs": {"flexible": summary_row(flexible["summary"]),
                     "rigid": summary_row(rigid["summary"]),
                     "rotor": summary_row(rotor["summary"])},
            "work_balance": work_balance(cfg, flexible),
            "rigid_work_balance": work_balance(cfg, rigid),
            "rigid": against_rigid(flexible, rigid),
            "rotor": against_full_basis(cfg, flexible, rotor),
            "series": {"flexible": flexible, "rigid": rigid}}
        if not args.no_full_order:
            runs = window(cfg, rotor_cfg, models, work / "full_order", args.window)
            result["full"] = against_full(runs, at_speed(cfg))
            result["window_series"] = runs
            result["window"] = {
                "end_s": float(runs["full"]["time_s"][-1]),
                **{f"{label}_{key}": runs[label][key] for label in runs
                   for key in ("coordinates", "wall_time_s", "energy_drift_rel")},
                **window_ringing(cfg, runs)}
    write(result, args)


def write(result: dict, args: Any) -> None:
    """crank_train.json, .md and .png in ``args.out``."""
    out = Path(args.out)
    document = {key: result[key] for key in ("runs", "work_balance", "rigid_work_balance",
                                             "rigid", "rotor", "window", "full") if key in result}
    document["study"] = str(args.study)
    flexible = result["series"]["flexible"]
    document["time_s"] = flexible["time_s"].tolist()
    record = write_record(out / "crank_train.json", document)["record"]
    text = tables(result)
    write_markdown(out / "crank_train.md", "# The inline-4 crank train\n\n" + text, record)
    plot(result, out / "crank_train.png")
    print(text)


if __name__ == "__main__":
    run_interruptibly(main, "--out")
