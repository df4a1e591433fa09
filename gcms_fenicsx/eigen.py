"""The free-free eigenproblem K φ = λ M φ: a verified shift-invert Krylov–Schur solve with SLEPc.

What this module is for: the lowest six rigid-body modes and the requested elastic
modes of an unconstrained body, M-orthonormal and sorted, with every claim about them
checked before they are returned — residuals, M-orthonormality, the rigid subspace,
and Sylvester's law of inertia for eigenvalues the Krylov method may have skipped.
A failed check raises :class:`EigenSolveError` with the numbers.
What it is not for: assembly (``fe``) and writing files (``modes_io``).

Rigid modes: the six analytic rigid-body fields (translations, rotations about the
centre of mass), M-orthonormalised, are the rigid modes; the Krylov solver works in
their M-orthogonal complement (SLEPc deflation space), because a Krylov method can
miss copies of the six-fold zero eigenvalue. Every computed mode's content in the
rigid subspace is measured by projection and must vanish.

Shift: K is singular, so σ = 0 is never factorised. σ = −0.1·λ̂₇ where λ̂₇ is the
seventh Rayleigh–Ritz value on the quadratic polynomial fields, an upper bound of the
first elastic eigenvalue (min–max principle) that costs a few mat-vecs.

Cost: one MUMPS factorisation of K − σM, then one triangular solve and a few M-products
per Krylov step. M is applied as Ms ⊗ I3 (DESIGN §2), 8× faster than the assembled M,
and the Ritz vectors are purified together in one multi-RHS solve.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.modes_config import ModesConfig
from gcms_fenicsx.progress import Progress, quiet
from gcms_fenicsx.fe import (FEModel, dense_operand, gram, kron_mass_operator, mass_dense,
                             mass_properties, mat_dense)

#: Largest admissible rigid-body content ‖Rᵀ M φ‖²/‖φ‖²_M of an elastic mode.
RIGID_CONTENT_LIMIT = 1e-8
#: Relative eigenvalue split below which two eigenvalues are reported as one repeated value.
REPEATED_SPLIT = 1e-6
#: Relative split below which neighbouring eigenvalues are reported as a near-repeated cluster.
CLUSTER_SPLIT = 1e-3
#: Largest admissible ‖ΦᵀMΦ − I‖_max.
ORTHONORMALITY_LIMIT = 1e-8

class EigenSolveError(ComputationFailed):
    """The eigen-solve failed or one of its checks did not hold."""


@dataclass(frozen=True)
class Modes:
    """Free-free modes, rigid first, then elastic in ascending order.

    ``vectors`` holds this rank's owned rows (node-major, direction-minor) of the
    M-orthonormal mode shapes, one column per mode.
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    rigid_count: int
    relative_residuals: np.ndarray
    orthonormality_error: float
    rigid_fractions: np.ndarray
    inertia_count: int
    shift: float
    center_m: np.ndarray  # centre of mass the rotation fields are taken about
    timings_s: dict[str, float] = field(default_factory=dict)

    @property
    def elastic_eigenvalues(self) -> np.ndarray:
        return self.eigenvalues[self.rigid_count:]

    @property
    def elastic_vectors(self) -> np.ndarray:
        return self.vectors[:, self.rigid_count:]

    @property
    def elastic_frequencies_hz(self) -> np.ndarray:
        """f = √λ / 2π."""
        return np.sqrt(np.maximum(self.elastic_eigenvalues, 0.0)) / (2.0 * np.pi)

    def lowest(self, count: int) -> "Modes":
        """The same solve restricted to its rigid modes and lowest ``count`` elastic modes."""
        keep = self.rigid_count + count
        return replace(self, eigenvalues=self.eigenvalues[:keep], vectors=self.vectors[:, :keep],
                       relative_residuals=self.relative_residuals[:keep],
                       rigid_fractions=self.rigid_fractions[:keep])

    @property
    def missed_eigenvalues(self) -> int:
        """Eigenvalues below the check shift (Sylvester) minus eigenvalues returned: 0."""
        return self.inertia_count - len(self.eigenvalues)

    def clusters(self) -> list[dict]:
        """Groups of neighbouring elastic eigenvalues closer than CLUSTER_SPLIT (relative).

        A group whose spread is below REPEATED_SPLIT is a repeated eigenvalue of that
        multiplicity; a larger spread is reported as near-repeated (e.g. a bending pair
        on a mesh that is not symmetric).
        """
        lam = self.elastic_eigenvalues
        groups: list[list[int]] = []
        for i in range(len(lam)):
            if groups and (lam[i] - lam[groups[-1][-1]]) <= CLUSTER_SPLIT * abs(lam[i]):
                groups[-1].append(i)
            else:
                groups.append([i])
        out = []
        for g in groups:
            if len(g) < 2:
                continue
            split = float((lam[g[-1]] - lam[g[0]]) / lam[g[-1]])
            out.append({"modes": g, "multiplicity": len(g), "relative_split": split,
                        "repeated": split < REPEATED_SPLIT,
                        "frequency_hz": float(np.sqrt(lam[g].mean()) / (2 * np.pi))})
        return out


def rigid_body_fields(nodes: np.ndarray, center: np.ndarray) -> np.ndarray:
    """The six rigid displacement fields at the nodes, node-major: translations e_l and rotations e_k × (x − c)."""
    n = nodes.shape[0]
    r = nodes - center
    out = np.zeros((n, 3, 6))
    for l in range(3):
        out[:, l, l] = 1.0
    for k in range(3):
        out[:, :, 3 + k] = np.cross(np.eye(3)[k], r)
    return out.reshape(3 * n, 6)


def ritz_first_elastic(model: FEModel, center: np.ndarray) -> float:
    """Seventh Rayleigh–Ritz value of (K, M) on the quadratic polynomial displacements.

    The subspace {1, x, y, z, x², y², z², xy, yz, zx} ⊗ R³ (30 columns) holds the six rigid
    modes, so by the min–max principle its seventh Ritz value bounds λ₇ from above.
    """
    comm = model.comm
    r = model.nodes - center
    scale = comm.allreduce(float(np.abs(r).max(initial=0.0)), op=MPI.MAX)
    s = r / scale
    poly = np.column_stack([np.ones(len(s)), s, s ** 2, s[:, 0] * s[:, 1], s[:, 1] * s[:, 2],
                            s[:, 2] * s[:, 0]])
    basis = np.kron(poly, np.eye(3))
    Kq = gram(comm, basis, mat_dense(model.K, basis))
    Mq = gram(comm, basis, mass_dense(model, basis))
    # a coarse mesh may not tell all ten polynomials apart (y² ≡ const on a one-cell P1
    # beam): keep the M-orthonormal directions Mq does resolve
    mass, vecs = np.linalg.eigh(0.5 * (Mq + Mq.T))
    keep = vecs[:, mass > 1e-12 * mass.max()] / np.sqrt(mass[mass > 1e-12 * mass.max()])
    values = np.linalg.eigvalsh(keep.T @ (0.5 * (Kq + Kq.T)) @ keep)
    return float(values[6])


def _factor_options(prefix: str) -> None:
    opts = PETSc.Options()
    opts[f"{prefix}mat_mumps_icntl_13"] = 1  # exact inertia on more than one rank
    opts[f"{prefix}mat_mumps_icntl_24"] = 1  # null-pivot detection, required by MatGetInertia


def shifted_matrix(model: FEModel, sigma: float) -> PETSc.Mat:
    """K − σM (same sparsity pattern: both are assembled on one space)."""
    A = model.K.copy()
    A.axpy(-sigma, model.M, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    return A


def factorised(model: FEModel, sigma: float) -> PETSc.KSP:
    """One sparse LDLᵀ (MUMPS Cholesky, with inertia) of K − σM, as a ``preonly`` KSP.

    The factor is ``ksp.getPC().getFactorMatrix()``; the caller destroys the KSP.
    """
    A = shifted_matrix(model, sigma)
    ksp = PETSc.KSP().create(model.comm)
    ksp.setOptionsPrefix("gcms_inertia_")
    _factor_options("gcms_inertia_")
    ksp.setOperators(A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    ksp.setFromOptions()
    ksp.setUp()
    A.destroy()  # the KSP keeps its own reference
    return ksp


def inertia_below(model: FEModel, sigma: float) -> int:
    """Number of eigenvalues of (K, M) below σ: the negative inertia of K − σM (Sylvester's law).

    M is positive definite, so the inertia of the factorised K − σM counts the
    eigenvalues below σ.
    """
    ksp = factorised(model, sigma)
    negative, _, _ = ksp.getPC().getFactorMatrix().getInertia()
    ksp.destroy()
    return int(negative)


def m_orthonormal(model: FEModel, X: np.ndarray) -> np.ndarray:
    """X L⁻ᵀ with Xᵀ M X = L Lᵀ: an M-orthonormal basis of span(X) (Cholesky–Gram–Schmidt)."""
    chol = np.linalg.cholesky(gram(model.comm, X, mass_dense(model, X)))
    return scipy.linalg.solve_triangular(chol, X.T, lower=True).T


def _run_eps(model: FEModel, nev: int, sigma: float, cfg: ModesConfig,
             deflation: np.ndarray) -> SLEPc.EPS:
    """Shift-invert Krylov–Schur for the nev eigenvalues nearest σ, orthogonal to ``deflation``.

    M enters as the matrix-free Ms ⊗ I3 (:func:`~gcms_fenicsx.fe.kron_mass_operator`): the
    M-products of every Krylov step (right-hand side, M-inner products) then cost a
    fraction of the assembled M's. The spectral transformation therefore keeps K − σM as a
    shell and factorises the assembled K − σM given as its preconditioner matrix; with
    ``preonly`` that factorisation is the exact inverse.
    """
    eps = SLEPc.EPS().create(model.comm)
    eps.setOptionsPrefix("gcms_eps_")
    eps.setOperators(model.K, kron_mass_operator(model))
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=nev)
    eps.setTarget(sigma)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    eps.setTolerances(cfg.tolerance, cfg.max_iterations)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setShift(sigma)
    st.setMatMode(SLEPc.ST.MatMode.SHELL)
    st.setPreconditionerMat(shifted_matrix(model, sigma))
    ksp = st.getKSP()
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    _factor_options("gcms_eps_st_")
    space = []
    for column in deflation.T:
        vec = model.K.createVecRight()
        vec.array[:] = column
        space.append(vec)
    eps.setDeflationSpace(space)
    eps.setPurify(False)  # done for all wanted vectors at once by :func:`purified`
    eps.setFromOptions()
    eps.solve()
    return eps


def purified(model: FEModel, factor: PETSc.Mat, ritz: np.ndarray) -> np.ndarray:
    """Purified Ritz vectors y ← (K − σM)⁻¹ M y, M-normalised, with one multi-RHS solve.

    ``factor``: a factorisation of K − σM. The shift-invert operator damps the part of a
    Ritz vector's error along eigenvalue λ by (λ₀ − σ)/(λ − σ): SLEPc's eigenvector
    purification, done here for all vectors in one block solve (MUMPS solves 32
    right-hand sides at about 1/7 of the cost per vector of a single solve).
    """
    rhs = dense_operand(model.K, mass_dense(model, ritz))
    out = rhs.duplicate()
    factor.matSolve(rhs, out)
    Y = out.getDenseArray().copy()
    rhs.destroy()
    out.destroy()
    norms = np.sqrt(model.comm.allreduce(np.sum(Y * mass_dense(model, Y), axis=0), op=MPI.SUM))
    return Y / norms


def solve_free_free(model: FEModel, cfg: ModesConfig,
                    progress: Progress = quiet) -> Modes:
    """The six rigid and the requested elastic modes of (K, M), verified.

    ``cfg.count`` elastic modes, or every elastic mode below ``cfg.max_frequency_hz``
    (counted beforehand with :func:`inertia_below`).
    """
    comm = model.comm
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    center = mass_properties(model.Ms, model.nodes, model.material.rho).center_of_mass_m
    lam7_bound = ritz_first_elastic(model, center)
    sigma = -0.1 * lam7_bound
    timings["shift_estimate"] = time.perf_counter() - t0

    if cfg.max_frequency_hz is not None:
        t0 = time.perf_counter()
        cut = (2.0 * np.pi * cfg.max_frequency_hz) ** 2
        wanted = inertia_below(model, cut) - 6
        timings["count_below_max_frequency"] = time.perf_counter() - t0
        if wanted < 1:
            raise EigenSolveError(
                f"no elastic mode below max_frequency_hz = {cfg.max_frequency_hz:g} Hz "
                f"(Sylvester count of K − λM at λ = {cut:.6g}: {wanted + 6} eigenvalues, "
                "6 of them rigid)")
    else:
        wanted = cfg.count
    total = 6 + wanted
    if total + 2 > model.ndofs // 2:
        raise EigenSolveError(f"{wanted} elastic modes requested, but the space has only "
                              f"{model.ndofs} degrees of freedom; ask for fewer than "
                              f"{model.ndofs // 2 - 8}")

    rigid = m_orthonormal(model, rigid_body_fields(model.nodes, center))
    progress(f"eigen-solve: {wanted} elastic modes of {model.ndofs} DOFs, shift {sigma:.4g}, "
             "rigid modes deflated")
    t0 = time.perf_counter()
    # one eigenpair past the last wanted one places the Sylvester check in the gap after it;
    # more only lengthen the Krylov basis (a restart more for four: 25 % of the solve)
    eps = _run_eps(model, wanted + 1, sigma, cfg, deflation=rigid)
    timings["eigensolve"] = time.perf_counter() - t0
    nconv = eps.getConverged()
    its = eps.getIterationNumber()
    if nconv < wanted + 1:
        reason = eps.getConvergedReason()
        eps.destroy()
        raise EigenSolveError(
            f"eigen-solver converged {nconv} of {wanted + 1} eigenpairs in {its} iterations "
            f"(max_iterations = {cfg.max_iterations}, tolerance = {cfg.tolerance:g}, "
            f"reason {reason}); raise [modes] max_iterations or loosen tolerance")

    t0 = time.perf_counter()
    values = np.array([eps.getEigenvalue(i).real for i in range(nconv)])
    order = np.argsort(values)
    vr = model.K.createVecRight()
    ritz = np.empty((vr.getLocalSize(), wanted))
    for j, i in enumerate(order[:wanted]):
        eps.getEigenvector(int(i), vr)
        ritz[:, j] = vr.array
    elastic = purified(model, eps.getST().getKSP().getPC().getFactorMatrix(), ritz)
    next_value = values[order[wanted]]
    eps.destroy()
    if values[order[0]] < 1e-8 * lam7_bound:
        raise EigenSolveError(
            f"a seventh zero-energy mode (eigenvalue {values[order[0]]:.3e}, first elastic "
            f"bound {lam7_bound:.3e}): is the mesh one connected body?")

    vectors = np.hstack([rigid, elastic])
    M_vectors = mass_dense(model, vectors)
    K_vectors = mat_dense(model.K, vectors)
    values = np.concatenate([np.diag(gram(comm, rigid, K_vectors[:, :6])),
                             values[order[:wanted]]])
    # content of each mode in the rigid subspace: ‖Rᵀ M φ‖² / ‖φ‖²_M (R M-orthonormal)
    rigid_fractions = (np.sum(gram(comm, rigid, M_vectors) ** 2, axis=0)
                       / np.diag(gram(comm, vectors, M_vectors)))
    res = K_vectors - M_vectors * values
    res_norm = np.sqrt(comm.allreduce(np.sum(res ** 2, axis=0), op=MPI.SUM))
    k_norm = np.sqrt(comm.allreduce(np.sum(K_vectors ** 2, axis=0), op=MPI.SUM))
    m_norm = np.sqrt(comm.allreduce(np.sum(M_vectors ** 2, axis=0), op=MPI.SUM))
    lam_ref = values[6]
    # elastic: ‖Kφ − λMφ‖/‖Kφ‖; rigid (Kφ ≈ 0): ‖Kφ − λMφ‖/(λ₇‖Mφ‖)
    residuals = np.where(np.arange(total) < 6, res_norm / (lam_ref * m_norm), res_norm / k_norm)
    ortho = float(np.abs(gram(comm, vectors, M_vectors) - np.eye(total)).max())
    timings["verification"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    check_shift = 0.5 * (values[-1] + next_value)
    inertia = inertia_below(model, check_shift)
    timings["inertia_check"] = time.perf_counter() - t0

    modes = Modes(eigenvalues=values, vectors=vectors, rigid_count=6,
                  relative_residuals=residuals, orthonormality_error=ortho,
                  rigid_fractions=rigid_fractions, inertia_count=inertia, shift=sigma,
                  center_m=center,
                  timings_s=timings)
    residual_limit = max(1e-6, 1e3 * cfg.tolerance)
    problems = []
    if residuals.max() > residual_limit:
        problems.append(f"max relative residual {residuals.max():.3e} > {residual_limit:.1e} "
                        f"(mode {int(residuals.argmax())})")
    if rigid_fractions[6:].max(initial=0.0) > RIGID_CONTENT_LIMIT:
        problems.append(f"elastic mode {int(rigid_fractions[6:].argmax()) + 1} has rigid content "
                        f"{rigid_fractions[6:].max():.3e} > {RIGID_CONTENT_LIMIT:.0e}")
    if ortho > ORTHONORMALITY_LIMIT:
        problems.append(f"M-orthonormality error {ortho:.3e} > {ORTHONORMALITY_LIMIT:.0e}")
    if modes.missed_eigenvalues != 0:
        problems.append(f"Sylvester count below {check_shift:.6g} is {inertia}, but "
                        f"{total} eigenvalues were found: {modes.missed_eigenvalues} missed")
    if problems:
        raise EigenSolveError("eigen-solve check failed: " + "; ".join(problems))
    return modes
