"""What a finished command wrote, as row entries: ``modes.json`` with ``mesh.json``,
``selection.json``, ``summary.json``, ``results.h5`` (through
``gcms_fenicsx.dynamics.read_results``) and two ``reduced.h5`` of one mesh compared (through
``gcms_fenicsx.dynamics.read_reduced``). The package is imported inside the readers, so
redrawing the report needs none of it and a reader that fails is one row's ``read_error``."""
from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from stress.measures import max_rel

Reader = Callable[[Path], dict]


def strict_json(path: Path) -> Any:
    """The JSON document at ``path``, refusing NaN and ±Infinity (RFC 8259 has none)."""
    def refuse(name: str):
        raise ValueError(f"{path.name}: {name} is not JSON")
    return json.loads(path.read_text(), parse_constant=refuse)


def both(*readers: Reader) -> Reader:
    """One reader whose row holds what each of ``readers`` finds, in order."""
    def read(out: Path) -> dict:
        row: dict = {}
        for r in readers:
            row.update(r(out))
        return row
    return read


def margins(verification: dict, eigenvalues: list[float]) -> dict:
    """limit / measured of every check in modes.json ``verification`` (None when the measured
    value is 0), and the lowest elastic eigenvalue over the zero-energy floor."""
    out = {}
    for name, check in verification.items():
        if not isinstance(check, dict):
            continue
        if "measured" in check and "limit" in check:
            m, lim = check["measured"], check["limit"]
            out[name] = (lim / m) if m and lim is not None else None
        elif name == "zero_energy" and "floor" in check and len(eigenvalues) > 6:
            out[name] = eigenvalues[6] / check["floor"]
        elif name == "sylvester" and "count" in check and "found" in check:
            out[name] = 1.0 if check["count"] == check["found"] else 0.0
    return out


def read_modes(out: Path) -> dict:
    """The mesh's size, the elastic frequencies, the verification margins and residuals, the
    eigen-solve's time and the mesh file's SHA-256 (None without mesh.msh)."""
    m = strict_json(out / "modes.json")
    mesh = strict_json(out / "mesh.json")
    t = m.get("timings_s", {})
    return {"nodes": mesh["nodes"], "cells": mesh["cells"], "ndofs": m["ndofs"],
            "frequencies_hz": m["elastic_frequencies_hz"],
            "margins": margins(m.get("verification", {}), m.get("eigenvalues_rad2_s2", [])),
            "max_backward_error": m.get("max_backward_error"),
            "max_relative_residual": m.get("max_relative_residual"),
            "missed_eigenvalues": m.get("missed_eigenvalues"),
            "eigensolve_s": t.get("eigensolve"),
            "mesh_sha256": hashlib.sha256((out / "mesh.msh").read_bytes()).hexdigest()
            if (out / "mesh.msh").exists() else None}


def read_selection(out: Path) -> dict:
    """The fields kept and dropped, the singular values, the condition numbers before and after
    selection, the pruning error and the time of selection and reduction."""
    s = strict_json(out / "selection.json")
    sv = sorted(s.get("singular_values", []))
    dropped = s.get("fields_dropped", [])
    return {"columns_before": s["columns_before"], "columns_after": s["columns_after"],
            "fields_kept": s["fields_kept"], "fields_kept_count": len(s["fields_kept"]),
            "fields_dropped": [{k: d.get(k) for k in ("field", "stage", "relative_residual",
                                                      "cosine") if k in d} for d in dropped],
            "singular_values": s.get("singular_values"), "sigma_smallest": sv[:3],
            "sigma_min": sv[0] if sv else None,
            "cond_phi_before": s["cond_phi_before"], "cond_phi_after": s["cond_phi_after"],
            "cond_mr_before": s["cond_mr_before"], "cond_mr_after": s["cond_mr_after"],
            "pruning_error": s["max_rel_frequency_error"],
            "reduced_frequencies_hz": s.get("reduced_frequencies_hz"),
            # the GCMS fields and their Gram and stiffness matrices are made with the modes
            # (modes.json), the selection and the reduced matrices from them (selection.json)
            "selection_reduction_s": _sum(s.get("timings_s", {}).get("selection_and_reduction"),
                                          strict_json(out / "modes.json").get("timings_s", {})
                                          .get("fields_and_matrices", 0.0))}


def _sum(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else a + b


def read_summary(out: Path) -> dict:
    """The simulation's summary: completeness, steps, speed, energy drift, Newton iterations."""
    s = strict_json(out / "summary.json")
    return {k: s.get(k) for k in ("complete", "steps", "steps_per_second", "reduced_dofs",
                                  "energy_drift_rel", "newton_iterations_mean",
                                  "newton_iterations_max", "wall_time_s", "message")}


def read_trajectory(out: Path):
    """The simulation's results.h5 (a ``gcms_fenicsx.dynamics.Trajectory``)."""
    from gcms_fenicsx.dynamics import read_results
    return read_results(out / "results.h5")


def tip_positions(out: Path) -> np.ndarray:
    """The positions of the output group ``end_xL`` (the beam's free end face) over time."""
    return np.asarray(read_trajectory(out).groups["end_xL"]["position"])


def peak_stresses(out: Path) -> np.ndarray:
    """Every recorded node's peak von Mises stress over the run (results.h5, the study's
    stress unit)."""
    return np.asarray(read_trajectory(out).stress["stress/peak_von_mises"])


def balance_history(traj) -> tuple[np.ndarray, np.ndarray]:
    """(t, balance error / max(kinetic + elastic)): the energy balance error over time in the
    scale of ``energy_drift_rel``."""
    e = traj.energy
    scale = float(np.max(np.abs(e["kinetic"] + e["elastic"])))
    return np.asarray(traj.time), np.asarray(e["balance_error"]) / (scale or 1.0)


def reduced_difference(path_a: Path, path_b: Path) -> dict:
    """Mr, Kr and the fields of two reduced models of the same mesh with nodes in another order
    (another rank count): each field's sign is taken from its overlap with the other's, and
    the coordinates' signs follow their field's (q holds one 3-vector per field)."""
    from scipy.spatial import cKDTree

    from gcms_fenicsx.dynamics import read_reduced
    a, b = read_reduced(path_a), read_reduced(path_b)
    dist, perm = cKDTree(b.nodes_m).query(a.nodes_m)
    extent = float(np.ptp(a.nodes_m, axis=0).max())
    Fa, Fb = a.fields, b.fields[perm]
    signs = np.sign(np.einsum("ij,ij->j", Fa, Fb))
    signs[signs == 0] = 1.0
    d = np.repeat(signs, 3)
    Mb, Kb = d[:, None] * b.mass * d, d[:, None] * b.stiffness * d
    return {"node_match_m": float(dist.max()), "node_match_over_size": float(dist.max()) / extent,
            "field_names_equal": list(a.field_names) == list(b.field_names),
            "sign_flips": int((signs < 0).sum()),
            "fields_difference": float(np.abs(Fa - signs * Fb).max() / np.abs(Fa).max()),
            "mr_difference": float(np.abs(a.mass - Mb).max() / np.abs(a.mass).max()),
            "kr_difference": float(np.abs(a.stiffness - Kb).max() / np.abs(a.stiffness).max()),
            "reduced_frequency_difference": max_rel(b.reduced_frequencies_hz,
                                                    a.reduced_frequencies_hz)}
