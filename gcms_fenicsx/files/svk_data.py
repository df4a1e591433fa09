"""The Saint Venant–Kirchhoff coefficients of a reduced body as plain data, and their place in
reduced.h5 (schema 3, ``reduced_model``): ``/svk/quadratic_upper`` (A's upper triangle, row
by row: half the bytes of A), ``/svk/linear`` (b) and the root attributes ``svk_constant`` (c)
and ``svk_fields_sha256``, the digest of the fields F they were integrated from
(``versioned.dataset_digest``), so coefficients moved to another model's file are refused.
What they mean and how they are used: ``dynamics.bodies.svk``; how they are computed:
``fe.svk_coefficients``. NumPy and h5py only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import h5py
import numpy as np

from gcms_fenicsx.files.array_checks import Fail, check_real_array, check_symmetric
from gcms_fenicsx.files.versioned import dataset_digest

#: The datasets and the root attribute that hold the coefficients.
SVK_DATASETS = ("svk/quadratic_upper", "svk/linear")
SVK_CONSTANT = "svk_constant"
SVK_FIELDS = "svk_fields_sha256"


def packed_size(n: int) -> int:
    """n (n + 1) / 2: the length of svec of a symmetric n × n matrix (s for nf fields), and
    of the stored upper triangle of A (for n = s)."""
    return n * (n + 1) // 2


@dataclass(frozen=True)
class SVKCoefficients:
    """The constants of the reduced Saint Venant–Kirchhoff energy V = ½ pᵀ A p + bᵀ p + c,
    p = svec(Q Qᵀ) (``dynamics.bodies.svk``): ``quadratic`` A (s × s, symmetric), ``linear`` b (s),
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
        return 8 * (packed_size(s) + s)


def check_svk(svk: SVKCoefficients, fields: np.ndarray, fail: Fail) -> None:
    """That the SVK coefficients were integrated from ``fields`` (the digest), and their
    shapes, finiteness and symmetry."""
    if svk.fields_digest != dataset_digest(fields):
        fail(f"the SVK coefficients were computed for other fields ({SVK_FIELDS} does not "
             "match /fields): reduce the body again")
    field_count = fields.shape[1]
    s = packed_size(field_count)
    for name, a, shape in (("/svk/quadratic", svk.quadratic, (s, s)),
                           ("/svk/linear", svk.linear, (s,))):
        check_real_array(name, a, fail)
        if a.shape != shape:
            fail(f"{name} has shape {a.shape}, expected {shape}: s = nf (nf + 1) / 2 for "
                 f"the {field_count} fields")
    if not isinstance(svk.constant, float) or not np.isfinite(svk.constant):
        fail(f"svk_constant must be a finite number, found {svk.constant!r}")
    check_symmetric("/svk/quadratic", svk.quadratic, fail)


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
    if upper.shape != (packed_size(s),):
        fail(f"/svk/quadratic_upper has shape {upper.shape}, expected ({packed_size(s)},): "
             f"the upper triangle of an {s} × {s} matrix, as /svk/linear has {s} entries")
    A = np.zeros((s, s))
    A[np.triu_indices(s)] = upper
    if not isinstance(digest, str):
        fail(f"attribute {SVK_FIELDS} is not a string")
    return SVKCoefficients(quadratic=A + np.triu(A, 1).T, linear=linear,
                           constant=float(constant) if np.ndim(constant) == 0 else constant,
                           fields_digest=digest)
