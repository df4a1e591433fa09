"""The loads of attachment modes: unit forces and moments at node groups as nodal vectors.

A unit force along d at group G acts on the group's weighted mean position (the point
joints and loads act on, ``node_groups``): f = Σ_i w_i e_(i, d), the same distribution a
scene load of 1 N has. A unit moment about a at G is the couple f_i = w_i (a × r_i) / J_a,
r_i = x_i − x̄ the nodes' positions about the group's mean, J_a = Σ_i w_i |a × r_i|²: no net
force and moment a (about a, exactly when a is a principal axis of the group's weights).
The static responses to these loads, relieved of their rigid-body part, are the attachment
modes (``eigensolve.solve_free_free``, docs/design.md §3.7).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from gcms_fenicsx.config.basis import AttachmentLoad
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mesh import BodyMesh
from gcms_fenicsx.fe.node_groups import group_weights


def load_vectors(model: FEModel, body: BodyMesh,
                     loads: tuple[AttachmentLoad, ...]) -> np.ndarray:
    """This rank's rows of the nodal load vectors (3 n_owned × len(loads)), node-major.
    Collective."""
    groups = group_weights(body, model.Vs)
    first = model.Vs.dofmap.index_map.local_range[0]
    n = model.nodes.shape[0]
    out = np.zeros((n, 3, len(loads)))
    for j, load in enumerate(loads):
        nodes, weights = groups[load.group]
        mine = (nodes >= first) & (nodes < first + n)
        rows, w = nodes[mine] - first, weights[mine]
        direction = np.asarray(load.direction)
        if load.kind == "force":
            out[rows, :, j] = w[:, None] * direction
            continue
        mean = model.comm.allreduce(w @ model.nodes[rows], op=MPI.SUM)
        arm = np.cross(direction, model.nodes[rows] - mean)
        inertia = model.comm.allreduce(float(w @ np.sum(arm * arm, axis=1)), op=MPI.SUM)
        out[rows, :, j] = w[:, None] * arm / inertia
    return out.reshape(3 * n, len(loads))
