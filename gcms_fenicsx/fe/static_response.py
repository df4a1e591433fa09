"""Static responses with inertia relief, K u = f' exactly, for the attachment modes
(docs/design.md §3.7).

The eigen-solve factorises K − σM (σ < 0), never K, which is singular. One solve with that
factor, u = (K − σM)⁻¹ f', is not the static response: its component along eigenmode k is
scaled by λ_k/(λ_k − σ), and σ = −0.1 λ̂₇ comes from an upper bound of the first elastic
eigenvalue that can be far above it (the default crankshaft: |σ| = 12 λ₇, so the modes just
above the computed ones were scaled by about 0.7 and the nose of the shaft was 3.4× too
compliant in a static test against the full model).

So the response is solved for: the components along the computed elastic modes φ_k
(M-orthonormal, eigenvalues λ_k) exactly, u_Φ = Σ_k φ_k φ_kᵀ f' / λ_k, and the rest,
K u'' = f'' = f' − M Φ Φᵀ f', by conjugate gradients preconditioned with (K − σM)⁻¹, column by
column in one block: on the M-orthogonal complement of the rigid and computed modes the
preconditioned operator's eigenvalues λ/(λ − σ) lie in [λ_{Nm+1}/(λ_{Nm+1} − σ), 1), so it
converges in a few iterations (each one product with K and one block solve with the
factor). f' is self-equilibrated (no rigid content), so every iterate stays free of it.
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from gcms_fenicsx.fe.algebra import factor_solve, gram, magnitude_product, mat_dense
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mass import mass_dense
from gcms_fenicsx.runtime.errors import ComputationFailed

#: Iterations stop when every column's residual |f'' − K u''| is below this fraction of
#: | |K| |u''| |, the size of the round-off in K u'' itself (a normwise backward error; a
#: residual relative to |f''| stalls near 1e-6 on a beam, where K u'' cancels to f''). At
#: 1e-12 the coarse crankshaft's held nose matches the full model to 3e-7 in 13 iterations
#: (1e-10: 1.4e-5 in 10; ``tests/test_attachment_statics``).
BACKWARD_TOLERANCE = 1e-12
MAX_ITERATIONS = 200


class StaticResponseError(ComputationFailed):
    """The preconditioned iteration did not reach its tolerance."""


def static_responses(model: FEModel, factor: PETSc.Mat, loads: np.ndarray,
                     modes: np.ndarray, eigenvalues: np.ndarray) -> tuple[np.ndarray, int]:
    """(U, iterations) with K U = ``loads`` (this rank's rows; self-equilibrated columns), U
    free of rigid content; ``factor`` a factorisation of K − σM, ``modes`` the computed elastic
    modes (M-orthonormal, this rank's rows) and ``eigenvalues`` theirs (module docstring).
    Collective."""
    comm = model.comm
    coefficients = gram(comm, modes, loads)                     # Φᵀ f'
    along = modes @ (coefficients / eigenvalues[:, None])
    rhs = loads - mass_dense(model, modes) @ coefficients       # f''
    U = np.zeros_like(rhs)
    r = rhs.copy()
    z = factor_solve(model.K, factor, r)
    p = z.copy()
    rz = _column_dot(comm, r, z)
    for iteration in range(1, MAX_ITERATIONS + 1):
        Kp = mat_dense(model.K, p)
        alpha = _ratio(rz, _column_dot(comm, p, Kp))
        U += p * alpha
        r -= Kp * alpha
        error = _backward_error(model, r, U)
        if np.all(error <= BACKWARD_TOLERANCE):
            return along + U, iteration
        z = factor_solve(model.K, factor, r)
        rz, previous = _column_dot(comm, r, z), rz
        p = z + p * _ratio(rz, previous)
    raise StaticResponseError(
        f"attachment modes: the static responses did not converge in {MAX_ITERATIONS} "
        f"preconditioned iterations (backward error {float(error.max()):.2e}, tolerance "
        f"{BACKWARD_TOLERANCE:.0e})")


def _backward_error(model: FEModel, r: np.ndarray, U: np.ndarray) -> np.ndarray:
    """|r_j| / | |K| |u_j| | per column (``algebra.magnitude_product``)."""
    magnitude = magnitude_product(model.K, U)
    bound = _column_dot(model.comm, magnitude, magnitude)
    bound[bound == 0.0] = 1.0
    return np.sqrt(_column_dot(model.comm, r, r) / bound)


def _ratio(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a / b per column, 0 where b is not positive (a column already solved: its residual,
    and so its search direction, is zero)."""
    return np.divide(a, b, out=np.zeros_like(a), where=b > 0.0)


def _column_dot(comm: MPI.Comm, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """x_jᵀ y_j for every column j, summed over ranks."""
    return comm.allreduce(np.einsum("ij,ij->j", X, Y), op=MPI.SUM)
