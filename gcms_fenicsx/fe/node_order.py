"""The mesh file's node numbering for the nodes of a Lagrange space: one order of the nodal
rows that does not depend on how many ranks the mesh is distributed over.

dolfinx numbers a space's nodes by rank (each rank's owned block in turn), so F, the node
coordinates and the node groups gathered in that order differ between one and two ranks.
The mesh file's numbering does not: for a space of the mesh's own geometric order, the
cell-local nodes of the space and of the geometry coincide (both basix Lagrange elements
of that degree), and ``geometry.input_global_indices`` gives each geometry node's index in
the file.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem


def input_node_indices(Vs: fem.FunctionSpace) -> np.ndarray:
    """For each owned node of the scalar space ``Vs`` (degree = the mesh's geometric order),
    its index in the mesh file; ValueError for another degree, or if the two numberings'
    node coordinates disagree (checked: they must coincide exactly up to round-off)."""
    mesh = Vs.mesh
    degree = Vs.ufl_element().degree()
    if degree != mesh.geometry.cmap.degree:
        raise ValueError(f"a P{degree} space on an order-{mesh.geometry.cmap.degree} mesh has "
                         "nodes the mesh file does not number")
    cells = mesh.topology.index_map(mesh.topology.dim)
    count = cells.size_local + cells.num_ghosts
    space_nodes = Vs.dofmap.list.array.reshape(count, -1)
    geometry_nodes = mesh.geometry.dofmap.array.reshape(count, -1)
    index_map = Vs.dofmap.index_map
    index = np.full(index_map.size_local + index_map.num_ghosts, -1, dtype=np.int64)
    file_index = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    index[space_nodes.ravel()] = file_index[geometry_nodes.ravel()]
    x = np.empty((len(index), 3))
    x[space_nodes.ravel()] = mesh.geometry.x[geometry_nodes.ravel()]
    owned = index_map.size_local
    coordinates = Vs.tabulate_dof_coordinates()[:owned]
    scale = max(float(np.abs(coordinates).max(initial=0.0)), 1.0)
    if index[:owned].min(initial=0) < 0 or \
            np.abs(x[:owned] - coordinates).max(initial=0.0) > 1e-10 * scale:
        raise ValueError("the space's nodes are not the mesh's geometry nodes")
    return index[:owned]
