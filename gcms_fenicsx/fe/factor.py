"""One sparse LDLᵀ of K − σM with MUMPS: the shift-invert factor and Sylvester's inertia count.

A count at a second shift reuses the first factorisation's ordering and symbolic analysis
(:func:`inertia_refactorised`): K − σM and K − σ'M have one sparsity pattern, so only the
numeric phase runs again.
"""
from __future__ import annotations

from petsc4py import PETSc

from gcms_fenicsx.fe.assembly import FEModel


def factor_options(prefix: str) -> None:
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
    factor_options("gcms_inertia_")
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


def inertia_refactorised(ksp: PETSc.KSP, model: FEModel, sigma: float, shift: float) -> int:
    """Number of eigenvalues of (K, M) below ``shift``, from ``ksp``'s factorisation of K − σM
    refactorised numerically at K − shift·M: MUMPS keeps its ordering and symbolic analysis
    (the pattern is the same), so this costs about half a new factorisation (0.40 s against
    0.73–0.87 s on the default crankshaft's 82k DOFs). The count is the same exact inertia
    as :func:`inertia_below`'s; the factor of K − σM is gone afterwards.
    """
    A, P = ksp.getOperators()
    P.axpy(sigma - shift, model.M, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
    P.stateIncrease()  # PETSc 3.18's parallel MatAXPY leaves the state: the PC would not refactor
    ksp.setOperators(A, P)
    ksp.setUp()
    negative, _, _ = ksp.getPC().getFactorMatrix().getInertia()
    return int(negative)
