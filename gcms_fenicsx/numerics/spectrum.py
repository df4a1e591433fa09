"""Clusters of eigenvalues: which neighbouring eigenvalues count as one (near-)repeated value.

A solver returns an arbitrary basis of a repeated eigenvalue (a square beam's bending pair),
and a mesh that is not symmetric splits it slightly, so a group of close eigenvalues is one
subspace, not separate modes: ``modes.json`` reports such groups, a mode count that cuts
one is warned, and an initial mode shape is chosen within its group. NumPy only (the
standalone integrator uses it).
"""
from __future__ import annotations

import numpy as np

#: Relative split below which two eigenvalues are reported as one repeated value.
REPEATED_SPLIT = 1e-6
#: Neighbouring eigenvalues whose relative split (λ_{k+1} − λ_k)/λ_{k+1} is below this are
#: chained into one cluster: meshes split a square beam's bending pairs by 1e-6..1e-5, while
#: the distinct modes of the study bodies lie at least 0.19 apart.
CLUSTER_SPLIT = 1e-3


def chained(lower: float, upper: float) -> bool:
    """Whether ``upper`` ≥ ``lower`` is within CLUSTER_SPLIT (relative) of it."""
    return upper - lower <= CLUSTER_SPLIT * abs(upper)


#: A cluster whose split inside comes above CLUSTER_SPLIT / NEAR_SPLIT_FACTOR, or whose gap to a
#: neighbour outside it comes below CLUSTER_SPLIT × NEAR_SPLIT_FACTOR, is near the rule's edge:
#: a small change of the body can change which eigenvalues it groups.
NEAR_SPLIT_FACTOR = 10.0


def relative_split(lam: np.ndarray, k: int) -> float:
    """(λ_{k+1} − λ_k)/|λ_{k+1}|: the split :func:`chained` compares with CLUSTER_SPLIT."""
    return float((lam[k + 1] - lam[k]) / abs(lam[k + 1]))


def cluster_splits(lam: np.ndarray, group: range, first: int = 0) -> tuple[float, float | None]:
    """The largest :func:`relative_split` between neighbours inside ``group`` (0 for one
    eigenvalue) and the smallest between it and its neighbours outside it, not below
    ``first`` (None if it has none)."""
    inside = max((relative_split(lam, k) for k in range(group.start, group.stop - 1)),
                 default=0.0)
    outside = [relative_split(lam, k) for k in (group.start - 1, group.stop - 1)
               if k >= first and k + 1 < len(lam)]
    return inside, min(outside, default=None)


def near_split_edge(inside: float, outside: float | None) -> bool:
    """Whether a cluster's splits (:func:`cluster_splits`) are within NEAR_SPLIT_FACTOR of
    CLUSTER_SPLIT: the grouping could change with a small change of the body."""
    return (inside > CLUSTER_SPLIT / NEAR_SPLIT_FACTOR
            or (outside is not None and outside < CLUSTER_SPLIT * NEAR_SPLIT_FACTOR))


def cluster_of(lam: np.ndarray, index: int, first: int = 0) -> range:
    """The indices of the eigenvalues chained to ``lam[index]`` (``lam`` ascending), not
    below ``first``."""
    low, high = index, index
    while low > first and chained(lam[low - 1], lam[low]):
        low -= 1
    while high + 1 < len(lam) and chained(lam[high], lam[high + 1]):
        high += 1
    return range(low, high + 1)


def clusters(lam: np.ndarray) -> list[dict]:
    """Every cluster of two or more of the ascending ``lam``: its indices, multiplicity,
    relative split, whether it is repeated (split below REPEATED_SPLIT) and its frequency
    (√mean / 2π, λ in rad²/s²)."""
    out, index = [], 0
    while index < len(lam):
        group = cluster_of(lam, index, index)
        if len(group) > 1:
            g = list(group)
            split = float((lam[g[-1]] - lam[g[0]]) / lam[g[-1]])
            out.append({"modes": g, "multiplicity": len(g), "relative_split": split,
                        "repeated": split < REPEATED_SPLIT,
                        "frequency_hz": float(np.sqrt(lam[g].mean()) / (2 * np.pi))})
        index = group.stop
    return out


def cut_cluster_warning(last: float, following: float, count: int) -> str | None:
    """A warning when the last wanted eigenvalue and the next are chained into one cluster
    (``numerics.spectrum``):
    the count then keeps an arbitrary part of a (near-)repeated group, chosen by the solver,
    so the reduced basis is not continuous in the body's shape (a square beam's bending pair
    kept half, docs/stability.md)."""
    if not chained(last, following):
        return None
    split = (following - last) / following
    hz = np.sqrt(np.array([last, following])) / (2 * np.pi)
    return (f"{count} elastic modes cut a near-repeated group: mode {count} at {hz[0]:.6g} Hz and "
            f"the next at {hz[1]:.6g} Hz (relative split {split:.1e}); the solver chooses which "
            f"combination is kept: ask for {count + 1} or more so the group is whole")
