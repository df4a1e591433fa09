"""The Saint Venant–Kirchhoff coefficients of a reduced body as plain data, and their place in
reduced.h5 (schema 3, ``reduced_model``): ``/svk/quadratic_upper`` (A's upper triangle, row
by row: half the bytes of A), ``/svk/linear`` (b) and the root attributes ``svk_constant`` (c)
and ``svk_fields_sha256``, the digest of the fields F they were integrated from
(``versioned.dataset_digest``), so coefficients moved to another model's file are refused.
What they mean and how they are used: ``dynamics.svk``; how they are computed:
``fe.svk_coefficients``. NumPy and h5py only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NoReturn

import h5py
import numpy as np

from gcms_fenicsx.files.versioned import dataset_digest

#: The datasets and the root attribute that hold the coefficients.
SVK_DATASETS = ("svk/quadratic_upper", "svk/linear")
SVK_CONSTANT = "svk_constant"
SVK_FIELDS = "svk_fields_sha256"
#: |A − Aᵀ| relative to max|A| (A is symmetrised when built), as for Mr and Kr.
_SYMMETRY_RTOL = 1e-10
Fail = Callable[[str], NoReturn]


@dataclass(frozen=True)
class SVKCoefficients:
    """The constants of the reduced Saint Venant–Kirchhoff energy V = ½ pᵀ A p + bᵀ p + c,
    p = svec(Q Qᵀ) (``dynamics.svk``): ``quadratic`` A (s × s, symmetric), ``linear`` b (s),
    ``constant`` c (J), s = nf (nf + 1) / 2 for the model's nf fields, and the digest of
    those fields."""

    quadratic: np.ndarray
    linear: np.ndarray
    constant: float
    fields_digest: str      # dataset_digest of the fields F they belong to

    @property
    def nbytes(self) -> int:
        """What the coefficients hold in memory (A in full, b)."""
        return self.quadratic.nbytes + self.linear.nbytes

    @property
    def stored_bytes(self) -> int:
        """What reduced.h5 stores of them (A's upper triangle, b)."""
        s = len(self.linear)
        return 8 * (s * (s + 1) // 2 + s)


def check_svk(svk: SVKCoefficients, fields: np.ndarray, fail: Fail) -> None:
    """That the SVK coefficients were integrated from ``fields`` (the digest), and their
    shapes, finiteness and symmetry."""
    if svk.fields_digest != dataset_digest(fields):
        fail(f"the SVK coefficients were computed for other fields ({SVK_FIELDS} does not "
             "match /fields): reduce the body again")
    field_count = fields.shape[1]
    s = field_count * (field_count + 1) // 2
    A, b = svk.quadratic, svk.linear
    for name, a, shape in (("/svk/quadratic", A, (s, s)), ("/svk/linear", b, (s,))):
        if not isinstance(a, np.ndarray) or a.dtype.kind != "f":
            fail(f"{name} must be an array of real numbers")
        if a.shape != shape:
            fail(f"{name} has shape {a.shape}, expected {shape}: s = nf (nf + 1) / 2 for "
                 f"the {field_count} fields")
        if not np.all(np.isfinite(a)):
            fail(f"{name} holds {np.count_nonzero(~np.isfinite(a))} non-finite values")
    if not isinstance(svk.constant, float) or not np.isfinite(svk.constant):
        fail(f"svk_constant must be a finite number, found {svk.constant!r}")
    asym = np.max(np.abs(A - A.T), initial=0.0)
    if asym > _SYMMETRY_RTOL * np.max(np.abs(A), initial=0.0):
        fail(f"/svk/quadratic is not symmetric: max |A - Aᵀ| = {asym:.3e}")


def write_svk(f: h5py.File, svk: SVKCoefficients) -> None:
    """``/svk/quadratic_upper``, ``/svk/linear`` and the root attribute ``svk_constant``."""
    upper, linear = SVK_DATASETS
    f.create_dataset(upper, data=svk.quadratic[np.triu_indices(len(svk.linear))])
    f.create_dataset(linear, data=svk.linear)
    f.attrs[SVK_CONSTANT] = float(svk.constant)
    f.attrs[SVK_FIELDS] = svk.fields_digest


def from_upper(upper: np.ndarray, linear: np.ndarray, constant: Any, digest: Any,
               fail: Fail) -> SVKCoefficients:
    """The coefficients from the stored upper triangle of A, b and c (``fail`` if the triangle
    does not fit b's length)."""
    s = len(linear)
    if upper.shape != (s * (s + 1) // 2,):
        fail(f"/svk/quadratic_upper has shape {upper.shape}, expected ({s * (s + 1) // 2},): "
             f"the upper triangle of an {s} × {s} matrix, as /svk/linear has {s} entries")
    A = np.zeros((s, s))
    A[np.triu_indices(s)] = upper
    if not isinstance(digest, str):
        fail(f"attribute {SVK_FIELDS} is not a string")
    return SVKCoefficients(quadratic=A + np.triu(A, 1).T, linear=linear,
                           constant=float(constant) if np.ndim(constant) == 0 else constant,
                           fields_digest=digest)
