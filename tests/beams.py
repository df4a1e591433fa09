"""The test beams of the dynamics tests: a steel beam of 30 × 20 mm rectangle, 0.5 m long
(x from 0 to L), whose node groups ``end_x0`` and ``end_xL`` are the end faces; its study
(the input of ``gcms reduce``), its committed reduced model, and the linear statics of a
reduced body (a reference the integrator's settled states are checked against).

NumPy and the standalone integrator only: ``tests/dynamics`` imports it in a process without
the finite-element stack, and ``tests/data/make_reduced_models.py`` builds the committed
models from :func:`beam_study`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.constraints.joints import build_constraints

LENGTH, WIDTH_Y, HEIGHT_Z = 0.5, 0.03, 0.02
E_STEEL, NU_STEEL, RHO_STEEL = 210e9, 0.3, 7850.0
GRAVITY = 9.81

#: Committed reduced models (``tests/data/make_reduced_models.py`` writes them).
DATA = Path(__file__).resolve().parent / "data"
#: reduced.h5 of ``beam_study(6)``: 6 elastic modes, 22 fields, 66 coordinates.
BEAM6 = DATA / "beam6.h5"
#: The same body with the Saint Venant–Kirchhoff coefficients (``beam_svk_study(6)``).
BEAM6_SVK = DATA / "beam6_svk.h5"

#: The test beam, with cosine_tolerance = 1e-12 spelled out (the default since a looser one
#: was found to drop the Poisson-contraction fields of slender beams, which the statics and
#: frequency tests depend on).
BEAM_STUDY = f"""
[geometry]
kind = "beam"
section = "rectangle"
width = {WIDTH_Y}
height = {HEIGHT_Z}
length = {LENGTH}

[mesh]
size = 0.012

[modes]
count = {{count}}

[selection]
cosine_tolerance = 1e-12
"""


def beam_study(count: int = 6) -> str:
    """The study of the test beam with ``count`` elastic modes (no [scene])."""
    return BEAM_STUDY.replace("{count}", str(count))


def beam_svk_study(count: int = 6) -> str:
    """The test beam's study with a free-floating scene whose elastic law is Saint
    Venant–Kirchhoff, so ``gcms reduce`` adds the SVK coefficients to reduced.h5."""
    return beam_study(count) + """
[scene]
end_time = 0.01
time_step = 1e-4
elasticity = "svk"
"""


def linear_static_displacement(body: Body, sc, force: np.ndarray, group: str) -> np.ndarray:
    """Displacement of ``group`` from the linear statics of the reduced model: [Kr Cᵀ; C 0]
    [Δq; λ] = [f; 0] with the joint rows of the scene ``sc`` at q0."""
    c = build_constraints(body, sc.joints, body.q0)
    C = c.jacobian(c.directions_at(0.0))
    n, m = body.dofs, c.count
    kkt = np.block([[body.stiffness, C.T], [C, np.zeros((m, m))]])
    dq = np.linalg.solve(kkt, np.concatenate([force, np.zeros(m)]))[:n]
    return dq.reshape(-1, 3).T @ body.groups[group].position
