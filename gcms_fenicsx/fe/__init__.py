"""Finite elements: the body's mesh, K and M with dolfinx, and the verified free-free modes.

The heavy part of the pipeline (dolfinx, PETSc, SLEPc, MPI, Gmsh): ``meshing`` runs the
geometry in a child process and ``mesh`` reads it into dolfinx; ``assembly`` assembles K, M
and Ms, ``algebra`` multiplies distributed matrices with dense blocks and ``mass`` applies
M = Ms ⊗ I3; ``modes``, ``eigensolve``, ``factor`` and ``verification`` are the eigen-solve
stage; ``node_groups`` the weights of surface groups; ``mode_shapes`` writes modes.json and
the shapes for ParaView; ``memory`` estimates what a study will need.

Every module here may import Gmsh, directly or through ``dolfinx.io``, and Gmsh's import
resets SIGINT to kill the process: the package imports it first and reinstalls the
command's handlers at once (``runtime.interrupts.reinstall``), so an interrupt during the
slower imports that follow still leaves ``--out`` as it was.
"""

import gmsh  # noqa: F401,E402  (resets SIGINT)

from gcms_fenicsx.runtime.interrupts import reinstall  # noqa: E402

reinstall()
