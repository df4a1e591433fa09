"""File formats and writing: versioned, checksummed HDF5 (``versioned``), the reduced model
(``reduced_model``), staged and atomic output with strict JSON (``outputs``), which files each
command writes (``names``) and the pictures of a simulation (``plots``). NumPy and h5py only
(Matplotlib when a picture is drawn): the standalone integrator reads and writes through it."""
