"""GCMS shape vectors as scalar nodal fields: Φ = F ⊗ I3 (reference eqs. (1)–(3), docs/design.md §2).

What this module is for: the field matrix F = [1, X, Y, Z, φ_1^1, φ_1^2, φ_1^3, φ_2^1, …]
(X measured from the centre of mass), its small Gram matrices G = Fᵀ Ms F and FᵀF,
Kr = Φᵀ K Φ (from K's stored node blocks, without Φ; Mr = G ⊗ I3 is
``modal_basis.reduced_mass``), and the dense Φ only when a caller asks.
Column (f, l) of Φ — field f in direction l — is column 3f + l, which is the reference's
order: Φt (l), Φr (k, l), then Φf (m, k, l).
What it is not for: deciding which fields to keep (``selection``).

F's rows are this rank's owned nodes; the Gram and reduced matrices are summed over
ranks and identical on every rank (they are small). :func:`modal_basis` gathers it all on
rank 0 as the plain product the later stages use.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
from mpi4py import MPI

from gcms_fenicsx.fe.algebra import column_rows, gram, mat_dense
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mesh import BodyMesh
from gcms_fenicsx.fe.modes import Modes
from gcms_fenicsx.fe.node_groups import group_weights
from gcms_fenicsx.fe.node_order import input_node_indices
from gcms_fenicsx.files.reduced_model import NodeGroup
from gcms_fenicsx.files.modal_basis import AXES, ModalBasis, field_names, symmetric


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


def field_basis(model: FEModel, modes: Modes) -> FieldBasis:
    """F from the undeformed node coordinates and the elastic mode shapes (eqs. (1)–(3) as fields)."""
    center = modes.center_m
    shapes = modes.elastic_vectors  # (3 n_owned, Nm), node-major
    attached = len(modes.attachment_labels)
    if attached:
        shapes = np.hstack([shapes, modes.attachment])
    n = model.nodes.shape[0]
    mode_fields = shapes.reshape(n, 3, -1).transpose(0, 2, 1).reshape(n, -1)  # (n, Nm·3): m, k
    F = np.hstack([np.ones((n, 1)), model.nodes - center, mode_fields])
    MsF = mat_dense(model.Ms, F)
    comm = model.comm
    return FieldBasis(fields=F, names=field_names(shapes.shape[1] - attached, attached),
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


def reduced_stiffness(model: FEModel, fields: np.ndarray) -> np.ndarray:
    """Kr = Φᵀ K Φ for Φ = F ⊗ I3, from this rank's rows of K, without forming Φ.

    On the blocked space K is stored in 3×3 node blocks: row (i, k) (node i, direction k)
    holds, for each neighbour node j, the columns (j, 0), (j, 1), (j, 2) side by side, and
    node i's three rows have the same neighbours. Every third stored value, from offset l,
    is therefore a node-column matrix A_l[(i, k), j] = K[(i, k), (j, l)], and
        (A_l F)[(i, k), g] = Σ_j K[(i, k), (j, l)] F[j, g] = (K Φ)[(i, k), (g, l)],
        Kr[(f, k), (g, l)] = Σ_i F[i, f] (A_l F)[(i, k), g].
    K is symmetric (block (l, k) of Kr is block (k, l) transposed), so for column direction l
    only the rows k ≤ l are multiplied: the first l + 1 of each node's three rows, which
    are stored one after another. Each sparse product has one column per field, and the
    three read two thirds of K's stored entries.
    Columns owned by other ranks take their rows of F from there (``fe.column_rows``).
    Memory: a copy of this rank's rows of K (values and column numbers) while Kr is formed.
    """
    K = model.K
    indptr, indices, values = K.getValuesCSR()  # this rank's rows; global column numbers
    n, nf = fields.shape
    lengths = np.diff(indptr)
    nodes, direction = np.divmod(indices[::3], 3)  # each stored triple: (node j, direction 0)?
    blocked = (len(lengths) == 3 * n and not np.any(lengths % 3)
               and not np.any(lengths.reshape(n, 3) != lengths[::3, None])
               and not np.any(direction))
    if not model.comm.allreduce(bool(blocked), op=MPI.LAND):  # every rank raises, none waits
        raise ValueError(f"K ({len(lengths)} rows on rank {model.comm.rank}) is not stored in "
                         f"3×3 node blocks of the {n} nodes of F there: not the stiffness of "
                         "a blocked vector space")
    columns, F = column_rows(K.getComm(), fields, K.getOwnershipRange()[0] // 3, nodes)
    first = indptr[:-1:3] // 3  # where node i's rows start among the entries of an A_l
    neighbours = lengths[::3] // 3  # stored neighbours of node i (each of its rows)
    local = np.empty((nf, 3, nf, 3))
    for l in range(3):
        row_lengths = np.repeat(neighbours, l + 1)  # rows (i, k) for k ≤ l, node-major
        if l < 2:  # node i's first l + 1 rows: entries first[i] .. first[i] + taken[i]
            taken = (l + 1) * neighbours
            ends = np.cumsum(taken, dtype=indptr.dtype)
            pick = (np.arange(taken.sum(), dtype=indptr.dtype)
                    + np.repeat(first - (ends - taken), taken))
            data, cols = np.take(values[l::3], pick), np.take(columns, pick)
        else:  # all three rows: the stored order itself
            data, cols = values[l::3], columns
        ptr = np.zeros(len(row_lengths) + 1, dtype=indptr.dtype)
        np.cumsum(row_lengths, out=ptr[1:])
        A_l = scipy.sparse.csr_matrix((data, cols, ptr), shape=(len(row_lengths), F.shape[0]))
        KPhi = (A_l @ F).reshape(n, (l + 1) * nf)  # row i: (K Φ)[(i, k), (g, l)], k ≤ l
        local[:, :l + 1, :, l] = (fields.T @ KPhi).reshape(nf, l + 1, nf)
        for k in range(l):
            local[:, l, :, k] = local[:, k, :, l].T
    return symmetric(model.comm.allreduce(local.reshape(3 * nf, 3 * nf), op=MPI.SUM))


def modal_basis(model: FEModel, modes: Modes, body: BodyMesh) -> ModalBasis | None:
    """The body's :class:`~gcms_fenicsx.files.modal_basis.ModalBasis` on rank 0 (None on
    the others): F of every field with G, FᵀF and Kr of all of them (collective), the node
    groups, and the rows gathered in the mesh file's node order (``fe.node_order``), so one
    and two ranks give the same basis."""
    comm = model.comm
    local = field_basis(model, modes)
    stiffness = reduced_stiffness(model, local.fields)
    groups = group_weights(body, model.Vs)
    index = comm.gather(input_node_indices(model.Vs), root=0)
    fields = comm.gather(local.fields, root=0)
    nodes = comm.gather(model.nodes, root=0)
    if comm.rank != 0:
        return None
    rows = np.argsort(np.concatenate(index), kind="stable")  # gathered row of file node i
    position = np.empty_like(rows)
    position[rows] = np.arange(len(rows))                       # file position of gathered row
    return ModalBasis(
        fields=np.vstack(fields)[rows], nodes_m=np.vstack(nodes)[rows],
        gram_mass=local.gram_mass, gram_euclid=local.gram_euclid, stiffness=stiffness,
        eigenvalues=modes.eigenvalues.copy(), rigid_count=modes.rigid_count,
        center_m=np.asarray(modes.center_m, dtype=float), attachment=modes.attachment_labels,
        groups={name: _in_file_order(position, nodes_g, weights)
                for name, (nodes_g, weights) in groups.items()})


def _in_file_order(position: np.ndarray, nodes: np.ndarray, weights: np.ndarray) -> NodeGroup:
    """A group of gathered rows renumbered to file positions, ascending."""
    renumbered = position[nodes]
    order = np.argsort(renumbered)
    return NodeGroup(nodes=renumbered[order].astype(np.int64), weights=weights[order])
