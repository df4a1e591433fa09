"""GCMS shape vectors as scalar nodal fields: Φ = F ⊗ I3 (reference eqs. (1)–(3), DESIGN §2).

What this module is for: the field matrix F = [1, X, Y, Z, φ_1^1, φ_1^2, φ_1^3, φ_2^1, …]
(X measured from the centre of mass), its small Gram matrices G = Fᵀ Ms F and FᵀF, the
reduced matrices Mr = G ⊗ I3 and Kr = Φᵀ K Φ (by direction blocks of K, without Φ), and
the dense Φ only when a caller asks.
Column (f, l) of Φ — field f in direction l — is column 3f + l, which is the reference's
order: Φt (l), Φr (k, l), then Φf (m, k, l).
What it is not for: deciding which fields to keep (``selection``).

F's rows are this rank's owned nodes; the Gram and reduced matrices are summed over
ranks and identical on every rank (they are small).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from gcms_fenicsx.eigen import Modes
from gcms_fenicsx.fe import FEModel, dense_operand, gram, mat_dense

RIGID_FIELDS = ("1", "X", "Y", "Z")
AXES = "xyz"


@dataclass(frozen=True)
class FieldBasis:
    """The scalar GCMS fields of one body and their Gram matrices.

    ``fields``: this rank's owned rows of F (nodes × fields); ``gram_mass`` = Fᵀ Ms F and
    ``gram_euclid`` = Fᵀ F over all ranks; ``center_m``: the centre of mass X is measured from.
    """

    fields: np.ndarray
    names: tuple[str, ...]
    gram_mass: np.ndarray
    gram_euclid: np.ndarray
    center_m: np.ndarray
    mode_count: int

    @property
    def field_count(self) -> int:
        return len(self.names)

    def column_names(self, kept: np.ndarray | None = None) -> list[str]:
        """Names of the GCMS columns of Φ (field, direction), e.g. ``phi3_y>z``."""
        idx = range(self.field_count) if kept is None else kept
        return [f"{self.names[f]}>{AXES[l]}" for f in idx for l in range(3)]


def field_names(mode_count: int) -> tuple[str, ...]:
    """'1', 'X', 'Y', 'Z', then 'phi{m}_{k}' for mode m (1-based) and component k ∈ {x, y, z}."""
    return RIGID_FIELDS + tuple(f"phi{m + 1}_{AXES[k]}" for m in range(mode_count)
                                for k in range(3))


def field_basis(model: FEModel, modes: Modes) -> FieldBasis:
    """F from the undeformed node coordinates and the elastic mode shapes (eqs. (1)–(3) as fields)."""
    center = modes.center_m
    shapes = modes.elastic_vectors  # (3 n_owned, Nm), node-major
    n = model.nodes.shape[0]
    mode_fields = shapes.reshape(n, 3, -1).transpose(0, 2, 1).reshape(n, -1)  # (n, Nm·3): m, k
    F = np.hstack([np.ones((n, 1)), model.nodes - center, mode_fields])
    MsF = mat_dense(model.Ms, F)
    comm = model.comm
    return FieldBasis(fields=F, names=field_names(shapes.shape[1]),
                      gram_mass=symmetric(gram(comm, F, MsF)),
                      gram_euclid=symmetric(gram(comm, F, F)),
                      center_m=center, mode_count=shapes.shape[1])


def phi_dense(fields: np.ndarray) -> np.ndarray:
    """This rank's rows of the dense Φ = F ⊗ I3 (3N × 3·fields): only when a caller asks."""
    n, nf = fields.shape
    Phi = np.zeros((n, 3, nf, 3))
    for l in range(3):
        Phi[:, l, :, l] = fields
    return Phi.reshape(3 * n, 3 * nf)


def reduced_mass(gram_mass: np.ndarray) -> np.ndarray:
    """Mr = Φᵀ M Φ = (Fᵀ Ms F) ⊗ I3, since M = Ms ⊗ I3 (DESIGN §2)."""
    return np.kron(gram_mass, np.eye(3))


def reduced_stiffness(model: FEModel, fields: np.ndarray) -> np.ndarray:
    """Kr = Φᵀ K Φ by direction blocks, without forming Φ.

    With K_lm the node-by-node block of K coupling direction l to direction m (rows l::3,
    columns m::3), Kr[(f, l), (g, m)] = (Fᵀ K_lm F)[f, g]; K_ml = K_lmᵀ, so six
    sparse-times-dense products with one column per field: a fifth of the work of K Φ with
    its 3·fields columns.
    """
    K = model.K
    comm = K.getComm()
    first, last = K.getOwnershipRange()
    rows = [PETSc.IS().createStride((last - first) // 3, first=first + l, step=3, comm=comm)
            for l in range(3)]
    nf = fields.shape[1]
    local = np.empty((nf, 3, nf, 3))
    operand = None  # F as a PETSc dense matrix, made once for the six products
    for l in range(3):
        for m in range(l, 3):  # K symmetric: the (m, l) block is the (l, m) block transposed
            K_lm = K.createSubMatrix(rows[l], rows[m])
            if operand is None:
                operand = dense_operand(K_lm, fields)
            local[:, l, :, m] = fields.T @ mat_dense(K_lm, fields, operand)
            local[:, m, :, l] = local[:, l, :, m].T
            K_lm.destroy()
    operand.destroy()
    return symmetric(model.comm.allreduce(local.reshape(3 * nf, 3 * nf), op=MPI.SUM))


def symmetric(A: np.ndarray) -> np.ndarray:
    """(A + Aᵀ)/2."""
    return 0.5 * (A + A.T)
