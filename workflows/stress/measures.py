"""Numbers derived from rows: relative differences, a row against a reference row, the split
of a near-repeated pair, the energy balance error's growth over a run, and the beam-theory
frequencies the finite-element ones are held against."""
from __future__ import annotations

import math

import numpy as np



def rel(a: float | None, b: float | None) -> float | None:
    """|a / b − 1| (None when either is missing)."""
    if a is None or b is None:
        return None
    return abs(a / b - 1.0) if b else (0.0 if a == b else math.inf)


def max_rel(a, b) -> float | None:
    """max |a − b| / |b| over two sequences of one length (None when missing or unequal)."""
    if a is None or b is None or len(a) != len(b) or not len(a):
        return None
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


def pair_split(freqs: list[float], i: int = 0) -> float | None:
    """(f_{i+1} − f_i) / f_i of 0-based mode i, None when there is no mode i + 1."""
    return (freqs[i + 1] - freqs[i]) / freqs[i] if len(freqs) > i + 1 else None


def compare_to(row: dict, ref: dict, scale: float = 1.0) -> None:
    """Differences of ``row`` from ``ref`` (frequencies times ``scale``)."""
    row["same_mesh_size"] = (row["nodes"], row["cells"]) == (ref["nodes"], ref["cells"])
    a, b = np.asarray(row["frequencies_hz"], float) * scale, np.asarray(ref["frequencies_hz"])
    if len(a) == len(b):
        d = np.abs(a / b - 1)
        row["frequency_difference"] = float(d.max())
        row["frequency_difference_mode"] = int(d.argmax()) + 1
        row["frequency_differences"] = d.tolist()
    if "fields_kept" in row and "fields_kept" in ref:
        row["same_fields_kept"] = row["fields_kept"] == ref["fields_kept"]
        row["same_fields_kept_count"] = row["fields_kept_count"] == ref["fields_kept_count"]
        for key in ("cond_mr_before", "cond_mr_after", "cond_phi_before", "cond_phi_after",
                    "pruning_error"):
            row[f"{key}_change"] = rel(row[key], ref[key])
        row["sigma_min_change"] = rel(row["sigma_smallest"][0], ref["sigma_smallest"][0]) \
            if row["sigma_smallest"] and ref["sigma_smallest"] else None
        row["singular_values_difference"] = max_rel(row["singular_values"],
                                                    ref["singular_values"])


def growth_fit(t: np.ndarray, err: np.ndarray, windows: int = 10) -> dict:
    """How the balance error evolves over a run cut into ``windows`` equal windows, the first
    of which (the start-up: release, spin-up) is left out of both fits:

    - ``drift_per_s``: the least-squares slope of the signed error in time, and
      ``drift_share`` = |slope| × (the fitted span) / max|err|: about 0 when the error stays
      flat, near 1 when a steady drift makes most of it;
    - ``growth_exponent``: the largest |err| of each window fitted as a t^p (0: flat, 0.5: a
      random walk, 1: linear growth from zero; an offset left by the start-up lowers it);
    - the largest |err| of the first and the last window."""
    t, e = np.asarray(t, float), np.asarray(err, float)
    a = np.abs(e)
    parts = [k for k in np.array_split(np.arange(len(t)), windows) if len(k)]
    peaks = np.array([a[k].max() for k in parts])
    centres = np.array([t[k].mean() for k in parts])
    use = (np.arange(len(parts)) >= 1) & (peaks > 0) & (centres > 0)
    p = float(np.polyfit(np.log(centres[use]), np.log(peaks[use]), 1)[0]) \
        if use.sum() >= 3 else None
    late = t >= t[parts[1][0]] if len(parts) > 1 else np.ones_like(t, bool)
    slope = float(np.polyfit(t[late], e[late], 1)[0]) if late.sum() > 3 else None
    span = float(t[late][-1] - t[late][0]) if late.any() else 0.0
    return {"growth_exponent": p, "drift_per_s": slope,
            "drift_share": (abs(slope) * span / a.max() if slope is not None and a.max() > 0
                            else None),
            "max_first_tenth": float(peaks[0]), "max_last_tenth": float(peaks[-1]),
            "window_maxima": peaks.tolist(), "max": float(a.max()), "end": float(a[-1])}


def downsample(t: np.ndarray, y: np.ndarray, n: int = 400) -> dict:
    """At most ``n`` evenly spread samples of the curve (t, y), first and last kept."""
    idx = np.unique(np.linspace(0, len(t) - 1, min(n, len(t))).round().astype(int))
    return {"t": np.asarray(t)[idx].tolist(), "y": np.asarray(y)[idx].tolist()}


def beam_references(E: float, nu: float, rho: float, b: float, h: float, L: float,
                    n: int = 1) -> dict:
    """n-th free-free bending of a b × h rectangle about the axis of h (displacement along h):
    Euler–Bernoulli and Timoshenko (Cowper κ), from gcms_fenicsx/references/beam_theory.py.

    Beyond L/h = 100 the Timoshenko value is f_EB (1 − C (h/L)²) with C from the same section
    at L/h = 100: the correction's leading term, whose next one, O((h/L)⁴), is about 1e-7 at
    L/h = 100 and 1e-11 at 1000. beam_theory's own value degrades there: its shift-invert
    (shift 1e-3 of the first bending eigenvalue) is lost against the shear stiffness
    κGA/Δx of its 4000 elements, so it moves by 1e-7 between calls at L/h = 200 (ARPACK's
    random start), differs from the leading term by 5e-7 at 200 and 1e-6 at 400, and SuperLU
    finds it exactly singular at 300, 500 and 1000."""
    from gcms_fenicsx.references.beam_theory import (cowper_kappa, euler_bernoulli_hz,
                                                     timoshenko_hz)
    A, I = b * h, b * h ** 3 / 12
    kappa = cowper_kappa("rectangle", nu)
    eb = float(euler_bernoulli_hz(n, E, I, rho, A, L))
    if L / h <= 100:
        return {"euler_bernoulli_hz": eb, "timoshenko_method": "beam_theory.timoshenko_hz",
                "timoshenko_hz": float(timoshenko_hz(n, E, nu, kappa, rho, A, I, L))}
    L100 = 100 * h
    C = (1 - timoshenko_hz(n, E, nu, kappa, rho, A, I, L100)
         / euler_bernoulli_hz(n, E, I, rho, A, L100)) * 100 ** 2
    return {"euler_bernoulli_hz": eb, "timoshenko_method": "f_EB (1 - C (h/L)^2), C at L/h = 100",
            "timoshenko_hz": float(eb * (1 - C * (h / L) ** 2))}
