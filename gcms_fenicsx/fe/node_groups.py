"""Named node sets of the body (joints, loads, sensors) with the weights of their mean position.

A surface group's position is its area-weighted mean, x̄ = (1/A) ∫_Γ x dA. With x
interpolated in the scalar P_k space, x̄ = Σ_i w_i x_i with w_i = ∫_Γ N_i dA / A: one
assembled vector per group. Each group's facets are re-tagged 1 in a fresh MeshTags, so
one compiled form serves every group.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from dolfinx.mesh import meshtags
from petsc4py import PETSc

from gcms_fenicsx.fe.mesh import BodyMesh


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
        nz = np.flatnonzero(local > 0)
        nodes = np.concatenate(mesh.comm.allgather(first + nz)).astype(np.int64)
        weights = np.concatenate(mesh.comm.allgather(local[nz]))
        area = weights.sum()
        if area <= 0:
            raise ValueError(f"surface group {name!r} has no facets in the mesh")
        order = np.argsort(nodes)
        out[name] = (nodes[order], weights[order] / area)
    return out
