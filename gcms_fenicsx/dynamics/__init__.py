"""The standalone integrator of a reduced GCMS body: NumPy and h5py only (docs/design.md §6).

Nothing in this package imports dolfinx, PETSc, MPI, Gmsh or SciPy, so a reduced model
(``reduced.h5``) can be simulated on a machine that has none of them::

    from gcms_fenicsx.dynamics import read_reduced, parse_scene, simulate
    traj, summary = simulate(read_reduced("reduced.h5"), parse_scene({...}))
    summary = simulate_to_file(model, scene, "results.h5")   # streamed: memory stays flat

or from the shell: ``python -m gcms_fenicsx.dynamics reduced.h5 study.toml --out DIR``.

Sub-packages by role: ``bodies`` (the body, its elastic laws, damping and loads),
``constraints`` (joints and the linear algebra they bring), ``stepping`` (generalized-α,
Newton, the initial state), ``bases`` (the rotor basis and the static shapes) and ``run``
(recording and the composition of a run). The [scene] table is ``config.scene``'s, the
results file ``files.results``'s.
"""
from gcms_fenicsx.files.results import ResultsError, Trajectory, read_results, write_results
from gcms_fenicsx.config.scene import Scene, SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate, simulate_body, simulate_to_file
from gcms_fenicsx.files.reduced_model import ReducedModelError, read_reduced

__all__ = ["ReducedModelError", "ResultsError", "Scene", "SceneError", "Trajectory",
           "parse_scene", "read_reduced", "read_results", "simulate", "simulate_body",
           "simulate_to_file", "write_results"]
