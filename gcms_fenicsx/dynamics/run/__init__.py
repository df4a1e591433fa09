"""A simulation as a whole: what is recorded (``recorder``), whether it fits on disk and in
memory (``capacity``), and the composition of a run (``simulate``)."""
