"""The coordinates a run steps in: the rotor basis (``rotor_basis``), the held body's static
shapes (``static_shapes``) and the choice among them for a scene (``run_basis``)."""
