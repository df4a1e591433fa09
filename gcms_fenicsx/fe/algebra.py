"""Distributed dense algebra: products of row-distributed PETSc matrices with dense blocks of
columns, their Gram matrices, and rows owned by other ranks.

A block X holds this rank's owned rows (of a matrix's columns); everything returned is this
rank's rows again, or summed over ranks (``gram``), so every function is collective.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse
from mpi4py import MPI
from petsc4py import PETSc


def dense_operand(A: PETSc.Mat, X: np.ndarray) -> PETSc.Mat:
    """X (this rank's owned rows) as a PETSc dense matrix laid out like A's columns."""
    B = PETSc.Mat().createDense((A.getSizes()[1], (None, X.shape[1])),
                                array=np.asfortranarray(X, dtype=PETSc.ScalarType),
                                comm=A.getComm())
    B.assemble()
    return B


def mat_dense(A: PETSc.Mat, X: np.ndarray) -> np.ndarray:
    """A @ X for X holding this rank's owned rows (one sparse-times-dense MatMatMult)."""
    B = dense_operand(A, X)
    C = A.matMult(B)
    out = C.getDenseArray().copy()
    B.destroy()
    C.destroy()
    return out


def factor_solve(A: PETSc.Mat, factor: PETSc.Mat, X: np.ndarray) -> np.ndarray:
    """F⁻¹ X for X holding this rank's owned rows of A's columns, one multi-RHS solve with the
    factorisation ``factor`` of a matrix laid out like A."""
    rhs = dense_operand(A, X)
    out = rhs.duplicate()
    factor.matSolve(rhs, out)
    Y = out.getDenseArray().copy()
    rhs.destroy()
    out.destroy()
    return Y


def rows_at(comm: PETSc.Comm, X: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Rows of the row-distributed X (this rank's owned rows, in rank order) at global
    row numbers ``rows``, wherever they are owned. Collective; a rank may ask for none."""
    width = X.shape[1]
    x = PETSc.Vec().createWithArray(np.ascontiguousarray(X, dtype=PETSc.ScalarType).ravel(),
                                    size=(X.size, PETSc.DECIDE), bsize=width, comm=comm)
    index = PETSc.IS().createBlock(width, rows.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
    y = PETSc.Vec().createSeq(len(rows) * width, bsize=width, comm=PETSc.COMM_SELF)
    scatter = PETSc.Scatter().create(x, index, y, None)
    scatter.scatter(x, y, PETSc.InsertMode.INSERT_VALUES, PETSc.ScatterMode.FORWARD)
    out = y.getArray().reshape(-1, width).copy()
    for obj in (scatter, y, index, x):
        obj.destroy()
    return out


def column_rows(comm: PETSc.Comm, X: np.ndarray, first: int,
                columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of the row-distributed X for global row numbers ``columns`` (a matrix's column
    indices): ``(local, X_ext)`` with ``X_ext[local] == X_global[columns]``.

    X holds this rank's rows ``first .. first + len(X)``; the others are fetched once each
    with :func:`rows_at` and appended below them. Collective: every rank calls it.
    """
    n = X.shape[0]
    local = columns - first
    remote = (local < 0) | (local >= n)
    others, position = np.unique(columns[remote], return_inverse=True)
    fetched = rows_at(comm, X, others)
    if not len(others):
        return local, X
    local[remote] = n + position
    return local, np.vstack([X, fetched])


def magnitude_product(A: PETSc.Mat, X: np.ndarray) -> np.ndarray:
    """|A| |X| (entrywise magnitudes) for X holding this rank's owned rows of A's columns.

    ``|A| |x|`` bounds the round-off of computing ``A x``: each entry of the computed product
    is within γ_k (|A||x|)_i of the exact one, k the row's stored entries (Higham, Accuracy
    and Stability of Numerical Algorithms, §3.5). Collective.
    """
    indptr, indices, values = A.getValuesCSR()
    local, X_ext = column_rows(A.getComm(), np.abs(X), A.getOwnershipRange()[0], indices)
    magnitudes = scipy.sparse.csr_matrix((np.abs(values), local, indptr),
                                         shape=(len(indptr) - 1, X_ext.shape[0]))
    return np.asarray(magnitudes @ X_ext)


def max_row_entries(A: PETSc.Mat) -> int:
    """The largest number of stored entries in a row of A, over all ranks (k of γ_k)."""
    indptr = A.getValuesCSR()[0]
    return A.getComm().tompi4py().allreduce(int(np.diff(indptr).max(initial=0)), op=MPI.MAX)



def gram(comm: MPI.Comm, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Xᵀ Y for row-distributed X, Y: each rank's owned rows, summed over ranks."""
    return comm.allreduce(X.T @ Y, op=MPI.SUM)
