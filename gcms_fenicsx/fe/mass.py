"""The mass matrix as M = Ms ⊗ I3 (docs/design.md §2, consequence 1): products through the
scalar Ms, the matrix-free operator SLEPc multiplies by, its check against the assembled M,
and the mass properties of the mesh.
"""
from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from gcms_fenicsx.fe.algebra import gram, magnitude_product, mat_dense
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mesh import MassProperties


def mass_dense(model: FEModel, X: np.ndarray) -> np.ndarray:
    """M @ X as (Ms ⊗ I3) X: one product of the scalar Ms with X's three direction slices.

    M = Ms ⊗ I3 on the node-major blocked space (docs/design.md §2, consequence 1), so row (i, l)
    of M X is Σ_j Ms_ij X[(j, l), :]. Ms has a ninth of M's nonzeros: the same product
    reads a third of the matrix entries per column (checked by :func:`kron_mass_check`).
    """
    n, k = model.nodes.shape[0], X.shape[1]
    return mat_dense(model.Ms, X.reshape(n, 3 * k)).reshape(3 * n, k)


class KronMass:
    """PETSc Python-shell context for M = Ms ⊗ I3 acting on vectors (see :func:`mass_dense`).

    SLEPc multiplies by M a few times per Krylov step (shift-invert right-hand side and
    M-inner products). Through Ms a product reads a third of the entries (timings: README,
    Performance).
    """

    def __init__(self, model: FEModel):
        self.model = model

    def mult(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        y.array[:] = mass_dense(self.model, x.array_r.reshape(-1, 1)).ravel()


def kron_mass_operator(model: FEModel) -> PETSc.Mat:
    """M = Ms ⊗ I3 as a matrix-free PETSc operator with M's row and column layout."""
    A = PETSc.Mat().createPython((model.M.getSizes()[0], model.M.getSizes()[1]),
                                 KronMass(model), comm=model.M.getComm())
    A.setUp()
    return A


def kron_mass_check(model: FEModel, round_off: float, seed: int = 0) -> tuple[float, float]:
    """(defect, limit): ‖M w − (Ms ⊗ I3) w‖ / ‖M w‖ for a random nodal field W (N×3),
    w = vec(W) node-major, and the most round-off can make of it.

    Zero in exact arithmetic when M = Ms ⊗ I3 (docs/design.md §2, consequence 1). Each product is
    within ``round_off`` |M||w| of the exact one entrywise (``round_off`` = γ_k for k
    stored entries per row), so the limit is 2 ``round_off`` ‖|M||w|‖ / ‖M w‖. Each rank
    draws its own owned rows.
    """
    W = np.random.default_rng(seed + model.comm.rank).standard_normal(model.nodes.shape)
    w = W.reshape(-1, 1)
    Mw = mat_dense(model.M, w).ravel()
    diff = Mw - mat_dense(model.Ms, W).ravel()
    magnitude = magnitude_product(model.M, w).ravel()
    norm = np.sqrt(gram(model.comm, Mw, Mw))
    return (float(np.sqrt(gram(model.comm, diff, diff)) / norm),
            float(2.0 * round_off * np.sqrt(gram(model.comm, magnitude, magnitude)) / norm))


def mass_properties(Ms: PETSc.Mat, nodes: np.ndarray, rho: float) -> MassProperties:
    """Volume, centre of mass and inertia per unit density from Ms and the nodal coordinates.

    Coordinates are exactly represented in the isoparametric P_k space, so with
    X = [1, x, y, z] at the nodes, (Xᵀ Ms X)/ρ holds ∫1, ∫x_i, ∫x_i x_j exactly (to
    quadrature): the rigid block of the Gram matrix G = Fᵀ Ms F (docs/design.md §2).
    """
    fields = np.hstack([np.ones((nodes.shape[0], 1)), nodes])
    moments = gram(Ms.getComm().tompi4py(), fields, mat_dense(Ms, fields)) / rho
    return MassProperties.from_moments(moments)
