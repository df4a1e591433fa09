"""docs/stability.png: eight panels drawn from the good rows of each probe class (a class not
run leaves its panel saying so)."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from common import pyplot, save_figure
from stress.paragraphs import g
from stress.studies import E_REFERENCE
from stress.tables import good


def empty(ax, title: str) -> None:
    """A panel whose class was not run."""
    ax.set_title(title)
    ax.text(0.5, 0.5, "not run", ha="center", va="center", transform=ax.transAxes)


def finish(ax, title: str, xlabel: str, ylabel: str | None = None, **legend) -> None:
    """Axis labels, the legend (``legend``: its keyword arguments), a grid and the title."""
    ax.set_xlabel(xlabel)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    ax.legend(**{"fontsize": 8, **legend})
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(title)


def slenderness_errors(ax, rs: list[dict]) -> None:
    """The first bending frequency against beam theory and the residuals over L/h."""
    lh = [r["slenderness"] for r in rs]
    ax.loglog(lh, [abs(r["error_euler_bernoulli"]) for r in rs], "o-", label="|f₁/f_EB − 1|")
    ax.loglog(lh, [abs(r["error_timoshenko"]) for r in rs], "s-", label="|f₁/f_Timoshenko − 1|")
    ax.loglog(lh, [r["max_relative_residual"] for r in rs], "^--",
              label="‖Kφ−λMφ‖/‖Kφ‖ (reported)")
    ax.loglog(lh, [r["max_backward_error"] for r in rs], "v--", label="backward error (checked)")
    finish(ax, "slenderness: first bending frequency and residuals", "L/h")


def slenderness_margins(ax, rs: list[dict]) -> None:
    """Every verification margin (limit / measured) over L/h."""
    for name in sorted({k for r in rs for k in r["margins"]} - {"sylvester"}):
        pts = [(r["slenderness"], r["margins"].get(name)) for r in rs if r["margins"].get(name)]
        if pts:
            ax.loglog(*zip(*pts), "o-", label=name)
    ax.axhline(1.0, color="k", lw=0.8)
    finish(ax, "slenderness: verification margins", "L/h", "limit / measured (fails below 1)")


def symmetry(ax, rows: list[dict]) -> None:
    """Singular value, pruning error, pair split, swing and frequencies over ε, and the swing
    with a mode count that cuts a pair."""
    eps = sorted((r for r in rows if r["case"].startswith("ε")), key=lambda r: r["epsilon"])
    cut = [r for r in rows if r["case"].startswith("Nm") and r.get("tip_difference_over_L")]
    x = [r["epsilon"] for r in eps]
    for key, label in (("sigma_min", "σ_min (of per-mode-scaled fields)"),
                       ("pruning_error", "pruning error"),
                       ("pair_split", "first bending pair split"),
                       ("tip_difference_over_L", "pendulum tip vs ε = 0, / L"),
                       ("frequency_difference", "max freq. change vs ε = 0")):
        pts = [(a, r.get(key) if key != "sigma_min" else r["sigma_smallest"][0])
               for a, r in zip(x, eps)]
        pts = [(a, b) for a, b in pts if b]
        if pts:
            ax.plot(*zip(*pts), "o-", label=label)
    ax.plot([e for e in x if e > 0], [e for e in x if e > 0], "k:", lw=0.8, label="ε")
    for r in cut:
        ax.plot([r["epsilon"]], [r["tip_difference_over_L"]], "rx", ms=8,
                label=f"tip vs ε = 0 with Nm = {r['modes']} (cuts a pair)")
    ax.set_xscale("symlog", linthresh=1e-7)
    ax.set_xticks(x, [f"{e:g}" for e in x], fontsize=8)
    ax.minorticks_off()
    ax.set_yscale("log")
    for a, r in zip(x, eps):
        ax.annotate(f"{r['fields_kept_count']}", (a, r["sigma_smallest"][0]),
                    textcoords="offset points", xytext=(0, 6), fontsize=7, ha="center")
    finish(ax, "symmetry: continuity in ε (numbers: fields kept)", "ε (width = side·(1+ε))",
           fontsize=7)


def long_runs(ax, longs: list[dict]) -> None:
    """The energy balance error of each long run over its time."""
    for r in longs:
        t, y = np.array(r["balance"]["t"]), np.abs(r["balance"]["y"])
        ax.semilogy(t / t[-1], np.maximum(y, 1e-18), lw=0.9,
                    label=f"{r['case']} ({t[-1]:g} s, p = {g(r['growth_exponent'], '.2f')})")
    finish(ax, "long runs: energy balance over time", "t / end time",
           "|balance error| / max(kinetic + elastic)", fontsize=7)


def many_modes(ax, ms: list[dict]) -> None:
    """Selection with reduction, eigen-solve and steps per second over Nm, per body."""
    twin = ax.twinx()
    for i, body in enumerate(("beam", "crankshaft")):
        rb = sorted((r for r in ms if r["body"] == body), key=lambda r: r["modes"])
        if not rb:
            continue
        nm = [r["modes"] for r in rb]
        ax.loglog(nm, [r["selection_reduction_s"] for r in rb], "o-", color=f"C{i}",
                  label=f"{body}: selection + reduction s")
        ax.loglog(nm, [r["eigensolve_s"] for r in rb], "s:", color=f"C{i}",
                  label=f"{body}: eigen-solve s")
        twin.loglog(nm, [r["steps_per_second"] for r in rb], "^--", color=f"C{i + 2}",
                    label=f"{body}: steps/s")
    twin.set_ylabel("steps/s")
    twin.legend(fontsize=7, loc="lower right")
    finish(ax, "many modes: cost against Nm", "Nm", "s", fontsize=7, loc="upper left")


def poisson(ax, nus: list[dict]) -> None:
    """The bending frequencies against Timoshenko towards ν = 0.5."""
    x = [0.5 - r["nu"] for r in nus]
    ax.semilogx(x, [r["error_weak"] for r in nus], "o-", label="f₁ (weak axis)")
    ax.semilogx(x, [r["error_strong"] for r in nus], "s-", label="f₂ (strong axis)")
    for a, r in zip(x, nus):
        ax.annotate(f"ν = {r['nu']:g}", (a, r["error_weak"]), textcoords="offset points",
                    xytext=(0, 6), fontsize=7, ha="center")
    ax.invert_xaxis()
    finish(ax, "material: bending frequencies towards incompressibility", "0.5 − ν",
           "f / f_Timoshenko(κ(ν)) − 1")


def young(ax, es: list[dict]) -> None:
    """Frequencies, cond(Mr) and the pruning error against E₀ over E."""
    E = [r["E"] for r in es]
    ax.loglog(E, [max(r["frequency_difference"], 1e-17) for r in es], "o-",
              label="max |f·√(E₀/E) / f(E₀) − 1|")
    ax.loglog(E, [max(r.get("cond_mr_after_change") or 0, 1e-17) for r in es], "s-",
              label="|cond(Mr) after / at E₀ − 1|")
    ax.loglog(E, [max(r.get("pruning_error") or 0, 1e-17) for r in es], "^:",
              label="pruning error")
    ax.axvline(E_REFERENCE, color="k", lw=0.6)
    finish(ax, "material: E over ten decades, same mesh", "E Pa (E₀ = 1e10)")


def differences(classes: dict[str, list[dict]]) -> list[tuple[str, float]]:
    """(label, relative difference) of every units variant from SI and of 2 ranks from 1."""
    bars = []
    for r in classes.get("units", []):
        if r["case"] != "SI":
            bars.append((f"{r['case']}: frequencies", r.get("frequency_difference")))
            bars.append((f"{r['case']}: cond(Mr) after", r.get("cond_mr_after_change")))
            if r.get("tip_difference_over_L") is not None:
                bars.append((f"{r['case']}: tip / L", r["tip_difference_over_L"]))
    for r in classes.get("mpi", []):
        if r.get("ranks") == 2:
            for key, label in (("frequency_difference", "frequencies"), ("mr_difference", "Mr"),
                               ("kr_difference", "Kr"), ("fields_difference", "F")):
                bars.append((f"2 ranks: {label}", r.get(key)))
    return [(k, v) for k, v in bars if v is not None]


def difference_bars(ax, bars: list[tuple[str, float]]) -> None:
    """The differences of :func:`differences` as horizontal bars on a log scale."""
    ax.barh(range(len(bars)), [max(v, 1e-17) for _, v in bars], color="C0")
    ax.set_yticks(range(len(bars)), [k for k, _ in bars], fontsize=7)
    ax.set_xscale("log")
    ax.invert_yaxis()
    ax.grid(True, which="both", axis="x", alpha=0.3)
    ax.set_xlabel("relative difference from SI / 1 rank")
    ax.set_title("units, size and MPI ranks: what differs")


Panel = tuple[tuple[int, int], str, Callable[[Any, list], None], list]


def panels(classes: dict[str, list[dict]]) -> list[Panel]:
    """(position, title when empty, drawing function, its data) of each panel."""
    mat = classes.get("material", [])
    return [
        ((0, 0), "slenderness", slenderness_errors,
         sorted(classes.get("slenderness", []), key=lambda r: r["slenderness"])),
        ((0, 1), "slenderness: verification margins", slenderness_margins,
         sorted(classes.get("slenderness", []), key=lambda r: r["slenderness"])),
        ((0, 2), "symmetry", symmetry,
         classes.get("symmetry", []) if any(r["case"].startswith("ε")
                                            for r in classes.get("symmetry", [])) else []),
        ((1, 0), "long runs", long_runs, [r for r in classes.get("long", []) if "balance" in r]),
        ((1, 1), "many modes", many_modes, classes.get("modes", [])),
        ((0, 3), "material: ν", poisson,
         sorted((r for r in mat if r["case"].startswith("ν")), key=lambda r: r["nu"])),
        ((1, 2), "material: E", young,
         sorted((r for r in mat if r["case"].startswith("E") and r["E"] != E_REFERENCE
                 and r.get("frequency_difference") is not None), key=lambda r: r["E"])),
        ((1, 3), "units and MPI", difference_bars, differences(classes)),
    ]


def plot(document: dict, path: Path) -> None:
    """Draw the panels of the document's good rows into ``path``."""
    plt = pyplot()
    classes = {k: good(v["rows"]) for k, v in document["classes"].items()}
    fig, axes = plt.subplots(2, 4, figsize=(23, 9.5))
    for (i, j), title, draw, data in panels(classes):
        if data:
            draw(axes[i, j], data)
        else:
            empty(axes[i, j], title)
    save_figure(fig, path, dpi=100)
