"""The rows as tables: which rows are good (a result read) and which BROKEN, the cells of
each probe class's columns and its Markdown table (printed and in docs/stability.md)."""
from __future__ import annotations

import math
from collections.abc import Callable


def good(rows: list[dict]) -> list[dict]:
    """The rows of a result that was read."""
    return [r for r in rows if r["outcome"] == "ok" and "read_error" not in r]


def broken(rows: list[dict]) -> list[dict]:
    """The rows of commands that broke their contract."""
    return [r for r in rows if r["outcome"] == "BROKEN"]


def f(v, spec: str = ".2e") -> str:
    """A table cell: "" for None, yes/no for a boolean, ``spec`` for a finite number."""
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return format(v, spec)


def ending(r: dict) -> str:
    """The exit status, with the outcome when not ok and "(unread)" after a reading failure."""
    text = f"{r['exit_status']}" if r["outcome"] == "ok" else f"{r['exit_status']} {r['outcome']}"
    return text + (" (unread)" if "read_error" in r else "")


def dropped(r: dict) -> str:
    """The fields dropped by the selection with stage and relative residual ("none")."""
    return ", ".join(f"{d.get('field')} ({d.get('stage')}, {f(d.get('relative_residual'), '.0e')})"
                     for d in r.get("fields_dropped", [])) or "none"


def smallest_margin(r: dict) -> str:
    """The smallest verification margin (limit / measured) and its check ("" when none)."""
    m = {k: v for k, v in r.get("margins", {}).items() if v is not None and k != "sylvester"}
    if not m:
        return ""
    k = min(m, key=m.get)
    return f"{m[k]:.1e} ({k})"


def two(r: dict, sep: str, a: tuple[str, str], b: tuple[str, str],
        when: str | None = None) -> str:
    """Two cells of ``r`` in one, each (key, spec), joined by ``sep`` ("" when the row lacks
    ``when``)."""
    if when is not None and when not in r:
        return ""
    return f"{f(r.get(a[0]), a[1])}{sep}{f(r.get(b[0]), b[1])}"


#: The columns every class ends with, and each class's columns (header, cell of a row).
COMMON = [("exit", ending), ("wall s", lambda r: f(r["wall_s"], ".1f"))]
COLUMNS: dict[str, list[tuple[str, Callable[[dict], str]]]] = {
    "symmetry": [
        ("case", lambda r: r["case"]), ("nodes", lambda r: f(r.get("nodes"), "d")),
        ("fields kept", lambda r: f(r.get("fields_kept_count"), "d")),
        ("dropped (stage, residual)", lambda r: dropped(r) if "fields_kept" in r else ""),
        ("3 smallest σ", lambda r: ", ".join(f(s, ".1e") for s in r.get("sigma_smallest", []))),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("bending pair split", lambda r: f(r.get("pair_split"), ".1e")),
        ("freq. change vs ε = 0: max (mode), f₁, f₂", lambda r: (
            f"{f(r['frequency_difference'], '.1e')} ({r['frequency_difference_mode']}), "
            f"{f(r['frequency_differences'][0], '.1e')}, {f(r['frequency_differences'][1], '.1e')}"
            if "frequency_differences" in r else "")),
        ("tip difference / L", lambda r: f(r.get("tip_difference_over_L"), ".1e")),
        *COMMON],
    "units": [
        ("case", lambda r: r["case"]), ("nodes", lambda r: f(r.get("nodes"), "d")),
        ("freq. diff. (× size)", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("same fields kept", lambda r: f(r.get("same_fields_kept"))),
        ("cond(Mr) before, after", lambda r: two(
            r, ", ", ("cond_mr_before", ".3e"), ("cond_mr_after", ".4g"))),
        ("cond changes (Mr b/a, Φ b/a)", lambda r: ", ".join(
            f(r.get(f"{k}_change"), ".0e") for k in ("cond_mr_before", "cond_mr_after",
                                                     "cond_phi_before", "cond_phi_after"))),
        ("σ diff.", lambda r: f(r.get("singular_values_difference"), ".0e")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".2e")),
        ("tip diff. / L", lambda r: f(r.get("tip_difference_over_L"), ".0e")),
        ("Newton it.", lambda r: f(r.get("newton_iterations_mean"), ".2f")),
        *COMMON],
    "slenderness": [
        ("L/h", lambda r: str(r["slenderness"])),
        ("size mm", lambda r: f(1e3 * r["mesh_size_m"], "g")),
        ("DOFs", lambda r: f(r.get("ndofs"), ",")), ("f₁ Hz", lambda r: f(r.get("f1_hz"), ".5g")),
        ("vs Euler–Bernoulli", lambda r: f(r.get("error_euler_bernoulli"), "+.1e")),
        ("vs Timoshenko", lambda r: f(r.get("error_timoshenko"), "+.1e")),
        ("backward error", lambda r: f(r.get("max_backward_error"), ".0e")),
        ("‖Kφ−λMφ‖/‖Kφ‖", lambda r: f(r.get("max_relative_residual"), ".0e")),
        ("smallest margin limit/measured", smallest_margin),
        ("eigen-solve s", lambda r: f(r.get("eigensolve_s"), ".1f")), *COMMON],
    "modes": [
        ("body", lambda r: r["body"]), ("Nm", lambda r: str(r["modes"])),
        ("DOFs", lambda r: f(r.get("ndofs"), ",")),
        ("columns", lambda r: f"{r['columns_before']} → {r['columns_after']}"
         if "columns_after" in r else ""),
        ("cond(Mr) before → after", lambda r: two(
            r, " → ", ("cond_mr_before", ".1e"), ("cond_mr_after", ".1e"))),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("eigen-solve s", lambda r: f(r.get("eigensolve_s"), ".1f")),
        ("sel. + red. s", lambda r: f(r.get("selection_reduction_s"), ".2f")),
        ("/ eigen-solve", lambda r: f(r.get("selection_over_eigensolve"), ".1%")),
        ("Newton it.", lambda r: f(r.get("newton_iterations_mean"), ".2f")),
        ("steps/s", lambda r: f(r.get("steps_per_second"), ",.0f")),
        ("energy drift", lambda r: f(r.get("energy_drift_rel"), ".1e")), *COMMON],
    "long": [
        ("case", lambda r: r["case"]), ("steps", lambda r: f(r.get("steps"), ",")),
        ("complete", lambda r: f(r.get("complete"))),
        ("energy drift", lambda r: f(r.get("energy_drift_rel"), ".1e")),
        ("max balance error, first → last tenth", lambda r: two(
            r, " → ", ("max_first_tenth", ".1e"), ("max_last_tenth", ".1e"), "max_first_tenth")),
        ("drift /s (share of max)", lambda r: (
            f"{f(r.get('drift_per_s'), '+.1e')} ({f(r.get('drift_share'), '.0%')})"
            if "drift_per_s" in r else "")),
        ("window maxima ∝ t^p", lambda r: f(r.get("growth_exponent"), ".2f")),
        ("Newton it. mean/max", lambda r: two(
            r, " / ", ("newton_iterations_mean", ".2f"), ("newton_iterations_max", "d"),
            "newton_iterations_mean")),
        ("steps/s", lambda r: f(r.get("steps_per_second"), ",.0f")), *COMMON],
    "material": [
        ("case", lambda r: r["case"]), ("f₁ Hz", lambda r: f(r.get("f1_hz"), ".6g")),
        ("f₁, f₂ vs Timoshenko", lambda r: two(
            r, ", ", ("error_weak", "+.1e"), ("error_strong", "+.1e"), "error_weak")),
        ("f·√(E₀/E) vs E₀", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("same mesh, fields", lambda r: two(
            r, ", ", ("same_mesh_file", ".2e"), ("same_fields_kept", ".2e"), "same_fields_kept")),
        ("fields kept", lambda r: f(r.get("fields_kept_count"), "d")),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")),
        ("pruning error", lambda r: f(r.get("pruning_error"), ".1e")),
        ("smallest margin", smallest_margin), *COMMON],
    "mpi": [
        ("case", lambda r: r["case"]), ("DOFs", lambda r: f(r.get("ndofs"), ",")),
        ("freq. diff.", lambda r: f(r.get("frequency_difference"), ".1e")),
        ("fields kept same", lambda r: f(r.get("same_fields_kept"))),
        ("Mr diff.", lambda r: f(r.get("mr_difference"), ".1e")),
        ("Kr diff.", lambda r: f(r.get("kr_difference"), ".1e")),
        ("F diff.", lambda r: f(r.get("fields_difference"), ".1e")),
        ("sign flips", lambda r: f(r.get("sign_flips"), "d")),
        ("cond(Mr) after", lambda r: f(r.get("cond_mr_after"), ".4g")), *COMMON],
    "assembly": [
        ("case", lambda r: r["case"]), ("coordinates", lambda r: f(r.get("coordinates"), ",")),
        ("steps", lambda r: f(r.get("steps"), ",")), ("complete", lambda r: f(r.get("complete"))),
        ("energy drift", lambda r: f(r.get("energy_drift_rel"), ".1e")),
        ("Newton it.", lambda r: f(r.get("newton_iterations_mean"), ".2f")),
        ("rows dropped", lambda r: f(r.get("dropped_rows"), "d")),
        ("drive torque peak N·m", lambda r: f(r.get("drive_torque_peak_nm"), ",.0f")),
        ("big end, main peak kN", lambda r: (
            f"{r['big_end_peak_n'] / 1e3:.2f}, {r['main_peak_n'] / 1e3:.2f}"
            if "big_end_peak_n" in r else "")),
        ("dissipated J", lambda r: f(r.get("damping_dissipation_j"), ".3g")),
        ("vs run: torque, big end", lambda r: (
            f"{r['against']}: {f(r['torque_difference_rel'], '.1e')}, "
            f"{f(r['big_end_difference_rel'], '.1e')}" if "against" in r else "")),
        ("models reused", lambda r: f(r.get("reused_models"), "d")),
        ("steps/s", lambda r: f(r.get("steps_per_second"), ",.0f")), *COMMON],
}


def table(cls: str, rows: list[dict]) -> str:
    """The Markdown table of a probe class's rows ("?" in a cell its row cannot fill)."""
    cols = COLUMNS[cls]
    lines = ["| " + " | ".join(h for h, _ in cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for _, fn in cols:
            try:
                cells.append(fn(r))
            except (KeyError, TypeError, ValueError, IndexError):
                cells.append("?")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
