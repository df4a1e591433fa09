"""Which GCMS fields to keep: cosine similarity, then a rank-revealing SVD (docs/design.md §4).

Works on the small Gram matrix W of the fields (mass-weighted G = Fᵀ Ms F by default,
Euclidean FᵀF on request); never on Φ, whose columns are dependent exactly when fields
are (Φ = F ⊗ I3), so whole fields are dropped and the kept space stays closed under
rotation. The four rigid fields 1, X, Y, Z are never dropped.

1. Directly proportional fields: |cos(f_i, f_j)| = |W_ij| / √(W_ii W_jj) ≥ 1 − cosine_tolerance
   drops the later field j (reason: proportional to i, with its cosine). 1 − |cos θ| ≈ θ²/2,
   so the tolerance is on the square of the part of f_j independent of f_i: the default
   1e-12 drops fields that differ from another by less than 1.4e-6 of their norm — the
   scale of svd_tolerance = 1e-6. A looser value drops the Poisson-contraction fields of a
   slender beam's bending pair (1 − |cos| = 5e-7 for L/h = 50), which stiffens the pair by
   10 %.
2. Remaining dependencies, with the rigid fields too: singular values σ of the fields
   scaled per mode (one scale for a mode's three fields, one for X, Y, Z together, so σ
   does not change when the body is rotated or a repeated pair's basis is re-chosen).
   The number of σ ≥ svd_tolerance · σ_max is the rank r; pivoted Cholesky of the scaled
   Gram matrix (rigid fields first) picks which r fields stay; each dropped field is
   reported with its relative residual after the kept ones.
3. Optionally (``orthonormalize``) the kept flexible fields are M-orthonormalised against
   the rigid fields and each other (the "preconditioned" basis): Mr becomes
   block-diagonal, the flexible block the identity and the rigid block scaled to unit mass
   and unit trace of its X, Y, Z part (``orthonormalizing_transform``).

``weighting`` picks the Gram matrix the tests run on: G = Fᵀ Ms F (mass) or FᵀF (euclidean).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.runtime.progress import Progress, quiet

RIGID = 4  # fields 1, X, Y, Z


@dataclass(frozen=True)
class Selection:
    """The kept fields (indices into the basis, ascending) and why every other one went."""

    kept: np.ndarray
    dropped: list[dict] = field(default_factory=list)
    singular_values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    config: SelectionConfig = field(default_factory=SelectionConfig)


def mode_scales(gram: np.ndarray) -> np.ndarray:
    """Per-field scale: 1/√W for field 1, one scale for X, Y, Z and one per mode's three fields.

    A rotation of the body mixes X, Y, Z and the three components of each mode by the same
    orthogonal matrix; these scales are invariant under it (docs/design.md §4, orientation).
    """
    d = np.diag(gram)
    nf = len(d)
    scale = np.empty(nf)
    scale[0] = 1.0 / np.sqrt(d[0])
    for start in range(1, nf, 3):
        block = d[start:start + 3].sum()
        scale[start:start + 3] = 1.0 / np.sqrt(block) if block > 0 else 0.0
    return scale


def scaled_gram(gram: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The Gram matrix of fields ``idx`` scaled by :func:`mode_scales` (scales of all fields)."""
    scale = mode_scales(gram)[idx]
    return gram[np.ix_(idx, idx)] * np.outer(scale, scale)


def scaled_singular_values(gram: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Singular values of the per-mode-scaled fields ``idx``, descending."""
    return np.sqrt(np.clip(np.linalg.eigvalsh(scaled_gram(gram, idx))[::-1], 0.0, None))


def cosine_matrix(gram: np.ndarray) -> np.ndarray:
    """C = D^-1/2 W D^-1/2 (cosine similarity of the fields in W's inner product)."""
    d = np.sqrt(np.diag(gram))
    return gram / np.outer(d, d)


#: Seconds per nf³ of the selection's dense work (the eigenvalues of the nf × nf Gram matrix
#: and up to nf pivots), measured on two shared cores: 2404 fields (800 modes) 14 s, 5104
#: fields (1700 modes, 1600 nodes: a 4.8k-DOF beam) 122 s. The selection announces this
#: times nf³ before it starts.
SECONDS_PER_FIELD_CUBED = 1e-9
#: Seconds between progress lines while the fields are pivoted.
PROGRESS_INTERVAL_S = 5.0


def estimated_seconds(fields: int) -> float:
    """The selection's estimated wall time for ``fields`` fields (SECONDS_PER_FIELD_CUBED)."""
    return SECONDS_PER_FIELD_CUBED * fields ** 3


def estimate_text(seconds: float) -> str:
    """"under a second", "40 s" or "2.1 min": an estimate as a progress line says it."""
    if seconds < 1.0:
        return "under a second"
    return f"{seconds:.0f} s" if seconds < 100.0 else f"{seconds / 60:.2g} min"


def select_fields(gram: np.ndarray, cfg: SelectionConfig, names: tuple[str, ...],
                  progress: Progress = quiet) -> Selection:
    """Cosine stage, then rank-revealing stage, on the field Gram matrix ``gram``; one
    progress line with the estimated time before, and one every PROGRESS_INTERVAL_S while
    the fields are pivoted."""
    nf = gram.shape[0]
    progress(f"selection: {nf} fields, estimated {estimate_text(estimated_seconds(nf))} (the "
             f"eigenvalues of their {nf} × {nf} Gram matrix and up to {nf} pivots)")
    dropped: list[dict] = []
    cos = cosine_matrix(gram)
    alive = np.ones(nf, dtype=bool)
    limit = 1.0 - cfg.cosine_tolerance
    for j in range(RIGID, nf):
        proportional = np.flatnonzero(alive[:j] & (np.abs(cos[:j, j]) >= limit))
        if proportional.size:   # the first field j is proportional to
            i = int(proportional[0])
            alive[j] = False
            dropped.append({"field": names[j], "index": j, "stage": "cosine",
                            "proportional_to": names[i], "cosine": float(cos[i, j])})

    idx = np.flatnonzero(alive)
    scaled = scaled_gram(gram, idx)
    sigma = scaled_singular_values(gram, idx)
    rank = int(np.sum(sigma >= cfg.svd_tolerance * sigma[0]))
    order, residual = _pivoted_cholesky(scaled, forced=min(RIGID, rank), steps=rank,
                                        progress=progress)
    keep_local = np.sort(order[:rank])
    for j in sorted(set(range(len(idx))) - set(keep_local.tolist())):
        dropped.append({"field": names[idx[j]], "index": int(idx[j]), "stage": "svd",
                        "relative_residual": float(np.sqrt(max(residual[j], 0.0)
                                                           / scaled[j, j])),
                        "threshold_singular_value": float(cfg.svd_tolerance * sigma[0])})
    kept = idx[keep_local]
    missing_rigid = set(range(RIGID)) - set(kept.tolist())
    if missing_rigid:
        raise ValueError(f"rigid fields {sorted(missing_rigid)} are dependent at "
                         f"svd_tolerance = {cfg.svd_tolerance:g}: the body is degenerate "
                         "(flat or a line) or the tolerance is far too loose")
    return Selection(kept=kept, dropped=sorted(dropped, key=lambda d: d["index"]),
                     singular_values=sigma, config=cfg)


def _pivoted_cholesky(A: np.ndarray, forced: int, steps: int,
                      progress: Progress = quiet) -> tuple[np.ndarray, np.ndarray]:
    """Greedy pivoted Cholesky: the first ``forced`` pivots in order, then the largest residual.

    Returns the pivot order and the residual diagonal after ``steps`` pivots (the squared
    norm of each field's part not spanned by the pivots chosen). Left-looking: pivot k's
    column is A's less the k columns before (n·k per pivot, not the n² of updating the whole
    residual matrix), so 5104 fields of rank 1600 take seconds.
    """
    n = A.shape[0]
    L = np.zeros((max(steps, 0), n))   # row k: pivot k's column (rows: contiguous products)
    residual = np.diag(A).astype(float).copy()
    free = np.ones(n, dtype=bool)
    order: list[int] = []
    start = last = time.perf_counter()
    for step in range(steps):
        p = step if step < forced else int(np.flatnonzero(free)[np.argmax(residual[free])])
        if residual[p] <= 0.0:
            break
        v = (A[:, p] - L[:step, p] @ L[:step]) / np.sqrt(residual[p])
        L[step] = v
        residual -= v * v
        free[p] = False
        order.append(p)
        now = time.perf_counter()
        if now - last >= PROGRESS_INTERVAL_S:
            last = now
            progress(f"selection: pivot {step + 1} of at most {steps} "
                     f"({now - start:.0f} s)")
    return np.array(order + np.flatnonzero(free).tolist()), residual


def orthonormalizing_transform(gram_kept: np.ndarray) -> np.ndarray:
    """T with Tᵀ G T = blockdiag(G_rr', I): the preconditioned basis F' = F T (Φ' = Φ (T ⊗ I3)).

    Flexible fields: M-orthogonalised against the rigid ones (F_f − F_r G_rr⁻¹ G_rf), then
    orthonormalised (L⁻ᵀ with L Lᵀ = G_ff − G_fr G_rr⁻¹ G_rf). Rigid fields: 1 scaled to unit
    mass and X, Y, Z by one common factor to unit trace of their block, so G_rr' has
    eigenvalues 1 and J_k / tr J (principal second moments): cond(Mr) ≈ tr J / J_min, set by
    the body's shape instead of its size and units. The common factor keeps the span closed
    under rotation and leaves R of the polar decomposition of the X, Y, Z block unchanged.
    """
    n = gram_kept.shape[0]
    G_rr, G_rf = gram_kept[:RIGID, :RIGID], gram_kept[:RIGID, RIGID:]
    project = np.linalg.solve(G_rr, G_rf)
    schur = gram_kept[RIGID:, RIGID:] - G_rf.T @ project
    L_inv_T = np.linalg.inv(np.linalg.cholesky(0.5 * (schur + schur.T))).T
    T = np.eye(n)
    T[0, 0] = 1.0 / np.sqrt(G_rr[0, 0])
    T[1:RIGID, 1:RIGID] = np.eye(3) / np.sqrt(np.trace(G_rr[1:, 1:]))
    T[:RIGID, RIGID:] = -project @ L_inv_T
    T[RIGID:, RIGID:] = L_inv_T
    return T


#: The largest condition number reported: 1/ε. A Gram matrix whose smallest eigenvalue is
#: below ε times its largest is singular to working precision, and its condition number is
#: reported as this bound.
COND_SINGULAR = 1.0 / np.finfo(float).eps


def condition_number(A: np.ndarray) -> float:
    """λ_max/λ_min of a symmetric positive semi-definite A, at most COND_SINGULAR."""
    w = np.linalg.eigvalsh(0.5 * (A + A.T))
    return float(min(w[-1] / w[0], COND_SINGULAR)) if w[0] > 0 else COND_SINGULAR


def conditioning(gram_mass: np.ndarray, gram_euclid: np.ndarray, T: np.ndarray | None = None,
                 kept: np.ndarray | None = None) -> dict:
    """cond₂(Φ) = √cond(FᵀF) and cond(Mr) = cond(G), before and after selection, in a form
    that does not depend on units: each Gram matrix is taken with the fields scaled by
    :func:`mode_scales` of that Gram matrix (1, X Y Z together, each mode's three fields
    together), so a change of length, mass or time units, or of the body's size, which
    multiplies each group of fields by one factor, leaves them unchanged (so does a rotation).
    "After" is on the kept fields, transformed by T (F' = F_kept T) when given: every field of
    the preconditioned basis has the units of 1/√mass (unit rigid mass, unit trace of the
    X, Y, Z block, M-orthonormal flexible fields), so its Gram matrices are taken as they are. Values are capped
    at COND_SINGULAR (singular to working precision). Φ = F ⊗ I3 has F's singular values,
    each three times, so no dense Φ is needed.
    """
    nf = gram_mass.shape[0]
    kept = np.arange(nf) if kept is None else kept
    every = np.arange(nf)

    def after(gram: np.ndarray) -> np.ndarray:
        if T is None:
            return scaled_gram(gram, kept)
        return T.T @ gram[np.ix_(kept, kept)] @ T

    return {"cond_phi_before": float(np.sqrt(condition_number(scaled_gram(gram_euclid, every)))),
            "cond_phi_after": float(np.sqrt(condition_number(after(gram_euclid)))),
            "cond_mr_before": condition_number(scaled_gram(gram_mass, every)),
            "cond_mr_after": condition_number(after(gram_mass))}
