"""Linear-elastic stiffness and mass of the body: weak forms and their assembly with dolfinx.

What this module is for: K and M on the blocked vector Lagrange space (node-major,
direction-minor), the scalar mass matrix Ms on the scalar space with the same node
numbering, and the check M = Ms ⊗ I3 that the GCMS mass algebra rests on (DESIGN §2).
What it is not for: eigen-solves (``eigen``) and anything reduced.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
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
    return FEModel(V=V, K=_assembled(a), M=_assembled(m),
                   Ms=_assembled(scalar_mass_form(Vs, material.rho)), nodes=owned_nodes(Vs),
                   material=material)


def mat_dense(A: PETSc.Mat, X: np.ndarray) -> np.ndarray:
    """A @ X for X holding this rank's owned rows (one sparse-times-dense MatMatMult)."""
    comm = A.getComm()
    B = PETSc.Mat().createDense((A.getSizes()[1], (None, X.shape[1])),
                                array=np.asfortranarray(X, dtype=PETSc.ScalarType), comm=comm)
    B.assemble()
    C = A.matMult(B)
    out = C.getDenseArray().copy()
    B.destroy()
    C.destroy()
    return out


def vector_from_nodal(model: FEModel, values: np.ndarray, scalar: bool = False) -> PETSc.Vec:
    """A PETSc vector on the vector (or scalar) space from this rank's owned nodal values."""
    vec = (model.Ms if scalar else model.K).createVecRight()
    vec.array[:] = np.ascontiguousarray(values).ravel()
    return vec


def kron_mass_defect(model: FEModel, samples: int = 3, seed: int = 0) -> float:
    """max over random nodal fields W (N×3) of ‖M w − (Ms ⊗ I3) w‖ / ‖M w‖, with w = vec(W) node-major.

    Zero to round-off when M = Ms ⊗ I3 (DESIGN §2, consequence 1); the seed is shared by
    all ranks so the answer does not depend on the partition's randomness.
    """
    rng = np.random.default_rng(seed + model.comm.rank)
    n = model.nodes.shape[0]
    worst = 0.0
    for _ in range(samples):
        W = rng.standard_normal((n, 3))
        Mw = model.M.createVecLeft()
        model.M.mult(vector_from_nodal(model, W), Mw)
        expected = np.empty((n, 3))
        ys = model.Ms.createVecLeft()
        for k in range(3):
            model.Ms.mult(vector_from_nodal(model, W[:, k], scalar=True), ys)
            expected[:, k] = ys.array
        diff = model.comm.allreduce(float(np.sum((Mw.array - expected.ravel()) ** 2)), op=MPI.SUM)
        norm = model.comm.allreduce(float(np.sum(Mw.array ** 2)), op=MPI.SUM)
        worst = max(worst, np.sqrt(diff / norm))
    return worst


def mass_properties(Ms: PETSc.Mat, nodes: np.ndarray, rho: float) -> MassProperties:
    """Volume, centre of mass and inertia per unit density from Ms and the nodal coordinates.

    Coordinates are exactly represented in the isoparametric P_k space, so with
    X = [1, x, y, z] at the nodes, (Xᵀ Ms X)/ρ holds ∫1, ∫x_i, ∫x_i x_j exactly (to
    quadrature): the rigid block of the Gram matrix G = Fᵀ Ms F (DESIGN §2).
    """
    fields = np.hstack([np.ones((nodes.shape[0], 1)), nodes])
    moments = fields.T @ mat_dense(Ms, fields)
    moments = Ms.getComm().tompi4py().allreduce(moments, op=MPI.SUM) / rho
    return MassProperties.from_moments(moments)
