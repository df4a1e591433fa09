"""gcms-fenicsx: generalized component mode synthesis for flexible multibody bodies.

This package's top level imports nothing heavy: ``gcms_fenicsx.dynamics`` must stay
importable with NumPy and h5py only. The finite-element stages import dolfinx,
PETSc and SLEPc in their own modules.
"""
__version__ = "0.1.0"
