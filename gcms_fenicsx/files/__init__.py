"""File formats and writing: versioned, checksummed HDF5 (``versioned``), checksums of files
and JSON documents (``checksums``), the reduced model (``reduced_model``), the modal basis
and its file (``modal_basis``, ``modes_file``), the SVK coefficients (``svk_data``), the
results of a run (``results``), staged and atomic output with strict JSON (``outputs``) and
which files each command writes (``names``). NumPy and h5py only: the standalone integrator
reads and writes through it."""
