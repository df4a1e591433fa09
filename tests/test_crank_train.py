"""The inline-4 crank train (``workflows/crank_train.toml``, docs/assemblies.md): a GCMS
crankshaft in five main bearings, four GCMS conrods of one reduced model, four pistons under
the built-in full-load pressure, spun up from rest to 3000 rpm.

Checked against what nobody here tuned: the energy balance of the whole train, the gas's
work over a cycle at speed against the indicated work of the exact slider-crank kinematics
(``gas_pressure.indicated_work_j``) and the drive taking it out (its mean torque −IMEP V_d /
4π but for the train's energy change); and the plot's families of joints.
"""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

from gcms_fenicsx.app.system_plots import family
from gcms_fenicsx.config.system import parse_system

REPO = Path(__file__).resolve().parents[1]
STUDY = REPO / "workflows" / "crank_train.toml"


def train(**system: float) -> dict:
    raw = tomllib.loads(STUDY.read_text())
    raw["system"].update(system)
    return raw


def test_the_crank_train_study_is_one_crankshaft_four_conrods_of_one_model_four_pistons():
    cfg = parse_system(train(), str(STUDY), STUDY.parent)
    kinds = {b.name: b.kind for b in cfg.bodies}
    assert sorted(kinds.values()) == ["flexible"] * 5 + ["point_mass"] * 4
    conrods = [b for b in cfg.flexible if b.name.startswith("conrod")]
    assert len(conrods) == 4 and len({b.model_key for b in conrods}) == 1
    assert cfg.engine.pistons == ("piston1", "piston2", "piston3", "piston4")
    drive = cfg.crank_drive
    # two four-stroke cycles at speed after the spin-up
    turned = drive.angular_velocity * (cfg.end_time_s - drive.ramp_time_s)
    assert turned == pytest.approx(2 * 4 * math.pi, rel=1e-5)


def test_joint_families_are_names_without_their_number():
    assert family("main_0") == "main" and family("big_end_12") == "big_end"
    assert family("guide") == "guide" and family("pin-2") == "pin" and family("7") == "7"


def test_a_coarse_crank_train_balances_its_energy_and_its_rigid_twin_the_gas_work(tmp_path):
    """The study on coarser meshes (crankshaft 16 mm, conrods 5 mm), its 40 ms spin-up and one
    cycle at speed, elastic and as its rigid twin (every flexible body ``as_rigid``, on the
    same reduced models). Both balance their energy to 1e-3 of the largest energy or work
    (measured 1.0e-4 and 6.7e-5). The rigid twin's pistons follow the exact kinematics, so
    over the cycle the gas does the indicated work of the four cylinders
    (``indicated_work_j``) and the drive's mean torque is −IMEP · V_d / 4π, each to 1e-4 (the
    trapezoidal rules of the run's powers and of the recorded torque; measured 2.9e-5 and
    6e-6). The elastic train's gas work differs by what its deflections move the pistons
    (measured 2.1e-3, asserted 1e-2: the crankshaft rings in torsion); its mean drive torque
    is −(W_gas − ΔE − W_d)/Δθ, ΔE its energy's change and W_d > 0 what the crankshaft's
    damping dissipated, to 1e-2 (the recorded rows' trapezoidal rule over the ringing torque;
    measured 2.4e-4). The same with the crankshaft in the rotor basis (``[basis] kind =
    "rotor"``, the same reduced model) holds as the elastic train does (1.9e-3, 1.2e-4); the
    rigid twin has no damping (W_d = 0)."""
    from mpi4py import MPI

    from gcms_fenicsx.app.commands import system_models
    from gcms_fenicsx.app.system_run import pressure_curve, rigid_twin_study, simulate_system
    from gcms_fenicsx.dynamics.system.gas_pressure import indicated_work_j

    raw = train(end_time=0.08)
    raw["bodies"]["crankshaft"]["mesh"] = {"size": 0.016}
    for k in range(1, 5):
        raw["bodies"][f"conrod{k}"]["mesh"] = {"size": 0.005}
    cfg = parse_system(raw, str(STUDY), STUDY.parent)
    with system_models(cfg, tmp_path, False, MPI.COMM_WORLD, lambda line: None) as built:
        models, stages, _ = built
    assert [stages[f"conrod{k}"] for k in (2, 3, 4)] == [{"model_of": "conrod1"}] * 3
    geometry = {b.name: b.study.plan.body.geometry for b in cfg.flexible}
    drive = cfg.crank_drive
    spin_up, omega = drive.ramp_time_s, drive.angular_velocity
    cycle = indicated_work_j(pressure_curve(cfg.engine), cfg.engine.bore_m,
                             geometry["crankshaft"].stroke / 2, geometry["conrod1"].length)
    raw["bodies"]["crankshaft"]["basis"]["kind"] = "rotor"
    rotor = parse_system(raw, str(STUDY), STUDY.parent)
    for label, study in (("elastic", cfg), ("rigid", rigid_twin_study(cfg)), ("rotor", rotor)):
        folder = tmp_path / label
        folder.mkdir()
        summary = simulate_system(study, models, folder, lambda line: None)
        assert summary["energy_drift_rel"] <= 1e-3, (label, summary["energy_drift_rel"])
        assert summary["bodies"]["crankshaft"].get("basis") == ("rotor" if label == "rotor"
                                                                else None)
        with h5py.File(folder / "system.h5") as f:
            t = f["time_s"][()]
            e = {k: f[f"energy/{k}"][()] for k in f["energy"]}
            torque = f["joints/main_0/drive_torque_nm"][()]
            gas = f["engine/gas_force_n"][()]
        assert gas.shape == (len(t), 4) and gas.max() > 30e3
        at_speed = t >= spin_up - 1e-12
        i0 = int(np.argmax(at_speed))
        turned = omega * (t[-1] - t[i0])
        assert turned == pytest.approx(4 * math.pi, rel=1e-5)
        gas_work = e["load_work"][-1] - e["load_work"][i0]
        total = e["kinetic"] + e["elastic"] + e["gravity"]
        change = total[-1] - total[i0]
        dissipated = e["damping_dissipation"][-1] - e["damping_dissipation"][i0]
        assert (dissipated > 0) == (label != "rigid"), (label, dissipated)
        mean = np.trapz(torque[at_speed], t[at_speed]) / (t[-1] - t[i0])
        if label == "rigid":
            assert gas_work == pytest.approx(4 * cycle, rel=1e-4)
            assert mean == pytest.approx(-4 * cycle / turned, rel=1e-4)
        else:
            assert gas_work == pytest.approx(4 * cycle, rel=1e-2)
            assert mean == pytest.approx(-(gas_work - change - dissipated) / turned, rel=1e-2)


def _window_runs(t: np.ndarray, omega: float, change_from: float) -> dict:
    """Three synthetic window runs (labels as ``crank_train.window``): (a) with a main-bearing
    force and a drive torque ringing at ``omega``; GCMS equal to it before ``change_from``
    and 10 % larger after; the rotor basis 20 % larger throughout."""
    force = np.stack([np.sin(omega * t) + 2.0, np.zeros_like(t), np.zeros_like(t)], axis=1)
    torque = 100.0 * np.sin(omega * t)
    runs = {}
    for label, scale in (("full", 1.0), ("gcms", np.where(t > change_from, 1.1, 1.0)),
                         ("rotor", 1.2)):
        s = np.broadcast_to(scale, t.shape)
        runs[label] = {"time_s": t, "joints": {
            "main_0": {"force_n": force * s[:, None], "drive_torque_nm": torque * s},
            "big_end_1": {"force_n": force * s[:, None]}}}
    return runs


def test_the_comparison_with_reference_a_measures_each_range_and_the_ringing():
    """``crank_train.against_full`` on runs whose errors are known: max_t |GCMS − (a)| / (a)'s
    peak over the window (0.1), to the end of the spin-up (0: GCMS equals (a) there), the rotor
    basis's (0.2), the drive torque's row after the forces; ``window_ringing`` finds a 500 Hz
    ringing to the zero-padded spectrum's resolution and its rms, 100/√2 N·m."""
    import sys
    from types import SimpleNamespace

    sys.path.insert(0, str(REPO / "workflows"))
    import crank_train

    t = np.arange(0.0, 0.12, 5e-5)
    runs = _window_runs(t, 2 * math.pi * 500.0, 0.05)
    rows = crank_train.against_full(runs, 0.04)
    assert list(rows) == ["main_0", "big_end_1", "main_0 drive torque"]
    for row in rows.values():
        assert row["error_rel"] == pytest.approx(0.1, rel=1e-12)
        assert row["rotor_error_rel"] == pytest.approx(0.2, rel=1e-12)
        assert row["spin_up_error_rel"] == 0.0
    cfg = SimpleNamespace(crank_drive=SimpleNamespace(ramp_time_s=0.04),
                          engine=SimpleNamespace(ramp_time_s=0.04, crank_drive="main_0"))
    ringing = crank_train.window_ringing(cfg, runs)
    resolution = 1.0 / (8 * (0.12 - 0.04))
    assert ringing["full_ringing_hz"] == pytest.approx(500.0, abs=resolution)
    assert ringing["full_torque_rms_nm"] == pytest.approx(100.0 / math.sqrt(2), rel=1e-3)
    assert ringing["rotor_torque_rms_nm"] == pytest.approx(1.2 * 100.0 / math.sqrt(2), rel=1e-3)
    short = {k: {"time_s": v["time_s"][t <= 0.05], "joints": v["joints"]} for k, v in runs.items()}
    assert crank_train.window_ringing(cfg, short) == {}
