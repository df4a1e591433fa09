"""The modal basis of one body as plain data: every GCMS field at every node with its small
matrices, the product the selection and the reduced model are made from, and what
``modes.h5`` keeps (docs/design.md §2, §4).

F = [1, X, Y, Z, φ_1^x, φ_1^y, φ_1^z, φ_2^x, …] holds every candidate scalar field at every
node, rows in the mesh file's node order (the same on any number of ranks); beside it the
small matrices every later stage needs: G = Fᵀ Ms F, FᵀF and Kr = Φᵀ K Φ of all fields
(Φ = F ⊗ I3), so the selection and the reduced matrices of any kept subset need neither
the mesh nor K (for fields F T: Mr = (Tᵀ G T) ⊗ I3, Kr = (T ⊗ I3)ᵀ Kr_all (T ⊗ I3)).
The fields of the lowest k modes are the first 4 + 3k, so a basis of fewer modes is a
leading block (:meth:`ModalBasis.lowest`). NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gcms_fenicsx.files.reduced_model import NodeGroup

RIGID_FIELDS = ("1", "X", "Y", "Z")
AXES = "xyz"


def phi_columns(fields: np.ndarray) -> np.ndarray:
    """The columns of Φ = F ⊗ I3 of the fields ``fields``: (f, l) is column 3f + l."""
    return (3 * np.asarray(fields)[:, None] + np.arange(3)).ravel()


#: The prefix of an attachment mode's field names (:func:`field_names`).
ATTACHMENT_PREFIX = "att"


def field_names(mode_count: int, attachment_count: int = 0) -> tuple[str, ...]:
    """'1', 'X', 'Y', 'Z', then 'phi{m}_{k}' for mode m (1-based) and component k ∈ {x, y, z},
    then 'att{a}_{k}' for attachment mode a."""
    return (RIGID_FIELDS + tuple(f"phi{m + 1}_{AXES[k]}" for m in range(mode_count)
                                 for k in range(3))
            + tuple(f"{ATTACHMENT_PREFIX}{a + 1}_{AXES[k]}" for a in range(attachment_count)
                    for k in range(3)))


def holds_attachment_modes(names: tuple[str, ...] | list[str]) -> bool:
    """Whether fields named ``names`` (:func:`field_names`) include attachment modes."""
    return any(name.startswith(ATTACHMENT_PREFIX) for name in names)


@dataclass(frozen=True)
class ModalBasis:
    """Every candidate field of one body and the small matrices of all of them.

    ``fields`` (N, 4 + 3 Nm) and ``nodes_m`` (N, 3) in the mesh file's node order;
    ``gram_mass`` = Fᵀ Ms F and ``gram_euclid`` = Fᵀ F (fields²); ``stiffness`` Kr of all
    fields (3 fields)², column (f, l) = 3f + l; ``eigenvalues`` the free-free eigenvalues,
    ``rigid_count`` rigid first; ``center_m`` the centre of mass X is measured from;
    ``groups`` the surface groups' nodes (rows of F) and weights; ``attachment`` the labels
    of the attachment modes, whose fields follow the eigenmodes' (docs/design.md §3.7).
    """

    fields: np.ndarray
    nodes_m: np.ndarray
    gram_mass: np.ndarray
    gram_euclid: np.ndarray
    stiffness: np.ndarray
    eigenvalues: np.ndarray
    rigid_count: int
    center_m: np.ndarray
    groups: dict[str, NodeGroup]
    attachment: tuple[str, ...] = ()

    @property
    def mode_count(self) -> int:
        return len(self.eigenvalues) - self.rigid_count

    @property
    def names(self) -> tuple[str, ...]:
        return field_names(self.mode_count, len(self.attachment))

    @property
    def field_count(self) -> int:
        return self.fields.shape[1]

    @property
    def elastic_frequencies_hz(self) -> np.ndarray:
        """f = √λ / 2π of the elastic modes."""
        return np.sqrt(np.maximum(self.eigenvalues[self.rigid_count:], 0.0)) / (2.0 * np.pi)

    def lowest(self, count: int) -> "ModalBasis":
        """The basis of the rigid, the lowest ``count`` elastic and every attachment mode: the
        leading blocks and the attachment ones."""
        if not 0 < count <= self.mode_count:
            raise ValueError(f"{count} modes asked of a basis of {self.mode_count}")
        first = len(RIGID_FIELDS) + 3 * count
        keep = np.r_[:first, len(RIGID_FIELDS) + 3 * self.mode_count:self.field_count]
        columns = phi_columns(keep)
        return replace(self, fields=self.fields[:, keep],
                       gram_mass=self.gram_mass[np.ix_(keep, keep)],
                       gram_euclid=self.gram_euclid[np.ix_(keep, keep)],
                       stiffness=self.stiffness[np.ix_(columns, columns)],
                       eigenvalues=self.eigenvalues[:self.rigid_count + count])

    def attachment_residuals(self) -> "ModalBasis":
        """The basis with each attachment mode u replaced by its part M-orthogonal to the
        basis's eigenmodes, M-normalised: u − Φ (ΦᵀMΦ)⁻¹ ΦᵀM u (docs/design.md §3.7).

        The span of the fields is the same, but the selection's scaled singular values then
        see the part of u the eigenmodes lack at full scale: unorthogonalised, that part is
        small beside u (the static response is mostly in the low modes) and a tolerance of
        1e-4 dropped fields that carry it (the pendulum's error rose from 0.05 % to 32 %).
        Applied to F as F T with T the identity but for the attachment columns, so G, FᵀF
        and Kr transform as Tᵀ G T and (T ⊗ I3)ᵀ Kr (T ⊗ I3). The eigenmodes kept are this
        basis's, which is why this is done here and not when the modes are solved."""
        na = len(self.attachment)
        if not na:
            return self
        rigid = len(RIGID_FIELDS)
        modes = rigid + 3 * np.arange(self.mode_count)[:, None] + np.arange(3)   # (Nm, 3)
        attached = rigid + 3 * self.mode_count + 3 * np.arange(na)[:, None] + np.arange(3)
        G = self.gram_mass

        def inner(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # vector M-products
            return sum(G[np.ix_(a[:, d], b[:, d])] for d in range(3))

        c = np.linalg.solve(inner(modes, modes), inner(modes, attached))          # (Nm, Na)
        T = np.eye(self.field_count)
        for d in range(3):
            T[np.ix_(modes[:, d], attached[:, d])] = -c
        G1 = T.T @ G @ T
        norms = np.sqrt(sum(np.diag(G1)[attached[:, d]] for d in range(3)))      # (Na,)
        for d in range(3):
            T[:, attached[:, d]] /= norms
        T3 = np.kron(T, np.eye(3))
        return replace(self, fields=self.fields @ T, gram_mass=symmetric(T.T @ G @ T),
                       gram_euclid=symmetric(T.T @ self.gram_euclid @ T),
                       stiffness=symmetric(T3.T @ self.stiffness @ T3))

    def mode_fields(self) -> np.ndarray:
        """The elastic mode shapes (N, 3, Nm): node, direction, mode."""
        n, first = self.fields.shape[0], len(RIGID_FIELDS)
        return self.fields[:, first:first + 3 * self.mode_count].reshape(n, -1, 3).transpose(0, 2, 1)


def symmetric(A: np.ndarray) -> np.ndarray:
    """(A + Aᵀ)/2."""
    return 0.5 * (A + A.T)


def reduced_mass(gram_mass: np.ndarray) -> np.ndarray:
    """Mr = Φᵀ M Φ = (Fᵀ Ms F) ⊗ I3, since M = Ms ⊗ I3 (docs/design.md §2)."""
    return np.kron(gram_mass, np.eye(3))
