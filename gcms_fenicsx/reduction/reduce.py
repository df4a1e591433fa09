"""From the modal basis to the reduced body: selection, Mr, Kr, gravity, node groups.

The stage takes the body's :class:`~gcms_fenicsx.files.modal_basis.ModalBasis` (every
field with G = Fᵀ Ms F, FᵀF and Kr of all fields) and the ``[selection]`` settings and
returns the reduced model: plain NumPy on one rank, with neither the mesh nor K, so a
change of ``[selection]`` alone reruns only this. For the kept fields F_k T (T the
orthonormalising transform, or I): Mr = (Tᵀ G_k T) ⊗ I3 and Kr = (T ⊗ I3)ᵀ Kr_k (T ⊗ I3).
The provenance of a file (input hash, material, mesh statistics) is the file layer's
(``commands``).
Its oracle is Rayleigh–Ritz (docs/design.md §4.5): every kept eigenmode lies in span(Φ),
so the lowest 6 + Nm eigenvalues of (Kr, Mr) reproduce the full model's, and any deviation
is the pruning error, reported as ``max_rel_frequency_error``.
"""
from __future__ import annotations

import time
import numpy as np
import scipy.linalg

from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.reduction import selection
from gcms_fenicsx.files.modal_basis import (ModalBasis, phi_columns, reduced_mass,
                                                 symmetric)
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.progress import Progress, quiet


class ReductionError(ComputationFailed):
    """The reduced model cannot be used (its mass matrix is not positive definite)."""


def reduce_body(basis: ModalBasis, settings: SelectionConfig,
                progress: Progress = quiet) -> ReducedModel:
    """Select fields, build Mr, Kr and the gravity matrix from the modal basis.

    The reduced model with its selection report (``selection.json``); its provenance is
    left to the file layer. ``progress`` hears the selection's estimate and pivots.
    """
    t0 = time.perf_counter()
    basis = basis.attachment_residuals()
    names_all = basis.names
    weighted = basis.gram_mass if settings.weighting == "mass" else basis.gram_euclid
    chosen = selection.select_fields(weighted, settings, names_all, progress)
    kept = chosen.kept
    G_kept = basis.gram_mass[np.ix_(kept, kept)]
    names = tuple(names_all[i] for i in kept)
    if settings.orthonormalize:
        T = selection.orthonormalizing_transform(G_kept)
        names = names[:selection.RIGID] + tuple(f"psi{j + 1}" for j in range(len(kept) - 4))
    else:
        T = np.eye(len(kept))
    t_select = time.perf_counter() - t0

    t0 = time.perf_counter()
    F = basis.fields[:, kept] @ T
    G = symmetric(T.T @ G_kept @ T)  # round-off in Tᵀ G T grows with ‖T‖²
    columns = phi_columns(kept)
    T3 = np.kron(T, np.eye(3))
    Mr = reduced_mass(G)
    Kr = symmetric(T3.T @ basis.stiffness[np.ix_(columns, columns)] @ T3)
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
    nm = basis.mode_count
    reduced_hz = np.sqrt(np.clip(reduced[6:6 + nm], 0.0, None)) / (2 * np.pi)
    full_hz = basis.elastic_frequencies_hz
    report = {
        "columns_before": 3 * basis.field_count,
        "columns_after": 3 * len(kept),
        "fields_before": basis.field_count,
        "fields_kept": list(names_all[i] for i in kept),
        "fields_dropped": chosen.dropped,
        "reduced_field_names": list(names),
        "preconditioned": settings.orthonormalize,
        **selection.conditioning(basis.gram_mass, basis.gram_euclid,
                                 T if settings.orthonormalize else None, kept),
        "singular_values": chosen.singular_values.tolist(),
        "reduced_frequencies_hz": reduced_hz.tolist(),
        "full_frequencies_hz": full_hz.tolist(),
        "max_rel_frequency_error": float(np.max(np.abs(reduced_hz / full_hz - 1))),
        "rigid_eigenvalue_max_rel": float(np.max(np.abs(reduced[:6]))
                                          / basis.eigenvalues[basis.rigid_count]),
        "tolerances": settings.to_json(),
        "timings_s": {"selection": t_select, "reduction": t_reduce,
                      "selection_and_reduction": t_select + t_reduce},
    }

    return ReducedModel(mass=Mr, stiffness=Kr, gravity=gravity, fields=F, nodes_m=basis.nodes_m,
                        field_names=names, groups=dict(basis.groups), frequencies_hz=full_hz,
                        reduced_frequencies_hz=reduced_hz, selection=report,
                        tolerances=settings.to_json())

