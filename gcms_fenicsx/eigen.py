"""The free-free eigenproblem K φ = λ M φ: a verified shift-invert Krylov–Schur solve with SLEPc.

What this module is for: the lowest six rigid-body modes and the requested elastic
modes of an unconstrained body, M-orthonormal and sorted, with every claim about them
checked before they are returned. The stage is three named steps: the shift
(:func:`shift_estimate`), the Krylov solve with purified Ritz vectors (:func:`krylov_modes`)
and the verification (:func:`verify`), each testable alone. A failed check raises
:class:`EigenSolveError` with the numbers.
What it is not for: assembly (``fe``) and writing files (``modes_io``).

Rigid modes: the six analytic rigid-body fields (translations, rotations about the
centre of mass), M-orthonormalised, are the rigid modes; the Krylov solver works in
their M-orthogonal complement (SLEPc deflation space), because a Krylov method can
miss copies of the six-fold zero eigenvalue. The purification solve with K − σM amplifies
round-off along the rigid modes by 1/|σ| (rigid content 8e-8 on a 2 m × 10 mm steel beam,
4e-6 at 5 m), so the rigid subspace, known exactly, is projected out of the purified vectors
again: the same deflation.

Shift: K is singular, so σ = 0 is never factorised. σ = −0.1·λ̂₇ where λ̂₇ is the
seventh Rayleigh–Ritz value on the quadratic polynomial fields, an upper bound of the
first elastic eigenvalue (min–max principle) that costs a few mat-vecs.

Verification limits follow from the problem, not from constants (:class:`Verification`):
round-off in a product with a matrix whose rows hold k entries is bounded by
γ_k = kε/(1 − kε) times the product of the magnitudes (|A||x|), and the Krylov
tolerance bounds what the solver itself leaves. The low modes of a slender body are where
this matters: K φ is a small difference of large terms there, so ‖Kφ − λMφ‖/‖Kφ‖ grows like
(L/h)⁴ (2.9e-6 at L/h = 200, 8e-5 at 500) while the backward error, which compares the
residual with the magnitudes it is computed from, stays at 1e-16.

Cost: one MUMPS factorisation of K − σM, then one triangular solve and a few M-products
per Krylov step. M is applied as Ms ⊗ I3 (DESIGN §2), 8× faster than the assembled M,
and the Ritz vectors are purified together in one multi-RHS solve.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.fe import (FEModel, dense_operand, gram, kron_mass_check, kron_mass_operator,
                             magnitude_product, mass_dense, mass_properties, mat_dense,
                             max_row_entries)
from gcms_fenicsx.modes_config import ModesConfig
from gcms_fenicsx.progress import Progress, quiet

#: Relative eigenvalue split below which two eigenvalues are reported as one repeated value.
REPEATED_SPLIT = 1e-6
#: Relative split below which neighbouring eigenvalues are reported as a near-repeated cluster.
CLUSTER_SPLIT = 1e-3
#: Seconds between progress lines of a long Krylov solve.
PROGRESS_INTERVAL_S = 3.0
EPS = float(np.finfo(float).eps)


class EigenSolveError(ComputationFailed):
    """The eigen-solve failed or one of its checks did not hold."""


def gamma(k: int) -> float:
    """γ_k = kε/(1 − kε): the relative round-off bound of a sum of k products (Higham §3.1)."""
    return k * EPS / (1.0 - k * EPS)


@dataclass(frozen=True)
class Verification:
    """Every check of a solve: the measured value beside the limit round-off and the solver
    tolerance allow for this problem.

    - ``backward_errors`` η_j = ‖Kφ − λMφ‖ / (‖|K||φ|‖ + |λ| ‖|M||φ|‖), the normwise backward
      error of each pair against the magnitudes the residual is computed from. Limit
      max(tol, γ_k(K)): below γ_k the residual is round-off of its own computation, and the
      Krylov stopping test ‖(K−σM)⁻¹Mx − θx‖ ≤ tol |θ| bounds η by about tol (purification
      only lowers it).
    - ``orthonormality_error`` max |ΦᵀMΦ − I| over rigid and elastic modes. Purifying Ritz
      vectors that passed that test changes their inner products by at most tol (each
      error component e along φ_i is ≤ tol |λ_i − σ|/|λ_i − λ_j| and is scaled by
      (λ_j − σ)/(λ_i − σ)), and the Gram matrix is computed to γ_k(M) ρ, ρ the largest
      |φ_i|ᵀ|M||φ_j|: limit tol + γ_k(M) ρ.
    - ``rigid_fractions`` ‖RᵀMφ‖²/‖φ‖²_M: at most six squared inner products with rigid
      modes, so the limit is 6 × (orthonormality limit)².
    - ``zero_energy_floor``: a converged Ritz value θ of (K − σM)⁻¹M is within tol |θ| (plus
      round-off γ_k(K) |θ|) of an eigenvalue, so λ = σ + 1/θ of a zero-energy mode
      (θ = 1/|σ|) comes out below (tol + γ_k(K)) |σ|: an "elastic" eigenvalue under that floor
      cannot be told from zero and is a seventh rigid mode.
    - ``inertia_count``: eigenvalues below ``check_shift`` by Sylvester's law (exact).
    - ``mass_kron_defect`` ‖Mw − (Ms ⊗ I3)w‖/‖Mw‖ for a random w, limit 2 γ_k(M) ‖|M||w|‖/‖Mw‖.
    """

    backward_errors: np.ndarray
    backward_error_limit: float
    relative_residuals: np.ndarray
    orthonormality_error: float
    orthonormality_limit: float
    rigid_fractions: np.ndarray
    rigid_content_limit: float
    zero_energy_floor: float
    inertia_count: int
    solved_count: int
    check_shift: float
    mass_kron_defect: float
    mass_kron_limit: float

    @property
    def missed(self) -> int:
        """Eigenvalues below the check shift (Sylvester) minus pairs of the solve: 0."""
        return self.inertia_count - self.solved_count

    def lowest(self, keep: int) -> "Verification":
        """The record of the first ``keep`` modes (the Sylvester count stays the solve's)."""
        return replace(self, backward_errors=self.backward_errors[:keep],
                       relative_residuals=self.relative_residuals[:keep],
                       rigid_fractions=self.rigid_fractions[:keep])

    def problems(self, eigenvalues: np.ndarray, rigid_count: int) -> list[str]:
        """One line per failed check, with its numbers; empty when every check holds."""
        out = []
        worst = int(self.backward_errors.argmax())
        if self.backward_errors[worst] > self.backward_error_limit:
            out.append(f"backward error {self.backward_errors[worst]:.3e} of mode {worst} > "
                       f"{self.backward_error_limit:.1e}")
        if self.orthonormality_error > self.orthonormality_limit:
            out.append(f"M-orthonormality error {self.orthonormality_error:.3e} > "
                       f"{self.orthonormality_limit:.1e}")
        elastic = self.rigid_fractions[rigid_count:]
        if elastic.max(initial=0.0) > self.rigid_content_limit:
            out.append(f"elastic mode {int(elastic.argmax()) + 1} has rigid content "
                       f"{elastic.max():.3e} > {self.rigid_content_limit:.1e}")
        lowest = eigenvalues[rigid_count:].min(initial=np.inf)
        if lowest <= self.zero_energy_floor:
            out.append(f"a seventh zero-energy mode (eigenvalue {lowest:.3e}, below the floor "
                       f"{self.zero_energy_floor:.3e} of what the solve can tell from zero): is "
                       "the mesh one connected body?")
        if self.missed:
            out.append(f"Sylvester count below {self.check_shift:.6g} is {self.inertia_count}, "
                       f"but {self.solved_count} eigenvalues were found: {self.missed} missed")
        if self.mass_kron_defect > self.mass_kron_limit:
            out.append(f"M differs from Ms ⊗ I3 by {self.mass_kron_defect:.3e} > "
                       f"{self.mass_kron_limit:.1e}: the mass is not isotropic on a blocked "
                       "space (DESIGN §2)")
        return out

    def to_json(self) -> dict:
        """Each check's measured value beside its limit (``modes.json`` ``verification``)."""
        return {
            "backward_error": {"measured": float(self.backward_errors.max()),
                               "limit": self.backward_error_limit,
                               "per_mode": self.backward_errors.tolist()},
            "m_orthonormality": {"measured": self.orthonormality_error,
                                 "limit": self.orthonormality_limit},
            "rigid_content": {"measured": float(self.rigid_fractions[6:].max(initial=0.0)),
                              "limit": self.rigid_content_limit},
            "zero_energy": {"floor": self.zero_energy_floor},
            "sylvester": {"shift": self.check_shift, "count": self.inertia_count,
                          "found": self.solved_count},
            "mass_kron": {"measured": self.mass_kron_defect, "limit": self.mass_kron_limit},
        }


@dataclass(frozen=True)
class Modes:
    """Free-free modes, rigid first, then elastic in ascending order.

    ``vectors`` holds this rank's owned rows (node-major, direction-minor) of the
    M-orthonormal mode shapes, one column per mode.
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    rigid_count: int
    shift: float
    center_m: np.ndarray  # centre of mass the rotation fields are taken about
    verification: Verification
    timings_s: dict[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

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

    @property
    def relative_residuals(self) -> np.ndarray:
        """‖Kφ − λMφ‖/‖Kφ‖ (rigid modes: over λ₇‖Mφ‖); reported, the check is the backward error."""
        return self.verification.relative_residuals

    @property
    def orthonormality_error(self) -> float:
        return self.verification.orthonormality_error

    @property
    def rigid_fractions(self) -> np.ndarray:
        return self.verification.rigid_fractions

    @property
    def inertia_count(self) -> int:
        return self.verification.inertia_count

    @property
    def missed_eigenvalues(self) -> int:
        """Eigenvalues below the check shift (Sylvester) minus eigenvalues of the solve: 0."""
        return self.verification.missed

    def lowest(self, count: int) -> "Modes":
        """The same solve restricted to its rigid modes and lowest ``count`` elastic modes."""
        keep = self.rigid_count + count
        return replace(self, eigenvalues=self.eigenvalues[:keep], vectors=self.vectors[:, :keep],
                       verification=self.verification.lowest(keep))

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


@dataclass(frozen=True)
class Shift:
    """Where the solve starts: the centre of mass, the bound λ̂₇ ≥ λ₇ and σ = −0.1 λ̂₇."""

    center_m: np.ndarray
    first_elastic_bound: float
    sigma: float


def shift_estimate(model: FEModel) -> Shift:
    """The shift of the solve (module docstring): a few mat-vecs on polynomial fields."""
    center = mass_properties(model.Ms, model.nodes, model.material.rho).center_of_mass_m
    bound = ritz_first_elastic(model, center)
    return Shift(center_m=center, first_elastic_bound=bound, sigma=-0.1 * bound)


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


def krylov_basis_size(wanted: int) -> int:
    """SLEPc's default Krylov–Schur basis size for ``wanted`` + 1 eigenpairs (nev ≤ 500)."""
    nev = wanted + 1
    return max(2 * nev, nev + 15)


def _monitor(progress: Progress, nev: int):
    """A SLEPc monitor printing converged pairs every PROGRESS_INTERVAL_S seconds."""
    last = [time.perf_counter()]

    def monitor(eps, its, nconv, eig, err) -> None:
        now = time.perf_counter()
        if now - last[0] > PROGRESS_INTERVAL_S:
            last[0] = now
            progress(f"eigen-solve: restart {its}, {min(nconv, nev)} of {nev} pairs converged")

    return monitor


def _run_eps(model: FEModel, nev: int, sigma: float, cfg: ModesConfig,
             deflation: np.ndarray, progress: Progress) -> SLEPc.EPS:
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
    eps.setMonitor(_monitor(progress, nev))
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
    return _m_normalised(model, Y)


def _m_normalised(model: FEModel, Y: np.ndarray) -> np.ndarray:
    norms = np.sqrt(model.comm.allreduce(np.sum(Y * mass_dense(model, Y), axis=0), op=MPI.SUM))
    return Y / norms


def without_rigid(model: FEModel, rigid: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Y − R (Rᵀ M Y), M-normalised: the rigid content of Y removed (R M-orthonormal)."""
    return _m_normalised(model, Y - rigid @ gram(model.comm, rigid, mass_dense(model, Y)))


@dataclass(frozen=True)
class KrylovModes:
    """What the Krylov solve returns: wanted elastic pairs (purified) and the next eigenvalue."""

    eigenvalues: np.ndarray
    vectors: np.ndarray
    next_eigenvalue: float
    iterations: int


def krylov_modes(model: FEModel, wanted: int, shift: Shift, rigid: np.ndarray,
                 cfg: ModesConfig, progress: Progress = quiet) -> KrylovModes:
    """The ``wanted`` lowest elastic pairs by shift-invert Krylov–Schur in the M-orthogonal
    complement of ``rigid``, purified and freed of rigid content (module docstring)."""
    # one eigenpair past the last wanted one places the Sylvester check in the gap after it;
    # more only lengthen the Krylov basis (a restart more for four: 25 % of the solve)
    eps = _run_eps(model, wanted + 1, shift.sigma, cfg, rigid, progress)
    nconv = eps.getConverged()
    its = eps.getIterationNumber()
    if nconv < wanted + 1:
        reason = eps.getConvergedReason()
        eps.destroy()
        raise EigenSolveError(
            f"eigen-solver converged {nconv} of {wanted + 1} eigenpairs in {its} iterations "
            f"(max_iterations = {cfg.max_iterations}, tolerance = {cfg.tolerance:g}, "
            f"reason {reason}); raise [modes] max_iterations or loosen tolerance")
    values = np.array([eps.getEigenvalue(i).real for i in range(nconv)])
    order = np.argsort(values)
    vr = model.K.createVecRight()
    ritz = np.empty((vr.getLocalSize(), wanted))
    for j, i in enumerate(order[:wanted]):
        eps.getEigenvector(int(i), vr)
        ritz[:, j] = vr.array
    elastic = purified(model, eps.getST().getKSP().getPC().getFactorMatrix(), ritz)
    eps.destroy()
    return KrylovModes(eigenvalues=values[order[:wanted]],
                       vectors=without_rigid(model, rigid, elastic),
                       next_eigenvalue=float(values[order[wanted]]), iterations=its)


def _norms(comm: MPI.Comm, X: np.ndarray) -> np.ndarray:
    return np.sqrt(comm.allreduce(np.sum(X ** 2, axis=0), op=MPI.SUM))


def verify(model: FEModel, eigenvalues: np.ndarray, vectors: np.ndarray, tolerance: float,
           sigma: float, check_shift: float, rigid_count: int = 6,
           timings: dict[str, float] | None = None) -> Verification:
    """Measure every check of :class:`Verification` for the pairs (eigenvalues, vectors)
    against the limits of this problem; the Sylvester count at ``check_shift`` factorises
    K − σM once (its seconds in ``timings["inertia_check"]``). Collective; raises nothing
    (see :meth:`Verification.problems`)."""
    comm = model.comm
    K_vectors = mat_dense(model.K, vectors)
    M_vectors = mass_dense(model, vectors)
    K_magnitude = magnitude_product(model.K, vectors)
    n = model.nodes.shape[0]
    M_magnitude = magnitude_product(model.Ms, np.abs(vectors).reshape(n, -1)).reshape(
        vectors.shape)  # |M| |φ| = (|Ms| ⊗ I3) |φ|
    k_K, k_M = max_row_entries(model.K), 3 * max_row_entries(model.Ms)
    res = K_vectors - M_vectors * eigenvalues
    res_norm, k_norm = _norms(comm, res), _norms(comm, K_vectors)
    mk_norm, mm_norm = _norms(comm, K_magnitude), _norms(comm, M_magnitude)
    backward = res_norm / (mk_norm + np.abs(eigenvalues) * mm_norm)
    lam_ref = eigenvalues[rigid_count] if len(eigenvalues) > rigid_count else 1.0
    # elastic: ‖Kφ − λMφ‖/‖Kφ‖; rigid (Kφ ≈ 0): ‖Kφ − λMφ‖/(λ₇‖Mφ‖)
    relative = np.where(np.arange(len(eigenvalues)) < rigid_count,
                        res_norm / (lam_ref * _norms(comm, M_vectors)), res_norm / k_norm)
    grams = gram(comm, vectors, M_vectors)
    magnitude_grams = gram(comm, np.abs(vectors), M_magnitude)
    ortho = float(np.abs(grams - np.eye(len(grams))).max())
    ortho_limit = tolerance + gamma(k_M) * float(magnitude_grams.max())
    rigid = grams[:rigid_count]
    rigid_fractions = np.sum(rigid ** 2, axis=0) / np.diag(grams)
    t0 = time.perf_counter()
    inertia = inertia_below(model, check_shift)
    if timings is not None:
        timings["inertia_check"] = time.perf_counter() - t0
    defect, defect_limit = kron_mass_check(model, gamma(k_M))
    return Verification(
        backward_errors=backward, backward_error_limit=max(tolerance, gamma(k_K)),
        relative_residuals=relative, orthonormality_error=ortho,
        orthonormality_limit=ortho_limit, rigid_fractions=rigid_fractions,
        rigid_content_limit=rigid_count * ortho_limit ** 2,
        zero_energy_floor=(tolerance + gamma(k_K)) * abs(sigma), inertia_count=inertia,
        solved_count=len(eigenvalues), check_shift=check_shift, mass_kron_defect=defect, mass_kron_limit=defect_limit)


def wanted_modes(model: FEModel, cfg: ModesConfig, timings: dict[str, float]) -> int:
    """Elastic modes to solve for: ``cfg.count``, or the Sylvester count below
    ``cfg.max_frequency_hz``; EigenSolveError if none or more than the space can hold."""
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
    if 6 + wanted + 2 > model.ndofs // 2:
        raise EigenSolveError(f"{wanted} elastic modes requested, but the space has only "
                              f"{model.ndofs} degrees of freedom; ask for fewer than "
                              f"{model.ndofs // 2 - 8}")
    return wanted


def cut_cluster_warning(last: float, following: float, count: int) -> str | None:
    """A warning when the last wanted eigenvalue and the next are closer than CLUSTER_SPLIT:
    the count then keeps an arbitrary part of a (near-)repeated group, chosen by the solver,
    so the reduced basis is not continuous in the body's shape (a square beam's bending pair
    kept half, docs/stability.md)."""
    split = (following - last) / following
    if split >= CLUSTER_SPLIT:
        return None
    hz = np.sqrt(np.array([last, following])) / (2 * np.pi)
    return (f"{count} elastic modes cut a near-repeated group: mode {count} at {hz[0]:.6g} Hz and "
            f"the next at {hz[1]:.6g} Hz (relative split {split:.1e}); the solver chooses which "
            f"combination is kept: ask for {count + 1} or more so the group is whole")


def solve_free_free(model: FEModel, cfg: ModesConfig, progress: Progress = quiet,
                    memory_check: Callable[[int], None] | None = None) -> Modes:
    """The six rigid and the requested elastic modes of (K, M), verified.

    ``cfg.count`` elastic modes, or every elastic mode below ``cfg.max_frequency_hz``
    (counted beforehand with :func:`inertia_below`). ``memory_check(wanted)`` may refuse
    the count before the Krylov basis is allocated.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    shift = shift_estimate(model)
    timings["shift_estimate"] = time.perf_counter() - t0
    wanted = wanted_modes(model, cfg, timings)
    if memory_check is not None:
        memory_check(wanted)
    rigid = m_orthonormal(model, rigid_body_fields(model.nodes, shift.center_m))
    progress(f"eigen-solve: {wanted} elastic modes of {model.ndofs} DOFs, shift "
             f"{shift.sigma:.4g}, rigid modes deflated")
    t0 = time.perf_counter()
    found = krylov_modes(model, wanted, shift, rigid, cfg, progress)
    timings["eigensolve"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    vectors = np.hstack([rigid, found.vectors])
    K_rigid = mat_dense(model.K, rigid)
    values = np.concatenate([np.diag(gram(model.comm, rigid, K_rigid)), found.eigenvalues])
    check_shift = 0.5 * (values[-1] + found.next_eigenvalue)
    verification = verify(model, values, vectors, cfg.tolerance, shift.sigma, check_shift,
                          timings=timings)
    timings["verification"] = time.perf_counter() - t0 - timings["inertia_check"]
    warning = cut_cluster_warning(values[-1], found.next_eigenvalue, wanted)
    if warning:
        progress(f"warning: {warning}")
    modes = Modes(eigenvalues=values, vectors=vectors, rigid_count=6, shift=shift.sigma,
                  center_m=shift.center_m, verification=verification, timings_s=timings,
                  warnings=(warning,) if warning else ())
    problems = verification.problems(values, 6)
    if problems:
        raise EigenSolveError("eigen-solve check failed: " + "; ".join(problems))
    return modes
