"""Child script of test_svk_coefficients: the SVK coefficients of the fields of a reduced.h5 on
the mesh.msh beside it, on however many ranks it runs; rank 0 writes them to an .npz.

    mpirun -n 2 python tests/mpi_svk_coefficients.py OUT_FOLDER RESULT.npz
"""
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from gcms_fenicsx.app import pipeline
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.files.reduced_model import read_reduced

folder, result = Path(sys.argv[1]), Path(sys.argv[2])
comm = MPI.COMM_WORLD
model = read_reduced(folder / "reduced.h5") if comm.rank == 0 else None
material = comm.bcast(Material(**model.material) if comm.rank == 0 else None, root=0)
svk, report = pipeline.svk_stage(folder / "mesh.msh", model.fields if comm.rank == 0 else None,
                                 material, comm=comm)
if comm.rank == 0:
    np.savez(result, quadratic=svk.quadratic, linear=svk.linear, constant=svk.constant,
             points=report["quadrature_points"])
