"""The checks of a free-free solve, each against the limit round-off and the solver tolerance
allow for the problem at hand (docs/design.md §3): nothing here is a fixed constant.

Round-off in a product with a matrix whose rows hold k entries is bounded by
γ_k = kε/(1 − kε) times the product of the magnitudes (|A||x|), and the Krylov tolerance
bounds what the solver itself leaves. The low modes of a slender body are where this
matters: K φ is a small difference of large terms there, so ‖Kφ − λMφ‖/‖Kφ‖ grows like
(L/h)⁴ while the backward error, which compares the residual with the magnitudes it is
computed from, stays near ε.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from mpi4py import MPI

from gcms_fenicsx.fe.algebra import gram, magnitude_product, mat_dense, max_row_entries
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mass import kron_mass_check, mass_dense

EPS = float(np.finfo(float).eps)


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
                       "space (docs/design.md §2)")
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


def _norms(comm: MPI.Comm, X: np.ndarray) -> np.ndarray:
    return np.sqrt(comm.allreduce(np.sum(X ** 2, axis=0), op=MPI.SUM))


def verify(model: FEModel, eigenvalues: np.ndarray, vectors: np.ndarray, tolerance: float,
           sigma: float, check_shift: float, inertia_count: int,
           rigid_count: int = 6) -> Verification:
    """Measure every check of :class:`Verification` for the pairs (eigenvalues, vectors)
    against the limits of this problem, with ``inertia_count`` the Sylvester count of
    eigenvalues below ``check_shift`` (``factor.inertia_refactorised``). Collective; raises
    nothing (see :meth:`Verification.problems`)."""
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
    defect, defect_limit = kron_mass_check(model, gamma(k_M))
    return Verification(
        backward_errors=backward, backward_error_limit=max(tolerance, gamma(k_K)),
        relative_residuals=relative, orthonormality_error=ortho,
        orthonormality_limit=ortho_limit, rigid_fractions=rigid_fractions,
        rigid_content_limit=rigid_count * ortho_limit ** 2,
        zero_energy_floor=(tolerance + gamma(k_K)) * abs(sigma), inertia_count=inertia_count,
        solved_count=len(eigenvalues), check_shift=check_shift, mass_kron_defect=defect, mass_kron_limit=defect_limit)
