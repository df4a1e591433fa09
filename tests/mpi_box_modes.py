"""Child script of test_eigen_mpi: free-free modes of a box beam on however many ranks it runs, as JSON on stdout."""
import json
import sys

from dolfinx.mesh import CellType, create_box
from mpi4py import MPI

import numpy as np

from gcms_fenicsx.app import pipeline
from gcms_fenicsx.fe import algebra, mass
from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.fe import basis
from gcms_fenicsx.files import modal_basis
from gcms_fenicsx.reduction import selection
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.modes import ModesConfig

mesh = create_box(MPI.COMM_WORLD, [[0, -0.02, -0.03], [0.6, 0.02, 0.03]], [24, 2, 3],
                  CellType.tetrahedron)
model = pipeline.assembly_stage(mesh, Material(), degree=2).model
modes = pipeline.modes_stage(model, ModesConfig(count=int(sys.argv[1])))
mass = mass.mass_properties(model.Ms, model.nodes, model.material.rho)
fields = basis.field_basis(model, modes)
kept = selection.select_fields(fields.gram_mass, SelectionConfig(), fields.names).kept
Kr = basis.reduced_stiffness(model, fields.fields[:, kept])
# independently: Φᵀ (K Φ) with the dense Φ and PETSc's distributed product
Phi = basis.phi_dense(fields.fields[:, kept])
kr_defect = float(np.abs(algebra.gram(MPI.COMM_WORLD, Phi, algebra.mat_dense(model.K, Phi)) - Kr).max()
                  / np.abs(Kr).max())
Mr = modal_basis.reduced_mass(fields.gram_mass[np.ix_(kept, kept)])
reduced = np.linalg.eigvalsh(np.linalg.solve(np.linalg.cholesky(Mr), np.linalg.solve(
    np.linalg.cholesky(Mr), Kr).T))  # L⁻¹ Kr L⁻ᵀ: the pencil (Kr, Mr), sign-independent
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps({"ranks": MPI.COMM_WORLD.size, "ndofs": model.ndofs,
                      "frequencies": modes.elastic_frequencies_hz.tolist(),
                      "missed": modes.missed_eigenvalues,
                      "residual": float(modes.relative_residuals.max()),
                      "volume": mass.volume_m3, "inertia": mass.inertia_m5.tolist(),
                      "kron_defect": modes.verification.mass_kron_defect,
                      "kron_limit": modes.verification.mass_kron_limit, "kr_defect": kr_defect, "kept": kept.tolist(),
                      "reduced_eigenvalues": reduced.tolist(),
                      # |entries|: invariant under the sign of each mode, which may differ
                      "abs_kr": np.abs(Kr).tolist(), "abs_mr": np.abs(Mr).tolist()}))
