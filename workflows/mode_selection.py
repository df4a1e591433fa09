"""Mode selection study: what removing dependent GCMS fields does to size, conditioning and accuracy.

For every beam section of the geometry library (1 m steel beams, 10 mm P2 meshes) and the
default crankshaft, one free-free solve with 20 elastic modes; then, for Nm = 10 and 20,
the default selection (preconditioned: M-orthonormalised basis) and the plain one:

- GCMS columns before and after, cond(Φ) (2-norm, the reference's measure) and cond(Mr)
  before and after, the pruning error (largest relative error of the lowest Nm elastic
  frequencies of (Kr, Mr) against the full model), and the time of selection plus
  reduction beside the eigen-solve's;
- a tolerance sweep on the square beam and the crankshaft (what looser tolerances buy);
- a heat map of the mass-weighted cosine-similarity matrix and the singular values of the
  per-mode-scaled fields, before and after selection.

    python workflows/mode_selection.py [--out docs/mode_selection] [--quick]

writes OUT.json (``cases``, one entry a case) and OUT.png and prints the Markdown table of
README.md.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from common import log, parser, pyplot, quiet, save_figure, table_head, temporary_folder
from common import table_row, write_record
from common.sections import SECTIONS

MODE_COUNTS = (10, 20)
SWEEP = (1e-10, 1e-8, 1e-6, 1e-4, 1e-3, 1e-2)


def studies(quick: bool) -> dict[str, dict]:
    """Study tables (as in a TOML file) by case name."""
    cases = {name: {"geometry": {"kind": "beam", "section": name, "length": 1.0, **dims},
                    "mesh": {"size": 0.01, "order": 2}}
             for name, dims in SECTIONS.items()}
    cases["crankshaft"] = {"geometry": {"kind": "crankshaft"}, "mesh": {"order": 2}}
    if quick:
        cases = {k: cases[k] for k in ("square", "polygon")}
    for table in cases.values():
        table["modes"] = {"count": max(MODE_COUNTS)}
    return cases


def run_case(name: str, table: dict, folder: Path) -> dict:
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.selection import SelectionConfig
    from gcms_fenicsx.config.study import parse_config
    from gcms_fenicsx.reduction import selection
    from gcms_fenicsx.reduction.reduce import ReductionError

    cfg = parse_config(table, name)
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    model, body, all_modes = chain.assembly.model, chain.body, chain.modes
    out = {"case": name, "ndofs": model.ndofs, "eigensolve_s": all_modes.timings_s["eigensolve"],
           "frequencies_hz": all_modes.elastic_frequencies_hz.tolist(), "by_modes": {},
           "sweep": []}
    every = pipeline.basis_stage(model, all_modes, body)
    for nm in MODE_COUNTS:
        row = {}
        for variant, settings in (("default", SelectionConfig()),
                                  ("plain", SelectionConfig(orthonormalize=False))):
            row[variant] = pipeline.reduction_stage(every.lowest(nm), settings).selection
        out["by_modes"][nm] = row
    if name in ("square", "crankshaft"):
        fields = every.lowest(10)
        out["cosine"] = selection.cosine_matrix(fields.gram_mass).tolist()
        out["field_names"] = list(fields.names)
        for tol in SWEEP:
            settings = SelectionConfig(cosine_tolerance=tol, svd_tolerance=tol)
            try:
                report = pipeline.reduction_stage(every.lowest(10), settings).selection
            except ReductionError as exc:  # a too-tight tolerance leaves Mr singular: data
                out["sweep"].append({"tolerance": tol, "error": str(exc)})
                continue
            out["sweep"].append({"tolerance": tol, "columns_after": report["columns_after"],
                                 "cond_phi_after": report["cond_phi_after"],
                                 "cond_mr_after": report["cond_mr_after"],
                                 "max_rel_frequency_error": report["max_rel_frequency_error"]})
        sel = selection.select_fields(fields.gram_mass, cfg.selection, fields.names)
        every = np.arange(fields.field_count)
        out["singular_values_before"] = selection.scaled_singular_values(
            fields.gram_mass, every).tolist()
        out["singular_values_after"] = selection.scaled_singular_values(
            fields.gram_mass, sel.kept).tolist()
    return out


def table(results: list[dict]) -> str:
    lines = table_head("case", "Nm", "DOFs", "columns before → after", "cond(Φ) before → after",
                       "cond(Mr) before → after", "plain: cond(Mr), error", "pruning error",
                       "selection + reduction s", "/ eigen-solve")
    for r in results:
        for nm, row in r["by_modes"].items():
            d, p = row["default"], row["plain"]
            t = d["timings_s"]["selection_and_reduction"]
            lines.append(table_row(
                r["case"], nm, f"{r['ndofs']:,}", f"{d['columns_before']} → {d['columns_after']}",
                *(f"{d[f'{k}_before']:.1e} → {d[f'{k}_after']:.1e}" for k in ("cond_phi",
                                                                               "cond_mr")),
                f"{p['cond_mr_after']:.1e}, {p['max_rel_frequency_error']:.0e}",
                f"{d['max_rel_frequency_error']:.1e}", f"{t:.2f}", f"{t / r['eigensolve_s']:.1%}"))
    return "\n".join(lines)


def sweep_table(results: list[dict]) -> str:
    lines = table_head("case (Nm = 10)", "tolerance", "columns after", "cond(Φ) after",
                       "cond(Mr) after", "pruning error")
    for r in results:
        for s in r["sweep"]:
            cells = ((f"failed: {s['error'][:60]} | | |",) if "error" in s else
                     (s["columns_after"], *(f"{s[k]:.1e}" for k in (
                         "cond_phi_after", "cond_mr_after", "max_rel_frequency_error"))))
            lines.append(table_row(r["case"], f"{s['tolerance']:.0e}", *cells))
    return "\n".join(lines)


def plot(results: list[dict], path: Path) -> None:
    plt = pyplot()
    shown = [r for r in results if "cosine" in r]
    fig, axes = plt.subplots(len(shown), 2, figsize=(12, 5.2 * len(shown)), squeeze=False)
    for (ax_c, ax_s), r in zip(axes, shown):
        C = np.abs(np.array(r["cosine"]))
        im = ax_c.imshow(C, cmap="magma", vmin=0, vmax=1)
        ticks = range(0, len(r["field_names"]), 3)
        ax_c.set_xticks(list(ticks), [r["field_names"][i] for i in ticks], rotation=90,
                        fontsize=7)
        ax_c.set_yticks(list(ticks), [r["field_names"][i] for i in ticks], fontsize=7)
        ax_c.set_title(f"{r['case']}, Nm = 10: |mass-weighted cosine similarity| of the fields")
        fig.colorbar(im, ax=ax_c, fraction=0.046)
        ax_s.semilogy(r["singular_values_before"], "o-", ms=3, label="all fields")
        ax_s.semilogy(r["singular_values_after"], "s-", ms=3, label="after default selection")
        ax_s.set_title(f"{r['case']}: singular values of the per-mode-scaled fields")
        ax_s.set_xlabel("index")
        ax_s.grid(True, which="both", alpha=0.3)
        ax_s.legend()
    save_figure(fig, path)


def main() -> None:
    args = parser(__doc__, out="docs/mode_selection",
                  quick="two beams only (a smoke run)").parse_args()
    quiet()
    results = []
    with temporary_folder() as tmp:
        for name, table_ in studies(args.quick).items():
            t0 = time.perf_counter()
            results.append(run_case(name, table_, tmp))
            log(f"{name}: {results[-1]['ndofs']} DOFs, {time.perf_counter() - t0:.0f} s")
    write_record(Path(f"{args.out}.json"), {"cases": results})
    plot(results, Path(f"{args.out}.png"))
    print(table(results))
    print()
    print(sweep_table(results))


if __name__ == "__main__":
    main()
