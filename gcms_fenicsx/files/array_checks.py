"""The checks a reader makes of the arrays it read, shared by the file formats' validators
(``reduced_model``, ``svk_data``): real and finite, and symmetric where a matrix must be.
Each reports through the validator's ``fail`` (which names the file). NumPy only."""
from __future__ import annotations

from typing import Any, Callable, NoReturn

import numpy as np

Fail = Callable[[str], NoReturn]
#: |A − Aᵀ| relative to max|A|: the symmetric matrices (Mr, Kr, the SVK coefficients' A) are
#: symmetrised when built.
SYMMETRY_RTOL = 1e-10


def check_real_array(name: str, a: Any, fail: Fail) -> None:
    """``fail`` unless ``a`` is an array of real numbers (integers read as such), all finite."""
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "fiu":
        found = a.dtype if isinstance(a, np.ndarray) else type(a).__name__
        fail(f"{name} must be an array of real numbers, found {found}")
    if not np.all(np.isfinite(a)):
        fail(f"{name} holds {np.count_nonzero(~np.isfinite(a))} non-finite values")


def check_symmetric(name: str, a: np.ndarray, fail: Fail) -> None:
    """``fail`` unless |a − aᵀ| ≤ SYMMETRY_RTOL max|a|."""
    asym = np.max(np.abs(a - a.T), initial=0.0)
    if asym > SYMMETRY_RTOL * np.max(np.abs(a), initial=0.0):
        fail(f"{name} is not symmetric: max |A - Aᵀ| = {asym:.3e}")
