"""Free-free modes on disk: the ``modes.json`` summary and mode shapes ParaView opens.

Mode shapes go to ``mode_shapes/mode_shapes.xdmf`` with its binary HDF5 beside it
(``mode_shapes.h5``): the mesh once, then each elastic mode as one "time step" numbered from
1 (the rigid modes are left out), P_k shapes at every P_k node of the order-k mesh. They are
written only when a study asks (``[outputs] mode_shapes = true``), from the modal basis
(mesh file node order), so cached modes serve as well as freshly solved ones.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from dolfinx import fem, io

from gcms_fenicsx.fe.modes import Modes
from gcms_fenicsx.fe.assembly import FEModel
from gcms_fenicsx.fe.node_order import input_node_indices

#: Where the mode shapes go inside ``--out``.
MODE_SHAPES_FILE = Path("mode_shapes") / "mode_shapes.xdmf"


def write_mode_shapes(mesh, mode_fields: np.ndarray, path: Path) -> None:
    """Write every elastic mode shape to the XDMF file ``path`` (HDF5 beside it), collectively.

    ``mode_fields`` (N, 3, Nm): node (mesh file order), direction, mode — every rank's copy
    (``ModalBasis.mode_fields``); each rank writes its owned nodes' rows.
    """
    V = fem.VectorFunctionSpace(mesh, ("CG", mesh.geometry.cmap.degree))
    Vs, _ = V.sub(0).collapse()
    rows = input_node_indices(Vs)
    u = fem.Function(V, name="mode_shape")
    owned = 3 * len(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    with io.XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        for j in range(mode_fields.shape[2]):
            u.x.array[:owned] = mode_fields[rows, :, j].ravel()
            u.x.scatter_forward()
            xdmf.write_function(u, float(j + 1))


def modes_report(model: FEModel, modes: Modes, timings_s: dict[str, float]) -> dict:
    """The ``modes.json`` document (plain JSON types)."""
    return {
        "ndofs": model.ndofs,
        "nodes": model.num_nodes,
        "element_degree": model.V.ufl_element().degree(),
        "mpi_ranks": model.comm.size,
        "rigid_mode_count": modes.rigid_count,
        "elastic_mode_count": len(modes.elastic_eigenvalues),
        "elastic_frequencies_hz": modes.elastic_frequencies_hz.tolist(),
        "eigenvalues_rad2_s2": modes.eigenvalues.tolist(),
        "max_relative_residual": float(modes.relative_residuals.max()),
        "relative_residuals": modes.relative_residuals.tolist(),
        "max_backward_error": float(modes.verification.backward_errors.max()),
        "m_orthonormality_error": modes.orthonormality_error,
        "rigid_fractions": modes.rigid_fractions.tolist(),
        "missed_eigenvalues": modes.missed_eigenvalues,
        "sylvester_count": modes.inertia_count,
        "repeated_eigenvalues": modes.clusters(),
        "shift": modes.shift,
        "mass_kron_defect": modes.verification.mass_kron_defect,
        "verification": modes.verification.to_json(),
        "warnings": list(modes.warnings),
        "timings_s": {**timings_s, **modes.timings_s},
    }
