"""Validation-only references: the full finite-element model stepped by the same integrator
(co-rotated linear and Saint Venant–Kirchhoff), the flexible pendulum case, and spectral
peaks. Used by tests and workflows, never by a command."""
