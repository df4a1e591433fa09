"""The full finite-element model as a body of the integrator: the full-order references of the
reduced one.

Every node is its own field (F = I): q holds all nodal positions (node-major, the order of
the blocked vector space), Mr = M, Kr = K, G = Ms, k1 = 1 and E = X − c. The co-rotated
linear elasticity, the joints and the generalized-α integrator of ``gcms_fenicsx.dynamics``
then run unchanged on all 3N degrees of freedom with SciPy sparse matrices and a sparse
LU of the iteration matrix: reference (a), the same model without modal reduction.

``svk_elastic`` replaces the co-rotated linear elasticity by the geometrically nonlinear
Saint Venant–Kirchhoff model, assembled by dolfinx: reference (b).

Serial only: the references are for validation on meshes of some 10⁴ DOFs.
"""
from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse
import scipy.sparse.linalg
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from petsc4py import PETSc

from gcms_fenicsx.dynamics.bodies.body import Body, group_rows, make_body
from gcms_fenicsx.dynamics.constraints.factorization import Solve, mass_factorization
from gcms_fenicsx.config.scene import Scene
from gcms_fenicsx.dynamics.constraints.statics import HeldStatic, held_static
from gcms_fenicsx.numerics.rotation import polar
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mass import mass_properties
from gcms_fenicsx.config.material import Material

#: Quadrature degree of the SVK forms: exact for the degree-4 energy density of P2 fields
#: on straight cells.
SVK_QUADRATURE = 4


def to_scipy(A: PETSc.Mat) -> scipy.sparse.csr_matrix:
    """A serial PETSc AIJ matrix as SciPy CSR (the same entries)."""
    indptr, indices, data = A.getValuesCSR()
    return scipy.sparse.csr_matrix((data, indices, indptr), shape=A.getSize())


def sparse_factorization(A: scipy.sparse.spmatrix) -> Solve:
    """x = A⁻¹ b by one sparse LU (SuperLU) of A, reused for every right-hand side."""
    lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(A))
    return lu.solve


def sparse_kkt_solve(K: scipy.sparse.spmatrix, C: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """[u; λ] of the bordered system [K Cᵀ; C 0] by one sparse LU (``statics.KKTSolve``)."""
    rows = scipy.sparse.csr_matrix(C)
    return sparse_factorization(scipy.sparse.bmat([[scipy.sparse.csr_matrix(K), rows.T],
                                                   [rows, None]]))(rhs)


def full_held_static(full: Body, scene: Scene, load: np.ndarray | None = None,
                     time_s: float = 0.0) -> HeldStatic:
    """``dynamics.constraints.statics.held_static`` of the full model: its joint rows chosen with a sparse
    LU of M, the bordered system solved with :func:`sparse_kkt_solve`."""
    return held_static(full, scene, load, mass_factorization(full, sparse_factorization),
                       sparse_kkt_solve, time_s)


def full_order_body(model: FEModel, groups: dict[str, tuple[np.ndarray, np.ndarray]]) -> Body:
    """The body on all nodes of ``model``, with the node groups of ``node_groups.group_weights``."""
    if model.comm.size != 1:
        raise ValueError("the full-order reference runs on one MPI rank")
    nodes = model.nodes
    n = len(nodes)
    Ms = to_scipy(model.Ms)
    center = mass_properties(model.Ms, nodes, model.material.rho).center_of_mass_m
    rows = {name: group_rows(scipy.sparse.csr_matrix((np.ones(len(idx)), (np.arange(len(idx)),
                                                                         idx)), shape=(len(idx), n)),
                             weights, nodes[idx])
            for name, (idx, weights) in groups.items()}
    return make_body(mass=to_scipy(model.M), stiffness=to_scipy(model.K), gram=Ms,
                     q0=nodes.ravel().copy(), unit=np.ones(n), centred=nodes - center,
                     gravity=np.kron((Ms @ np.ones(n))[:, None], np.eye(3)), groups=rows,
                     node_fields=scipy.sparse.identity(n, format="csr"), nodes_m=nodes)


class SVKState:
    """What the integrator needs of an internal-force evaluation; the strain energy is
    assembled only when asked for (the recorder asks once per recorded step)."""

    def __init__(self, force: np.ndarray, rotation: np.ndarray, displacement: np.ndarray,
                 u: fem.Function, energy_form: fem.Form) -> None:
        self.force, self.rotation = force, rotation
        self._displacement, self._u, self._energy_form = displacement, u, energy_form

    @cached_property
    def energy(self) -> float:
        self._u.x.array[:] = self._displacement
        return fem.assemble_scalar(self._energy_form)

    @property
    def local_gradient(self) -> np.ndarray:
        """The force in the body frame, Tᵀ f (nf, 3), as the integrator takes it."""
        return self.force.reshape(-1, 3).dot(self.rotation)


def svk_forms(V: fem.FunctionSpace, material: Material,
              u: fem.Function) -> tuple[ufl.Form, ufl.Form]:
    """Internal virtual work and strain energy of Saint Venant–Kirchhoff (total Lagrangian).

    F = I + ∇u, E = ½ (FᵀF − I), S = λ tr(E) I + 2μ E; δW = ∫ (F S) : ∇v dX and
    W = ∫ (λ/2 tr(E)² + μ E : E) dX. For small strains S → σ of linear elasticity, so the
    model differs from the co-rotated linear one only through the kinematics. Both forms
    use the same quadrature (degree ``SVK_QUADRATURE``), so the force is the energy's
    gradient.
    """
    v = ufl.TestFunction(V)
    dx = ufl.dx(metadata={"quadrature_degree": SVK_QUADRATURE})
    mu, lmbda = material.lame
    F = ufl.Identity(3) + ufl.grad(u)
    E = 0.5 * (F.T * F - ufl.Identity(3))
    S = lmbda * ufl.tr(E) * ufl.Identity(3) + 2.0 * mu * E
    energy = (0.5 * lmbda * ufl.tr(E) ** 2 + mu * ufl.inner(E, E)) * dx
    return ufl.inner(F * S, ufl.grad(v)) * dx, energy


def svk_elastic(model: FEModel, body: Body):
    """q ↦ SVKState: dolfinx-assembled SVK internal forces at nodal positions q (u = q − X),
    with the frame R = polar(A(q)) of ``body`` for the integrator's rotated Jacobian."""
    u = fem.Function(model.V)
    residual, energy = svk_forms(model.V, model.material, u)
    residual_form, energy_form = fem.form(residual), fem.form(energy)
    vec = assemble_vector(residual_form)
    q0 = body.q0

    def evaluate(q: np.ndarray) -> SVKState:
        displacement = q - q0
        u.x.array[:] = displacement
        with vec.localForm() as local:
            local.set(0.0)
        fem.petsc.assemble_vector(vec, residual_form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        R = polar(q.reshape(-1, 3).T @ body.affine).rotation
        return SVKState(vec.array.copy(), R, displacement, u, energy_form)

    return evaluate
