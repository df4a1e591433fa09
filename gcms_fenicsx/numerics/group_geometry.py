"""The geometry of a node group: the directions its nodes extend in, with the pseudo-inverse
of its second moment on them (``group_rows`` of ``dynamics.bodies.body`` and the attachment
loads of ``fe.attachment``), and the lever a moment row takes about an axis there
(``dynamics.constraints.joints``, the rotor basis's and the attachment modes' moment loads).
NumPy only.
"""
from __future__ import annotations

import numpy as np

from gcms_fenicsx.runtime.errors import SceneError

#: A group direction is in the span of its nodes when its second moment exceeds this
#: fraction of the largest one (a flat face has one direction below it).
SPAN_TOLERANCE = 1e-6

#: A rotation constraint about c needs a group direction d ⊥ c with at least this length
#: after c is projected out of the group's span.
MIN_LEVER = 1e-3


def group_span(moment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(span, S⁺) of a group's second moment S = Σ w_i r_i r_iᵀ: the orthonormal directions
    (3, k) its nodes extend in (eigenvalue above SPAN_TOLERANCE of the largest) and the
    pseudo-inverse of S on them."""
    lam, vecs = np.linalg.eigh(moment)
    inside = lam > SPAN_TOLERANCE * lam.max() if lam.max() > 0 else np.zeros(3, bool)
    return vecs[:, inside], (vecs[:, inside] / lam[inside]) @ vecs[:, inside].T


def moment_lever(span: np.ndarray, group: str, c: tuple[float, float, float],
                 turning: tuple[float, float, float] | None) -> np.ndarray:
    """The lever of a unit moment about c at a group (an attachment load): the one its joint's
    moment row takes (:func:`lever`); SceneError when the group has none."""
    d = lever(span, np.asarray(c, float), None if turning is None else np.asarray(turning, float))
    if d is None:
        raise SceneError(f"[basis] attachment: group {group!r} cannot take a moment about "
                         f"{list(c)}: its nodes do not extend perpendicular to it")
    return d


def lever(span: np.ndarray, c: np.ndarray, turning: np.ndarray | None) -> np.ndarray | None:
    """A unit direction d in the group's span with d ⊥ c, or None if the group has none.

    With a turning axis e, only d = e × c or d = e give rows blind to the turning.
    """
    if turning is not None:
        for d in (np.cross(turning, c), turning):
            if np.linalg.norm(span.T @ d) > 1.0 - MIN_LEVER:
                return d
        return None
    if span.shape[1] == 0:
        return None
    perp = span - np.outer(c, c @ span)
    lengths = np.linalg.norm(perp, axis=0)
    best = int(np.argmax(lengths))
    return perp[:, best] / lengths[best] if lengths[best] > MIN_LEVER else None
