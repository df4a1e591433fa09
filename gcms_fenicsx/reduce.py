"""From free-free modes to the reduced model: GCMS fields, selection, Mr, Kr, gravity, node groups.

The stage's two products are the :class:`~gcms_fenicsx.reduced_model.ReducedModel` (on rank
0; the small matrices and the nodal rows gathered there) and the selection report written
as ``selection.json``. Its oracle is Rayleigh–Ritz (DESIGN §3): every kept eigenmode lies in
span(Φ), so the lowest 6 + Nm eigenvalues of (Kr, Mr) reproduce the full model's, and any
deviation is the pruning error, reported as ``max_rel_frequency_error``.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.linalg

from gcms_fenicsx import basis, selection
from gcms_fenicsx.config import REDUCED_MODEL_TABLES, StudyConfig
from gcms_fenicsx.eigen import Modes
from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.fe import FEModel
from gcms_fenicsx.mesh import BodyMesh
from gcms_fenicsx.node_groups import gather_rows, group_weights
from gcms_fenicsx.reduced_model import NodeGroup, ReducedModel


class ReductionError(ComputationFailed):
    """The reduced model cannot be used (its mass matrix is not positive definite)."""


def reduce_body(model: FEModel, modes: Modes, body: BodyMesh, cfg: StudyConfig,
                mesh_stats: dict) -> tuple[ReducedModel | None, dict]:
    """Select fields, build Mr, Kr and the gravity matrix; the model on rank 0, the report on all."""
    comm = model.comm
    t0 = time.perf_counter()
    fields = basis.field_basis(model, modes)
    weighted = fields.gram_mass if cfg.selection.weighting == "mass" else fields.gram_euclid
    chosen = selection.select_fields(weighted, cfg.selection, fields.names)
    kept = chosen.kept
    G_kept = fields.gram_mass[np.ix_(kept, kept)]
    names = tuple(fields.names[i] for i in kept)
    if cfg.selection.orthonormalize:
        T = selection.orthonormalizing_transform(G_kept)
        names = names[:selection.RIGID] + tuple(f"psi{j + 1}" for j in range(len(kept) - 4))
    else:
        T = np.eye(len(kept))
    t_select = time.perf_counter() - t0

    t0 = time.perf_counter()
    F = fields.fields[:, kept] @ T
    G = basis.symmetric(T.T @ G_kept @ T)  # round-off in Tᵀ G T grows with ‖T‖²
    Mr, Kr = basis.reduced_mass(G), basis.reduced_stiffness(model, F)
    # Φᵀ M (1 ⊗ g) = (Fᵀ Ms 1) ⊗ g, and F's first column is T₀₀·1
    gravity = np.kron(G[:, :1] / T[0, 0], np.eye(3))
    t_reduce = time.perf_counter() - t0

    try:
        scipy.linalg.cholesky(Mr)
    except np.linalg.LinAlgError as exc:
        raise ReductionError(
            f"Mr is not positive definite after selection (cond(G) = "
            f"{np.linalg.cond(G):.3e}): dependent fields remain; raise [selection] "
            f"svd_tolerance (now {cfg.selection.svd_tolerance:g})") from exc
    reduced = scipy.linalg.eigh(Kr, Mr, eigvals_only=True)
    nm = len(modes.elastic_eigenvalues)
    reduced_hz = np.sqrt(np.clip(reduced[6:6 + nm], 0.0, None)) / (2 * np.pi)
    full_hz = modes.elastic_frequencies_hz
    report = {
        "columns_before": 3 * fields.field_count,
        "columns_after": 3 * len(kept),
        "fields_before": fields.field_count,
        "fields_kept": list(fields.names[i] for i in kept),
        "fields_dropped": chosen.dropped,
        "reduced_field_names": list(names),
        "preconditioned": cfg.selection.orthonormalize,
        **selection.conditioning(fields.gram_mass, fields.gram_euclid,
                                 T if cfg.selection.orthonormalize else None, kept),
        "singular_values": chosen.singular_values.tolist(),
        "reduced_frequencies_hz": reduced_hz.tolist(),
        "full_frequencies_hz": full_hz.tolist(),
        "max_rel_frequency_error": float(np.max(np.abs(reduced_hz / full_hz - 1))),
        "rigid_eigenvalue_max_rel": float(np.max(np.abs(reduced[:6])) / modes.eigenvalues[6]),
        "tolerances": cfg.selection.to_json(),
        "timings_s": {"selection": t_select, "reduction": t_reduce,
                      "selection_and_reduction": t_select + t_reduce},
    }

    groups = group_weights(body, model.Vs)
    all_fields = gather_rows(comm, F)
    all_nodes = gather_rows(comm, model.nodes)
    if comm.rank != 0:
        return None, report
    reduced_model = ReducedModel(
        mass=Mr, stiffness=Kr, gravity=gravity, fields=all_fields, nodes_m=all_nodes,
        field_names=names,
        groups={name: NodeGroup(nodes=n, weights=w) for name, (n, w) in groups.items()},
        frequencies_hz=full_hz, reduced_frequencies_hz=reduced_hz, selection=report,
        tolerances=cfg.selection.to_json(),
        material={"E": cfg.material.E, "nu": cfg.material.nu, "rho": cfg.material.rho},
        mesh=mesh_stats, input_hash=cfg.digest(*REDUCED_MODEL_TABLES))
    return reduced_model, report
