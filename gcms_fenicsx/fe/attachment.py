"""The loads of attachment modes as nodal vectors: unit forces and moments at node groups,
and the centrifugal load of a spin.

Each is the load a joint's row (or a scene load) puts on the group (``dynamics.constraints.joints``), so
the reactions of the joints are combinations of them. A unit force along d at group G acts
on the group's weighted mean position (the point joints and loads act on, ``node_groups``):
f_i = w_i d, the same distribution a scene load of 1 N has. A unit moment about c is the load
conjugate to the joint's moment row (c × d) · L(q) d, L the group's least-squares linear map
(``body.group_rows``) and d its lever (``numerics.group_geometry.moment_lever``, with the joint's turning axis):

    f_i = w_i (r_i · S⁺ d) (c × d),    S = Σ_i w_i r_i r_iᵀ,  r_i = x_i − x̄,

no net force and the moment Σ r_i × f_i = d × (c × d) = c. The centrifugal load of spinning
at 1 rad/s about a joint's axis e through the group's mean x̄ is f = M ((I − e eᵀ)(x − x̄))
(its part along the rigid modes, from where the axis passes, is relieved anyway). The
static responses to these loads, relieved of their rigid-body part, are the attachment modes
(``eigensolve.solve_free_free``, docs/design.md §3.7).
"""
from __future__ import annotations

import numpy as np
from mpi4py import MPI

from gcms_fenicsx.config.basis import AttachmentLoad
from gcms_fenicsx.numerics.group_geometry import group_span, moment_lever
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.mass import mass_dense
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
        if load.kind == "centrifugal":
            radial = model.nodes - mean
            radial -= np.outer(radial @ direction, direction)
            out[:, :, j] = mass_dense(model, radial.reshape(3 * n, 1)).reshape(n, 3)
            continue
        r = model.nodes[rows] - mean
        span, pinv = group_span(model.comm.allreduce((r * w[:, None]).T @ r, op=MPI.SUM))
        d = moment_lever(span, load.group, load.direction, load.turning)
        out[rows, :, j] = np.outer(w * (r @ (pinv @ d)), np.cross(direction, d))
    return out.reshape(3 * n, len(loads))
