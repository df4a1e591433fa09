"""Time stepping: generalized-α parameters (``alpha``), the step's state (``state``), the
initial state (``initial``), the integrator with its Newton iteration (``integrator``) and
its failures (``errors``)."""
