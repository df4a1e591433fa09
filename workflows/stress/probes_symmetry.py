"""Probe classes 1 and 2 on the steel square beam (30 mm, 0.5 m): symmetry perturbation (the
beam widened by ε, its pendulum swing against ε = 0, a mode count that cuts a near-repeated
pair, the square section against the rectangle of equal sides) and units and size (SI
against mm-t-s, the body scaled by 1e-3 and 1e3)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from stress.measures import compare_to, pair_split, rel
from stress.readers import (both, peak_stresses, read_modes, read_selection, read_summary,
                            tip_positions)
from stress.runner import gcms
from stress.studies import (BEAM_LENGTH_M, CUT_PAIR_MODES, EPSILONS, SQUARE_MODES, mm_t_s,
                            square_beam, swinging_square_beam)
from stress.suite import Suite


def read_swing(out: Path) -> dict:
    """Modes, selection and summary of a swinging beam, and its first bending pair's split."""
    row = both(read_modes, read_selection, read_summary)(out)
    row["pair_split"] = pair_split(row["frequencies_hz"])
    return row


def tip_gap(a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance between two tip trajectories over time, over the beam's length."""
    return float(np.linalg.norm(a - b, axis=1).max() / BEAM_LENGTH_M)


def swing(suite: Suite, eps: float, count: int, name: str, case: str,
          tips: dict[float, np.ndarray], **extra) -> dict | None:
    """`gcms run` of the beam widened by ``eps`` with ``count`` modes swinging: its row (None
    when it has no result), its tip trajectory kept in ``tips[eps]`` (a failure to read it
    the row's ``read_error``)."""
    run = gcms("run", swinging_square_beam(1.0 + eps, count), suite.path(name))
    row = suite.probe("symmetry", case, run, read_swing, epsilon=eps, **extra)
    if not run.ok or "read_error" in row:
        return None
    try:
        tips[eps] = tip_positions(run.out)
    except Exception as exc:  # noqa: BLE001
        row["read_error"] = f"results.h5: {type(exc).__name__}: {exc}"
    return row


def compare_tips(row: dict, tips: dict[float, np.ndarray], eps: float) -> None:
    """The tip trajectory at ``eps`` against ε = 0 in ``row``, when both were read."""
    if eps in tips and 0.0 in tips and tips[eps].shape == tips[0.0].shape:
        row["tip_difference_over_L"] = tip_gap(tips[eps], tips[0.0])


def symmetry(suite: Suite) -> None:
    """Class 1: the beam widened by each ε, a mode count cutting a pair, the square section."""
    tips: dict[float, np.ndarray] = {}
    ref = None
    for eps in ((0.0, 1e-6, 0.1) if suite.quick else EPSILONS):
        row = swing(suite, eps, SQUARE_MODES, f"symmetry_eps{eps:g}", f"ε = {eps:g}", tips)
        if row is None:
            continue
        if eps == 0.0:
            ref = row
        elif ref is not None:
            compare_to(row, ref)
            compare_tips(row, tips, eps)
    # Nm = 6 cuts the third bending pair (modes 6 and 7, split by the mesh's asymmetry only):
    # which member the reduced model gets depends on the mesh, and so on ε
    cut: dict[float, np.ndarray] = {}
    for eps in (0.0, 1e-6):
        row = swing(suite, eps, CUT_PAIR_MODES, f"symmetry_cut_eps{eps:g}",
                    f"Nm = {CUT_PAIR_MODES}: ε = {eps:g}", cut, modes=CUT_PAIR_MODES)
        if row is not None and eps:
            compare_tips(row, cut, eps)
    # the square section itself against the rectangle of equal sides
    run = gcms("reduce", square_beam(section="square"), suite.path("symmetry_square"))
    row = suite.probe("symmetry", "square section", run, both(read_modes, read_selection),
                      epsilon=0.0)
    if ref is not None and run.ok and "read_error" not in row:
        compare_to(row, ref)
        row["pair_split"] = pair_split(row["frequencies_hz"])


def units(suite: Suite) -> None:
    """Class 2: the swinging beam in SI and in mm-t-s (with every surface node's stresses),
    the beam scaled by 1e-3 and 1e3 (with the swing's scene, so with the same attachment
    modes as the SI study)."""
    reader = both(read_modes, read_selection)
    si_study = swinging_square_beam()
    si_study["scene"]["outputs"]["stress_groups"] = "surface"
    si = gcms("run", si_study, suite.path("units_SI"))
    ref = suite.probe("units", "SI", si, both(reader, read_summary), scale=1.0)
    ok = si.ok and "read_error" not in ref
    mm = gcms("run", mm_t_s(si_study), suite.path("units_mm"))
    row = suite.probe("units", "mm-t-s", mm, both(reader, read_summary), scale=1.0)
    if ok and mm.ok and "read_error" not in row:
        compare_to(row, ref)
        try:
            row["tip_difference_over_L"] = tip_gap(tip_positions(si.out),
                                                   tip_positions(mm.out) / 1e3)
            si_peak, mm_peak = peak_stresses(si.out), peak_stresses(mm.out)
            row["stress_difference"] = float(np.abs(1e6 * mm_peak - si_peak).max()
                                             / si_peak.max())
        except Exception as exc:  # noqa: BLE001
            row["read_error"] = f"results.h5: {type(exc).__name__}: {exc}"
        row["energy_drift_change"] = rel(row["energy_drift_rel"], ref["energy_drift_rel"])
    for scale in (1e-3, 1e3):
        # the SI study's scene, for the same attachment modes (its joint holds a group, not
        # lengths; ``gcms reduce`` does not run it)
        scaled = dict(square_beam(scale=scale), scene=si_study["scene"])
        run = gcms("reduce", scaled, suite.path(f"units_size{scale:g}"))
        row = suite.probe("units", f"size ×{scale:g}", run, reader, scale=scale)
        if ok and run.ok and "read_error" not in row:
            compare_to(row, ref, scale=scale)  # f ∝ 1/size at the same material
