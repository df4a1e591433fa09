"""Linear-elastic stiffness and mass of the body: weak forms and their assembly with dolfinx.

What this module is for: K and M on the blocked vector Lagrange space (node-major,
direction-minor) and the scalar mass matrix Ms on the scalar space with the same node
numbering (M = Ms ⊗ I3, docs/design.md §2: ``mass``). What it is not for: products with
them (``algebra``, ``mass``), eigen-solves (``eigensolve``) and anything reduced.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix
from mpi4py import MPI
from petsc4py import PETSc

from gcms_fenicsx.config.material import Material


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
