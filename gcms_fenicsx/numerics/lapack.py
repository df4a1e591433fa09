"""LAPACK and BLAS through NumPy's C entry points, without its Python-level wrappers.

For a 3×3 or a 14×14 matrix the wrappers (input conversion, checks, error-state set-up,
``__array_function__`` dispatch) cost more than the arithmetic itself, and the integrator
calls these in every step. The inputs here are known finite; a singular or non-finite result
shows up as non-finite numbers downstream, where the step reports it with its time. The
wrappers serve where the entry points are not found under the names NumPy 1.x and 2.x give
them. NumPy only.
"""
from __future__ import annotations

from typing import Callable

import numpy as np


def _gufunc(names: tuple[str, ...], fallback: Callable) -> Callable:
    from numpy.linalg import _umath_linalg
    for name in names:
        if hasattr(_umath_linalg, name):
            return getattr(_umath_linalg, name)
    return fallback


def _multiarray_dot() -> Callable:
    for module in ("numpy.core._multiarray_umath", "numpy._core._multiarray_umath"):
        try:
            return __import__(module, fromlist=["dot"]).dot
        except (ImportError, AttributeError):
            continue
    return np.dot


#: (W, s, Vᵀ) of A = W diag(s) Vᵀ, singular values descending.
svd = _gufunc(("svd_n_f", "svd_f"), np.linalg.svd)
#: det A of a square matrix, or of a stack of them.
determinant = _gufunc(("det",), np.linalg.det)
#: A⁻¹ of a square matrix.
inverse = _gufunc(("inv",), np.linalg.inv)
#: dot(a, b, out): a · b written into the C-contiguous ``out``.
dot_into = _multiarray_dot()
