"""Numerics shared by the finite-element side and the integrator, with NumPy only: the
clustering of eigenvalues (``spectrum``), rotations and the polar decomposition
(``rotation``), LAPACK calls without NumPy's wrappers (``lapack``), the packing of symmetric
matrices (``packing``) and the geometry of a node group (``group_geometry``). It imports no
other layer of gcms_fenicsx but ``runtime`` (docs/design.md, Layers)."""
