"""The free-free eigenproblem K φ = λ M φ: a verified shift-invert Krylov–Schur solve with SLEPc.

What this module is for: the lowest six rigid-body modes and the requested elastic
modes of an unconstrained body, M-orthonormal and sorted, with every claim about them
checked before they are returned (docs/design.md §3). The stage is three named steps: the
shift (:func:`shift_estimate`), the Krylov solve with purified Ritz vectors
(:func:`krylov_modes`) and the verification (``verification.verify``), each testable alone.
A failed check raises :class:`EigenSolveError` with the numbers.
What it is not for: assembly (``assembly``), the factor (``factor``) and writing files
(``mode_shapes``).

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

Cost: one MUMPS factorisation of K − σM, then one triangular solve and a few M-products
per Krylov step (M applied as Ms ⊗ I3, ``mass``), the Ritz vectors purified together in
one multi-RHS solve, and the same factorisation refactorised numerically at the check shift for
the Sylvester count (``factor.inertia_refactorised``: its ordering and analysis reused).
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

from gcms_fenicsx.config.modes import ModesConfig
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.fe.algebra import factor_solve, gram, mat_dense
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.factor import (factor_options, inertia_below, inertia_refactorised,
                                    shifted_matrix)
from gcms_fenicsx.fe.mass import kron_mass_operator, mass_dense, mass_properties
from gcms_fenicsx.fe.modes import Modes
from gcms_fenicsx.fe.static_response import static_responses
from gcms_fenicsx.fe.verification import verify
from gcms_fenicsx.numerics.spectrum import cut_cluster_warning
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.progress import Progress, quiet

#: Seconds between progress lines of a long Krylov solve.
PROGRESS_INTERVAL_S = 3.0


class EigenSolveError(ComputationFailed):
    """The eigen-solve failed or one of its checks did not hold."""


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


def m_orthonormal(model: FEModel, X: np.ndarray) -> np.ndarray:
    """X L⁻ᵀ with Xᵀ M X = L Lᵀ: an M-orthonormal basis of span(X) (Cholesky–Gram–Schmidt)."""
    chol = np.linalg.cholesky(gram(model.comm, X, mass_dense(model, X)))
    return scipy.linalg.solve_triangular(chol, X.T, lower=True).T


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
    factor_options("gcms_eps_st_")
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
    right-hand sides for much less per vector than single solves; docs/design.md §8).
    """
    return _m_normalised(model, factor_solve(model.K, factor, mass_dense(model, ritz)))


def _m_normalised(model: FEModel, Y: np.ndarray) -> np.ndarray:
    norms = np.sqrt(model.comm.allreduce(np.sum(Y * mass_dense(model, Y), axis=0), op=MPI.SUM))
    return Y / norms


def without_rigid(model: FEModel, rigid: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Y − R (Rᵀ M Y), M-normalised: the rigid content of Y removed (R M-orthonormal)."""
    return _m_normalised(model, Y - rigid @ gram(model.comm, rigid, mass_dense(model, Y)))


@dataclass(frozen=True)
class KrylovModes:
    """What the Krylov solve returns: wanted elastic pairs (purified), the next eigenvalue, the
    Sylvester count at the check shift halfway between the two (with its seconds), and the
    static responses K u = f' to the self-equilibrated loads it was given
    (``static_response``), with their iterations and seconds."""

    eigenvalues: np.ndarray
    vectors: np.ndarray
    next_eigenvalue: float
    iterations: int
    check_shift: float
    inertia_count: int
    inertia_seconds: float
    static: np.ndarray | None = None
    static_iterations: int = 0
    static_seconds: float = 0.0


def krylov_modes(model: FEModel, wanted: int, shift: Shift, rigid: np.ndarray,
                 cfg: ModesConfig, progress: Progress = quiet,
                 loads: np.ndarray | None = None) -> KrylovModes:
    """The ``wanted`` lowest elastic pairs by shift-invert Krylov–Schur in the M-orthogonal
    complement of ``rigid``, purified and freed of rigid content (module docstring), and the
    static responses to ``loads`` (``static_response``: preconditioned with the same factor),
    before it is refactorised for the Sylvester count."""
    # one eigenpair past the last wanted one places the Sylvester check in the gap after it;
    # more only lengthen the Krylov basis
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
    ksp = eps.getST().getKSP()
    factor = ksp.getPC().getFactorMatrix()
    vectors = without_rigid(model, rigid, purified(model, factor, ritz))
    eigenvalues = values[order[:wanted]]
    static, static_iterations, t0 = None, 0, time.perf_counter()
    if loads is not None:
        static, static_iterations = static_responses(model, factor, loads, vectors, eigenvalues)
    static_seconds = time.perf_counter() - t0
    last, following = float(values[order[wanted - 1]]), float(values[order[wanted]])
    check_shift = 0.5 * (last + following)
    t0 = time.perf_counter()
    inertia = inertia_refactorised(ksp, model, shift.sigma, check_shift)
    inertia_seconds = time.perf_counter() - t0
    eps.destroy()
    return KrylovModes(eigenvalues=eigenvalues, vectors=vectors, next_eigenvalue=following,
                       iterations=its, check_shift=check_shift, inertia_count=inertia,
                       inertia_seconds=inertia_seconds, static=static,
                       static_iterations=static_iterations, static_seconds=static_seconds)


def wanted_modes(model: FEModel, cfg: ModesConfig, timings: dict[str, float]) -> int:
    """Elastic modes to solve for: ``cfg.count``, or the Sylvester count below
    ``cfg.max_frequency_hz``; EigenSolveError if none or more than the space can hold."""
    if cfg.cut is not None:
        t0 = time.perf_counter()
        cut = cfg.cut
        wanted = cfg.count_from(inertia_below(model, cut) - 6)
        timings["count_below_max_frequency"] = time.perf_counter() - t0
        if wanted < 1:
            raise EigenSolveError(
                f"no elastic mode below max_frequency_hz = {cfg.max_frequency_hz:g} Hz "
                f"(Sylvester count of K − λM at λ = {cut:.6g}: {wanted + 6} eigenvalues, "
                "6 of them rigid)")
    else:
        wanted = cfg.count_from(0)
    if 6 + wanted + 2 > model.ndofs // 2 and cfg.auto:
        raise ConfigError("[modes] count", "auto", f"the scene's band up to "
                          f"{cfg.max_frequency_hz:.4g} Hz (set by its {cfg.band.set_by}) holds "
                          f"{wanted} elastic modes, more than the {model.ndofs} DOFs allow; "
                          "raise [scene] time_step or give a number")
    if 6 + wanted + 2 > model.ndofs // 2:
        raise EigenSolveError(f"{wanted} elastic modes requested, but the space has only "
                              f"{model.ndofs} degrees of freedom; ask for fewer than "
                              f"{model.ndofs // 2 - 8}")
    return wanted


def solve_free_free(model: FEModel, cfg: ModesConfig, progress: Progress = quiet,
                    memory_check: Callable[[int, int, int], None] | None = None,
                    loads: np.ndarray | None = None) -> Modes:
    """The six rigid and the requested elastic modes of (K, M), verified, and the attachment
    modes of ``loads`` (columns: this rank's rows of unit loads, ``fe.attachment``).

    Attachment mode (docs/design.md §3.7): the load relieved of its rigid-body part by the
    inertia forces, f' = f − M R Rᵀ f (R the M-orthonormal rigid modes: Rᵀ f' = 0, a
    self-equilibrated load), its static response K u = f' (``static_response``: exact along
    the computed modes, the rest by conjugate gradients preconditioned with the solve's own
    factor of K − σM), then u − R Rᵀ M u, M-normalised.

    ``cfg.count`` elastic modes, or every elastic mode below ``cfg.max_frequency_hz``
    (counted beforehand with :func:`inertia_below`). ``memory_check(dofs, nodes, wanted)``
    may refuse the count before the Krylov basis is allocated.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    shift = shift_estimate(model)
    timings["shift_estimate"] = time.perf_counter() - t0
    wanted = wanted_modes(model, cfg, timings)
    if memory_check is not None:
        memory_check(model.ndofs, model.num_nodes, wanted)
    rigid = m_orthonormal(model, rigid_body_fields(model.nodes, shift.center_m))
    progress(f"eigen-solve: {wanted} elastic modes of {model.ndofs} DOFs, shift "
             f"{shift.sigma:.4g}, rigid modes deflated")
    t0 = time.perf_counter()
    relieved = None if loads is None else \
        loads - mass_dense(model, rigid) @ gram(model.comm, rigid, loads)
    found = krylov_modes(model, wanted, shift, rigid, cfg, progress, relieved)
    timings["inertia_check"] = found.inertia_seconds
    timings["eigensolve"] = (time.perf_counter() - t0 - found.inertia_seconds
                             - found.static_seconds)
    if loads is not None:
        timings["attachment"] = found.static_seconds
        progress(f"attachment modes: {loads.shape[1]} static responses, "
                 f"{found.static_iterations} preconditioned iterations, "
                 f"{found.static_seconds:.1f} s")

    t0 = time.perf_counter()
    vectors = np.hstack([rigid, found.vectors])
    K_rigid = mat_dense(model.K, rigid)
    values = np.concatenate([np.diag(gram(model.comm, rigid, K_rigid)), found.eigenvalues])
    verification = verify(model, values, vectors, cfg.tolerance, shift.sigma,
                          found.check_shift, found.inertia_count)
    timings["verification"] = time.perf_counter() - t0
    warning = cut_cluster_warning(values[-1], found.next_eigenvalue, wanted)
    if warning:
        progress(f"warning: {warning}")
    modes = Modes(eigenvalues=values, vectors=vectors, rigid_count=6, shift=shift.sigma,
                  center_m=shift.center_m, verification=verification, timings_s=timings,
                  warnings=(warning,) if warning else (),
                  attachment=None if loads is None else without_rigid(model, rigid, found.static))
    problems = verification.problems(values, 6)
    if problems:
        raise EigenSolveError("eigen-solve check failed: " + "; ".join(problems))
    return modes
