"""From free-free modes to the reduced body: GCMS fields, selection, Mr, Kr, gravity, node groups.

The stage takes what it uses — the assembled model, the modes, the body's surface groups and
the ``[selection]`` settings — and returns the reduced model as this rank holds it: the small
matrices (the same on every rank), this rank's rows of the kept fields and the selection
report (``selection.json``). Gathering the rows on rank 0 and the provenance of a file (input hash,
material, mesh statistics) are the file layer's (``pipeline.reduced_model``, ``commands``).
Its oracle is Rayleigh–Ritz (docs/design.md §4.5): every kept eigenmode lies in span(Φ),
so the lowest 6 + Nm eigenvalues of (Kr, Mr) reproduce the full model's, and any deviation
is the pruning error, reported as ``max_rel_frequency_error``.
"""
from __future__ import annotations

import time
import numpy as np
import scipy.linalg

from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mesh import BodyMesh
from gcms_fenicsx.fe.modes import Modes
from gcms_fenicsx.fe.node_groups import group_weights
from gcms_fenicsx.files.reduced_model import NodeGroup, ReducedModel
from gcms_fenicsx.reduction import basis, selection
from gcms_fenicsx.runtime.errors import ComputationFailed


class ReductionError(ComputationFailed):
    """The reduced model cannot be used (its mass matrix is not positive definite)."""


def reduce_body(model: FEModel, modes: Modes, body: BodyMesh,
                settings: SelectionConfig) -> ReducedModel:
    """Select fields, build Mr, Kr and the gravity matrix (collective).

    The reduced model as this rank holds it: Mr, Kr, the gravity matrix, the groups and the
    report (``selection``) complete and the same on every rank, the rows of F and of the node
    coordinates only this rank's owned ones (all of them on one rank;
    ``pipeline.reduced_model`` gathers them). Its provenance is left to the file layer.
    """
    t0 = time.perf_counter()
    fields = basis.field_basis(model, modes)
    weighted = fields.gram_mass if settings.weighting == "mass" else fields.gram_euclid
    chosen = selection.select_fields(weighted, settings, fields.names)
    kept = chosen.kept
    G_kept = fields.gram_mass[np.ix_(kept, kept)]
    names = tuple(fields.names[i] for i in kept)
    if settings.orthonormalize:
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
            f"svd_tolerance (now {settings.svd_tolerance:g})") from exc
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
        "preconditioned": settings.orthonormalize,
        **selection.conditioning(fields.gram_mass, fields.gram_euclid,
                                 T if settings.orthonormalize else None, kept),
        "singular_values": chosen.singular_values.tolist(),
        "reduced_frequencies_hz": reduced_hz.tolist(),
        "full_frequencies_hz": full_hz.tolist(),
        "max_rel_frequency_error": float(np.max(np.abs(reduced_hz / full_hz - 1))),
        "rigid_eigenvalue_max_rel": float(np.max(np.abs(reduced[:6])) / modes.eigenvalues[6]),
        "tolerances": settings.to_json(),
        "timings_s": {"selection": t_select, "reduction": t_reduce,
                      "selection_and_reduction": t_select + t_reduce},
    }

    groups = {name: NodeGroup(nodes=nodes, weights=weights)
              for name, (nodes, weights) in group_weights(body, model.Vs).items()}
    return ReducedModel(mass=Mr, stiffness=Kr, gravity=gravity, fields=F, nodes_m=model.nodes,
                        field_names=names, groups=groups, frequencies_hz=full_hz,
                        reduced_frequencies_hz=reduced_hz, selection=report,
                        tolerances=settings.to_json())
