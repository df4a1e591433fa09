"""Linear-elastic stiffness and mass of the body: weak forms and their assembly with dolfinx.

What this module is for: K and M on the blocked vector Lagrange space (node-major,
direction-minor), the scalar mass matrix Ms on the scalar space with the same node
numbering, and the check M = Ms ⊗ I3 that the GCMS mass algebra rests on (DESIGN §2).
What it is not for: eigen-solves (``eigen``) and anything reduced.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix
from mpi4py import MPI
from petsc4py import PETSc

from gcms_fenicsx.material import Material
from gcms_fenicsx.mesh import MassProperties


@dataclass(frozen=True)
class FEModel:
    """Assembled matrices of one body, distributed over the mesh's communicator.

    ``nodes`` holds this rank's owned node coordinates, one row per node in the order
    of the owned rows of ``Ms`` (and of ``K``, ``M`` in blocks of three).
    """

    V: fem.FunctionSpace
    Vs: fem.FunctionSpace  # the scalar space of Ms, same nodes
    K: PETSc.Mat
    M: PETSc.Mat
    Ms: PETSc.Mat
    nodes: np.ndarray
    material: Material

    @property
    def comm(self) -> MPI.Comm:
        return self.V.mesh.comm

    @property
    def ndofs(self) -> int:
        return self.K.getSize()[0]

    @property
    def num_nodes(self) -> int:
        return self.Ms.getSize()[0]


def elasticity_forms(V: fem.FunctionSpace, material: Material) -> tuple[ufl.Form, ufl.Form]:
    """Bilinear forms of 3D isotropic linear elasticity: a(u, v) = ∫ σ(u) : ε(v) dx, m(u, v) = ∫ ρ u·v dx.

    σ(u) = 2μ ε(u) + λ tr(ε(u)) I, ε(u) = sym(∇u) (Hooke's law, Lamé parameters).
    """
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    mu, lmbda = material.lame

    def eps(w):
        return ufl.sym(ufl.grad(w))

    def sigma(w):
        return 2.0 * mu * eps(w) + lmbda * ufl.tr(eps(w)) * ufl.Identity(3)

    return ufl.inner(sigma(u), eps(v)) * ufl.dx, material.rho * ufl.inner(u, v) * ufl.dx


def scalar_mass_form(Vs: fem.FunctionSpace, rho: float) -> ufl.Form:
    """m_s(u, v) = ∫ ρ u v dx on a scalar space: M = Ms ⊗ I3 on the blocked space."""
    u, v = ufl.TrialFunction(Vs), ufl.TestFunction(Vs)
    return rho * u * v * ufl.dx


def _assembled(a: ufl.Form) -> PETSc.Mat:
    A = assemble_matrix(fem.form(a))
    A.assemble()
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    return A


def owned_nodes(Vs: fem.FunctionSpace) -> np.ndarray:
    """Coordinates of this rank's owned nodes (rows of a scalar or blocked space)."""
    return Vs.tabulate_dof_coordinates()[: Vs.dofmap.index_map.size_local].copy()


def assemble_scalar_mass(mesh, rho: float = 1.0) -> tuple[PETSc.Mat, np.ndarray]:
    """Ms on the scalar P_k space (k = geometry order) and the owned node coordinates."""
    Vs = fem.FunctionSpace(mesh, ("CG", mesh.geometry.cmap.degree))
    return _assembled(scalar_mass_form(Vs, rho)), owned_nodes(Vs)


def assemble(mesh, material: Material, degree: int | None = None) -> FEModel:
    """Assemble K, M (vector P_k) and Ms (scalar P_k, same node numbering).

    k defaults to the geometry's order (isoparametric, as ``[mesh] order`` chooses); a
    straight-edged order-1 mesh also takes k = 2.
    """
    V = fem.VectorFunctionSpace(mesh, ("CG", degree or mesh.geometry.cmap.degree))
    Vs, _ = V.sub(0).collapse()
    a, m = elasticity_forms(V, material)
    return FEModel(V=V, Vs=Vs, K=_assembled(a), M=_assembled(m),
                   Ms=_assembled(scalar_mass_form(Vs, material.rho)), nodes=owned_nodes(Vs),
                   material=material)


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


def mass_dense(model: FEModel, X: np.ndarray) -> np.ndarray:
    """M @ X as (Ms ⊗ I3) X: one product of the scalar Ms with X's three direction slices.

    M = Ms ⊗ I3 on the node-major blocked space (DESIGN §2, consequence 1), so row (i, l)
    of M X is Σ_j Ms_ij X[(j, l), :]. Ms has a ninth of M's nonzeros: the same product
    reads a third of the matrix entries per column (checked by :func:`kron_mass_check`).
    """
    n, k = model.nodes.shape[0], X.shape[1]
    return mat_dense(model.Ms, X.reshape(n, 3 * k)).reshape(3 * n, k)


class KronMass:
    """PETSc Python-shell context for M = Ms ⊗ I3 acting on vectors (see :func:`mass_dense`).

    SLEPc multiplies by M a few times per Krylov step (shift-invert right-hand side and
    M-inner products). Through Ms a product reads a third of the entries and takes an
    eighth of the time (1.05 against 8.9 ms on an 82k-DOF P2 crankshaft).
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


def gram(comm: MPI.Comm, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Xᵀ Y for row-distributed X, Y: each rank's owned rows, summed over ranks."""
    return comm.allreduce(X.T @ Y, op=MPI.SUM)


def kron_mass_check(model: FEModel, round_off: float, seed: int = 0) -> tuple[float, float]:
    """(defect, limit): ‖M w − (Ms ⊗ I3) w‖ / ‖M w‖ for a random nodal field W (N×3),
    w = vec(W) node-major, and the most round-off can make of it.

    Zero in exact arithmetic when M = Ms ⊗ I3 (DESIGN §2, consequence 1). Each product is
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
    quadrature): the rigid block of the Gram matrix G = Fᵀ Ms F (DESIGN §2).
    """
    fields = np.hstack([np.ones((nodes.shape[0], 1)), nodes])
    moments = gram(Ms.getComm().tompi4py(), fields, mat_dense(Ms, fields)) / rho
    return MassProperties.from_moments(moments)
