"""The files each command writes into ``--out`` when it runs fully: what ``staged_output``
replaces, and removes when a run did not produce it this time (``owns``)."""

MESH_FILES = ("mesh.msh", "mesh.json")
MODES_FILES = (*MESH_FILES, "modes.h5", "modes.json", "mode_shapes")
REDUCE_FILES = (*MODES_FILES, "selection.json", "reduced.h5", "stress_modes.h5")
#: A plot a stopped simulation could not draw is removed rather than left from an earlier run.
SIMULATION_FILES = ("results.h5", "summary.json", "trajectory.png", "energy.png", "joints.png",
                    "stress.xdmf", "stress.h5", "stress.png")
