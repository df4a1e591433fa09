"""Probe classes 3, 4 and 6, the eigen-solve and the selection under stress: slenderness
(square beams of L/h = 10 … 1000 against beam theory), many modes (Nm = 10 … 100 on a beam
and the default crankshaft) and material extremes (ν up to 0.499, E over ten decades)."""
from __future__ import annotations

import math
from pathlib import Path

from stress.measures import beam_references, compare_to, pair_split
from stress.readers import Reader, both, read_modes, read_selection, read_summary
from stress.runner import gcms
from stress.studies import (E_REFERENCE, E_VALUES, MAT_B, MAT_H, MAT_L, MODE_COUNTS, NUS,
                            SLENDERNESS, STEEL, THICK_M, material_beam, modes_beam,
                            modes_crankshaft, slender_beam)
from stress.suite import Suite


def slender_reader(lh: int) -> Reader:
    """Modes of the beam of L/h = ``lh`` with its first bending frequency against beam theory,
    its pair split and its smallest verification margin."""
    def read(out: Path) -> dict:
        row = read_modes(out)
        ref = beam_references(STEEL["E"], STEEL["nu"], STEEL["rho"], THICK_M, THICK_M,
                              THICK_M * lh)
        f1 = row["frequencies_hz"][0]
        m = [v for v in row["margins"].values() if v is not None]
        return {**row, **ref, "f1_hz": f1,
                "error_euler_bernoulli": f1 / ref["euler_bernoulli_hz"] - 1,
                "error_timoshenko": f1 / ref["timoshenko_hz"] - 1,
                "pair_split": pair_split(row["frequencies_hz"]),
                "smallest_margin": min(m) if m else None}
    return read


def slenderness(suite: Suite) -> None:
    """Class 3: `gcms modes` of 10 mm square steel beams of each L/h."""
    for lh in ((10, 30) if suite.quick else SLENDERNESS):
        study, size = slender_beam(lh)
        run = gcms("modes", study, suite.path(f"slender_{lh}"))
        suite.probe("slenderness", f"L/h = {lh}", run, slender_reader(lh), slenderness=lh,
                    mesh_size_m=size)


def read_many_modes(out: Path) -> dict:
    """Modes, selection and summary, and selection with reduction over the eigen-solve time."""
    row = both(read_modes, read_selection, read_summary)(out)
    row["selection_over_eigensolve"] = (row["selection_reduction_s"] / row["eigensolve_s"]
                                        if row["eigensolve_s"] else None)
    return row


def many_modes(suite: Suite) -> None:
    """Class 4: `gcms run` of a beam and of the crankshaft with each mode count."""
    counts = (10,) if suite.quick else MODE_COUNTS
    for body, make in (("beam", modes_beam), ("crankshaft", modes_crankshaft)):
        for nm in counts:
            run = gcms("run", make(nm), suite.path(f"modes_{body}_{nm}"))
            suite.probe("modes", f"{body}, Nm = {nm}", run, read_many_modes, body=body,
                        modes=nm)


def poisson_reader(nu: float) -> Reader:
    """Modes and selection of the material beam of Poisson's ratio ``nu``, its first bending
    frequencies (weak and strong axis) against Timoshenko."""
    def read(out: Path) -> dict:
        row = both(read_modes, read_selection)(out)
        f = row["frequencies_hz"]
        weak = beam_references(STEEL["E"], nu, STEEL["rho"], MAT_B, MAT_H, MAT_L)
        strong = beam_references(STEEL["E"], nu, STEEL["rho"], MAT_H, MAT_B, MAT_L)
        return {**row, "f1_hz": f[0], "f2_hz": f[1],
                "timoshenko_weak_hz": weak["timoshenko_hz"],
                "timoshenko_strong_hz": strong["timoshenko_hz"],
                "error_weak": f[0] / weak["timoshenko_hz"] - 1,
                "error_strong": f[1] / strong["timoshenko_hz"] - 1}
    return read


def material(suite: Suite) -> None:
    """Class 6: `gcms reduce` of the material beam at each ν, then at each E compared with
    E₀ = E_REFERENCE on the same mesh."""
    size = 0.01 if suite.quick else 0.006
    for nu in ((0.3, 0.499) if suite.quick else NUS):
        run = gcms("reduce", material_beam(dict(STEEL, nu=nu), size),
                   suite.path(f"material_nu{nu:g}"))
        suite.probe("material", f"ν = {nu:g}", run, poisson_reader(nu), nu=nu, E=STEEL["E"])
    values = (1e5, E_REFERENCE, 1e15) if suite.quick else E_VALUES
    found = {}
    for E in values:
        run = gcms("reduce", material_beam(dict(STEEL, E=E), size), suite.path(f"material_E{E:g}"))
        found[E] = suite.probe("material", f"E = {E:.0e} Pa", run,
                               both(read_modes, read_selection), nu=STEEL["nu"], E=E)
    ref = found.get(E_REFERENCE)
    if ref is None or ref["outcome"] != "ok" or "read_error" in ref:
        return
    for E, row in found.items():
        if row["outcome"] == "ok" and "read_error" not in row:
            compare_to(row, ref, scale=math.sqrt(E_REFERENCE / E))
            row["same_mesh_file"] = row["mesh_sha256"] == ref["mesh_sha256"]
