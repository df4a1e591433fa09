"""Free-free modes on disk: the ``modes.json`` summary and mode shapes ParaView opens.

Mode shapes go to a VTK collection (``.pvd`` + ``.vtu``) with arbitrary-order Lagrange
cells, so P2 shapes are written at every P2 node; each elastic mode is one "time step"
numbered from 1, the rigid modes are left out.
"""
from __future__ import annotations

from pathlib import Path

from dolfinx import fem, io

from gcms_fenicsx.fe.modes import Modes
from gcms_fenicsx.fe.assembly import FEModel


def write_mode_shapes(model: FEModel, modes: Modes, path: Path) -> None:
    """Write every elastic mode shape (M-normalised displacement) to ``path`` (a ``.pvd``;
    its ``.pvtu``/``.vtu`` pieces go beside it, so give it a folder of its own)."""
    u = fem.Function(model.V, name="mode_shape")
    owned = modes.vectors.shape[0]
    with io.VTKFile(model.comm, str(path), "w") as vtk:
        for j in range(modes.elastic_vectors.shape[1]):
            u.x.array[:owned] = modes.elastic_vectors[:, j]
            u.x.scatter_forward()
            vtk.write_function(u, float(j + 1))


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


def frequency_table(modes: Modes) -> str:
    """A few lines listing the elastic frequencies, for the terminal."""
    f = modes.elastic_frequencies_hz
    rows = [f"  {i + 1:3d}  {fi:12.4f} Hz" for i, fi in enumerate(f)]
    return "\n".join(["  mode    frequency", *rows]) if len(f) else "  (no elastic modes)"
