"""Named node sets of the body (joints, loads, sensors) with the weights of their mean position.

A surface group's position is its area-weighted mean, x̄ = (1/A) ∫_Γ x dA. With x
interpolated in the scalar P_k space, x̄ = Σ_i w_i x_i with w_i = ∫_Γ N_i dA / A: one
assembled vector per group. Each group's facets are re-tagged 1 in a fresh MeshTags, so
one compiled form serves every group. A group holds the nodes of positive weight, and of
those not the ones below ``WEIGHT_FLOOR`` of their sum: on a flat P2 facet the vertex
functions integrate to zero, so a vertex's assembled weight is round-off of either sign,
which machines differ in. (A curved facet's vertex integrals can be truly negative; those
nodes are left out as before, −0.13 % of the default crankshaft's end_x0 area.)
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from dolfinx.mesh import meshtags
from petsc4py import PETSc

from gcms_fenicsx.fe.mesh import BodyMesh

#: A node whose weight is below this fraction of its group's positive weights is not in it (the
#: round-off of a flat P2 facet's vertex integral, which is zero, is 1e-19..1e-17 of the area;
#: the smallest true weights of the default crankshaft, vertices of curved facets, are 4e-6).
WEIGHT_FLOOR = 1e-12


def group_weights(body: BodyMesh, Vs: fem.FunctionSpace) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """For every surface group: (global node indices, weights summing to 1), on every rank.

    Node indices are global indices of the scalar space ``Vs`` (the one of Ms), the
    numbering in which ``pipeline.reduced_model`` gathers nodal rows.
    """
    mesh = body.mesh
    v = ufl.TestFunction(Vs)
    index_map = Vs.dofmap.index_map
    owned = index_map.size_local
    first = index_map.local_range[0]
    out = {}
    for name, tag in sorted(body.groups.items()):
        facets = body.facet_tags.indices[body.facet_tags.values == tag]
        marker = meshtags(mesh, mesh.topology.dim - 1, facets,
                          np.ones(len(facets), dtype=np.int32))
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=marker)
        vec = assemble_vector(fem.form(v * ds(1)))
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        local = vec.array[:owned]
        nz = np.flatnonzero(local > 0.0)
        nodes = np.concatenate(mesh.comm.allgather(first + nz)).astype(np.int64)
        weights = np.concatenate(mesh.comm.allgather(local[nz]))
        if not weights.sum() > 0:
            raise ValueError(f"surface group {name!r} has no facets in the mesh")
        kept = weights > WEIGHT_FLOOR * weights.sum()
        nodes, weights = nodes[kept], weights[kept]
        area = weights.sum()
        order = np.argsort(nodes)
        out[name] = (nodes[order], weights[order] / area)
    return out
