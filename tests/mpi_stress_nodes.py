"""Child script of test_stress_recovery: the stress modes' mesh part (``pipeline.stress_stage``)
for the surface and two groups, whole body, on the mesh.msh of an output folder, on however
many ranks it runs; rank 0 writes it to stress_modes.h5 in RESULT_FOLDER.

    mpirun -n 2 python tests/mpi_stress_nodes.py OUT_FOLDER RESULT_FOLDER
"""
import sys
from pathlib import Path

from geometry.groups import surface_tags
from mpi4py import MPI

from gcms_fenicsx.app import pipeline
from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.files.reduced_model import read_reduced
from gcms_fenicsx.files.stress_nodes import write_stress_nodes

folder, result = Path(sys.argv[1]), Path(sys.argv[2])
comm = MPI.COMM_WORLD
nodes = comm.bcast(read_reduced(folder / "reduced.h5").fields.shape[0] if comm.rank == 0
                   else None, root=0)
groups = surface_tags(None)                         # a beam's: end_x0, end_xL, ...
for name, asked in (("surface", StressOutputs(surface=True, times=(0.01,))),
                    ("groups", StressOutputs(groups=("end_x0", "end_xL")))):
    stress = pipeline.stress_stage(folder / "mesh.msh", groups, asked, nodes, name, comm=comm)
    if comm.rank == 0:
        write_stress_nodes(result / f"{name}.h5", stress)
