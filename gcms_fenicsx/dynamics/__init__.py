"""The standalone integrator of a reduced GCMS body: NumPy and h5py only (docs/design.md §6).

Nothing in this package imports dolfinx, PETSc, MPI, Gmsh or SciPy, so a reduced model
(``reduced.h5``) can be simulated on a machine that has none of them::

    from gcms_fenicsx.dynamics import read_reduced, parse_scene, simulate
    traj, summary = simulate(read_reduced("reduced.h5"), parse_scene({...}))
    summary = simulate_to_file(model, scene, "results.h5")   # streamed: memory stays flat

or from the shell: ``python -m gcms_fenicsx.dynamics reduced.h5 study.toml --out DIR``.

Modules: ``rotation`` (polar decomposition and its rate), ``body`` (the GCMS body),
``corotated`` (elastic energy, forces, exact tangent), ``joints`` (linear constraints),
``loads``, ``scene`` (the [scene] table), ``initial`` (the initial mode shape),
``integrator`` (generalized-α and Newton), ``recorder`` and ``results`` (what is kept,
results.h5), ``budget`` (whether the results fit), ``simulate`` (composition); the rotor
basis: ``rotor``, ``rotor_basis``, ``basis_choice``, ``run_basis``.
"""
from gcms_fenicsx.dynamics.results import ResultsError, Trajectory, read_results, write_results
from gcms_fenicsx.dynamics.scene import Scene, SceneError, parse_scene
from gcms_fenicsx.dynamics.simulate import simulate, simulate_body, simulate_to_file
from gcms_fenicsx.files.reduced_model import ReducedModelError, read_reduced

__all__ = ["ReducedModelError", "ResultsError", "Scene", "SceneError", "Trajectory",
           "parse_scene", "read_reduced", "read_results", "simulate", "simulate_body",
           "simulate_to_file", "write_results"]
