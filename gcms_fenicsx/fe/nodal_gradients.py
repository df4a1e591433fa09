"""The gradient of a nodal field at the nodes a scene's stresses are recovered at: the stress
modes' finite-element part (docs/design.md §9).

A P2 field's gradient is continuous inside a cell and jumps between cells, so at a node it has
one value per cell that holds the node. The value recorded is their mean (every cell counts
alike, whatever its size): for the node's row of

    ∇v(X_i) ≈ (1/|c(i)|) Σ_{c ∋ i} Σ_a v_a ∇N_a^c(X_i) = Σ_a B_{(i, ·), a} v_a,

one sparse operator B (3 rows a node, its columns the mesh file's nodes) that applies to any
nodal field alike: to the reduced model's fields F (the gradients D = B F the online recovery
needs) and to a full-order displacement, so a full-order reference's stress is formed the same
way, at the same nodes. Averaging the gradient, then forming the stress, is averaging the
stress tensor of the co-rotated law (linear in F for a given frame), which on a P2 cantilever
is within 0.16 % of beam theory away from the clamp; averaging a von Mises value instead is
1.9 % off (design §9). The cost in accuracy is that of any nodal average: at a node on a sharp
re-entrant edge the cells disagree most, and the mean is one value of a stress the
continuum makes singular there — it converges with the mesh no better than the edge allows.

The physical gradients of the cell's basis functions at its own nodes are J⁻ᵀ ∇_ξ N with the
Jacobian of the cell's (possibly curved) geometry, from basix's P2 tabulation: the geometry's
cell-local nodes are the space's (``fe.node_order``). Each rank takes its owned cells, a block
at a time; rank 0 sums the ranks' rows, so one and two ranks give the same operator to
round-off. Collective.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import basix
import numpy as np
import scipy.sparse
from dolfinx import fem
from dolfinx.mesh import exterior_facet_indices

from gcms_fenicsx.config.stress_outputs import SURFACE, StressOutputs
from gcms_fenicsx.fe.mesh import BodyMesh
from gcms_fenicsx.files.stress_nodes import SparseRows, StressNodes
from gcms_fenicsx.runtime.progress import Progress, quiet

#: Cells whose basis gradients are formed at once: 10 nodes × 10 functions × 3 each, so a
#: block holds 300 · 8192 doubles (20 MB) however large the mesh.
CELLS_PER_BLOCK = 8192
#: The basix P2 tetrahedron's local nodes in the order of VTK's (and XDMF's) Tetrahedron_10:
#: vertices, then edges 01, 12, 02, 03, 13, 23 (basix numbers its edges 23, 13, 12, 03, 02, 01);
#: a P1 tetrahedron's vertices are in VTK's order already.
VTK_TET10 = np.array([0, 1, 2, 3, 9, 6, 8, 7, 5, 4])


@dataclass(frozen=True)
class _Cells:
    """This rank's owned cells: their nodes' indices in the mesh file and coordinates."""

    nodes: np.ndarray         # (cells, k) mesh-file indices, basix's local order
    x: np.ndarray             # (cells, k, 3)


def _owned_cells(mesh: Any) -> _Cells:
    cells = mesh.topology.index_map(mesh.topology.dim)
    geometry = mesh.geometry.dofmap.array.reshape(cells.size_local + cells.num_ghosts, -1)
    geometry = geometry[:cells.size_local]
    file_index = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    return _Cells(nodes=file_index[geometry], x=mesh.geometry.x[geometry])


def _reference_gradients(degree: int) -> np.ndarray:
    """∇_ξ N_a at the element's own nodes p: (p, a, 3)."""
    element = basix.create_element(basix.ElementFamily.P, basix.CellType.tetrahedron, degree,
                                   basix.LagrangeVariant.equispaced)
    table = element.tabulate(1, element.points)           # (1 + 3, points, functions, 1)
    return np.moveaxis(table[1:, :, :, 0], 0, -1)


def basis_gradients(x: np.ndarray, dN: np.ndarray) -> np.ndarray:
    """∇_X N_a at the cells' nodes p, (cells, p, a, 3), for cells of node coordinates x
    (cells, a, 3): ∇_X N = J⁻ᵀ ∇_ξ N with J = Σ_a x_a ⊗ ∇_ξ N_a at p."""
    J = np.einsum("cak,pad->cpkd", x, dN)
    return np.einsum("pad,cpdk->cpak", dN, np.linalg.inv(J))


def requested_nodes(body: BodyMesh, stress: StressOutputs, comm: Any) -> dict[str, np.ndarray]:
    """The mesh-file indices of the nodes on each requested group's facets (``surface``:
    every exterior facet), sorted, on every rank."""
    mesh = body.mesh
    tdim = mesh.topology.dim
    Vs = fem.FunctionSpace(mesh, ("Lagrange", mesh.geometry.cmap.degree))
    cells = mesh.topology.index_map(tdim)
    count = cells.size_local + cells.num_ghosts
    space = Vs.dofmap.list.array.reshape(count, -1)
    geometry = mesh.geometry.dofmap.array.reshape(count, -1)
    index_map = Vs.dofmap.index_map
    index = np.full(index_map.size_local + index_map.num_ghosts, -1, dtype=np.int64)
    index[space.ravel()] = np.asarray(mesh.geometry.input_global_indices,
                                      dtype=np.int64)[geometry.ravel()]
    if stress.surface:
        mesh.topology.create_connectivity(tdim - 1, tdim)
        facets = {SURFACE: exterior_facet_indices(mesh.topology)}
    else:
        tags = body.facet_tags
        facets = {name: tags.indices[tags.values == body.groups[name]] for name in stress.groups}
    out = {}
    for name, where in facets.items():
        local = index[fem.locate_dofs_topological(Vs, tdim - 1, where)]
        out[name] = np.unique(np.concatenate(comm.allgather(local)))
    return out


def nodal_gradient_operator(cells: _Cells, rows_of: np.ndarray, row_count: int,
                            node_count: int, comm: Any) -> scipy.sparse.csr_matrix | None:
    """B (3 · row_count × node_count, rank 0; None elsewhere): row 3 r + k the mean over the
    cells holding node ``rows_of⁻¹(r)`` of ∂/∂X_k of the nodal field (module docstring);
    ``rows_of`` maps a mesh-file node to its row r, or −1 for a node without one."""
    dN = _reference_gradients(_degree(cells.nodes.shape[1]))
    B = scipy.sparse.csr_matrix((3 * row_count, node_count))
    counts = np.zeros(row_count)
    for start in range(0, len(cells.nodes), CELLS_PER_BLOCK):
        nodes = cells.nodes[start:start + CELLS_PER_BLOCK]
        rows = rows_of[nodes]                                    # (c, p)
        c, p = np.nonzero(rows >= 0)
        if not len(c):
            continue
        grads = basis_gradients(cells.x[start:start + CELLS_PER_BLOCK][np.unique(c)], dN)
        which = np.searchsorted(np.unique(c), c)
        values = grads[which, p]                                  # (pairs, a, 3)
        r = rows[c, p]
        np.add.at(counts, r, 1.0)
        row_index = np.broadcast_to((3 * r)[:, None, None] + np.arange(3), values.shape)
        col_index = np.broadcast_to(nodes[c][:, :, None], values.shape)
        B = B + scipy.sparse.csr_matrix((values.ravel(), (row_index.ravel(), col_index.ravel())),
                                        shape=B.shape)
    parts = comm.gather((B.tocoo(), counts), root=0)
    if comm.rank != 0:
        return None
    total = sum((part for part, _ in parts[1:]), parts[0][0]).tocsr()
    held = sum(c for _, c in parts)
    if np.any(held == 0):
        raise ValueError(f"{int(np.sum(held == 0))} requested nodes lie in no cell")
    return (scipy.sparse.diags(np.repeat(1.0 / held, 3)) @ total).tocsr()


def _degree(nodes_per_cell: int) -> int:
    """The Lagrange degree of a tetrahedron with this many nodes (4: 1, 10: 2)."""
    degrees = {4: 1, 10: 2}
    if nodes_per_cell not in degrees:
        raise ValueError(f"a tetrahedral mesh with {nodes_per_cell} nodes per cell")
    return degrees[nodes_per_cell]


def stress_nodes(body: BodyMesh, stress: StressOutputs, node_count: int, key: str,
                 progress: Progress = quiet, comm: Any = None) -> StressNodes | None:
    """The stress modes' mesh part for ``stress``: the requested nodes by group, the operator B
    at them — at every node, with the cells (VTK order) for the whole-body fields, when
    ``stress.whole_body`` (VTK's node order, 4 or 10 a cell) — on rank 0 (None on the others). Collective."""
    comm = body.mesh.comm if comm is None else comm
    groups = requested_nodes(body, stress, comm)
    nodes = np.unique(np.concatenate(list(groups.values())))
    cells = _owned_cells(body.mesh)
    rows_nodes = np.arange(node_count) if stress.whole_body else nodes
    progress(f"stress modes: the gradient at {len(nodes)} nodes"
             + (f" (and the rest of the {node_count} for the whole-body fields)"
                if stress.whole_body else ""))
    rows_of = np.full(node_count, -1, dtype=np.int64)
    rows_of[rows_nodes] = np.arange(len(rows_nodes))
    B = nodal_gradient_operator(cells, rows_of, len(rows_nodes), node_count, comm)
    width = cells.nodes.shape[1]
    vtk = (cells.nodes[:, VTK_TET10] if width == 10 else cells.nodes) if stress.whole_body \
        else np.zeros((0, width), dtype=np.int64)
    gathered = comm.gather(vtk, root=0)
    if comm.rank != 0:
        return None
    B.sort_indices()
    return StressNodes(key=key, node_count=node_count, gradient_nodes=rows_nodes,
                       requested=np.searchsorted(rows_nodes, nodes),
                       groups={name: np.searchsorted(nodes, g) for name, g in groups.items()},
                       gradient=SparseRows(B.indptr.astype(np.int64), B.indices.astype(np.int64),
                                           B.data, B.shape),
                       cells=np.concatenate(gathered))
