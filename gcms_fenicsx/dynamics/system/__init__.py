"""Assemblies: several bodies in one state, joints between them (docs/design.md §10).

``members`` (flexible GCMS bodies placed in the assembly, point masses), ``rows`` (joint rows
between members' points, node groups and the ground: linear, driven and bilinear),
``assembly`` (the stacked coordinates, the block-diagonal mass, the independent rows),
``stepper`` (the generalized-α step of the assembly, Newton with a Schur complement on the
multipliers), ``march`` (a run, its records and its energy balance) and ``gas_pressure`` (the
cylinder pressure over the four-stroke cycle, the gas forces on pistons). NumPy only.
"""
