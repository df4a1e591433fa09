"""The compiled step's time functions: the directions of driven rows and the external forces
at a time (``joints.Constraints.directions_at``, ``loads.ExternalForces``). Numba."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gcms_fenicsx.dynamics.stepping.compiled.algebra import JIT


@njit(**JIT)
def _drive_angle(W, T, cycloidal, t):
    """Drive.angle: θ(t) of the speed Ω = W reached over T by a cosine or cycloidal ramp."""
    if t >= T:
        return W * (t - 0.5 * T)
    if cycloidal:
        c = 2.0 * math.pi / T
        return W / T * (0.5 * t * t + (math.cos(c * t) - 1.0) / (c * c))
    c = math.pi / T
    return 0.5 * W * (t - math.sin(c * t) / c)


@njit(**JIT)
def directions_at(t, directions, drive_rows, drive_vectors, drive_params, out):
    """u_i(t): the rows a drive turns turned by its angle (Constraints.directions_at), into
    ``out`` (m × 3) if any row is driven."""
    if drive_rows.shape[0] == 0:
        return directions
    U = out
    U[:, :] = directions
    for j in range(drive_rows.shape[0]):
        theta = _drive_angle(drive_params[j, 0], drive_params[j, 1], drive_params[j, 2] == 1.0,
                             t)
        c, s = math.cos(theta), math.sin(theta)
        i = drive_rows[j]
        for l in range(3):
            U[i, l] = (c * drive_vectors[j, 0, l] + s * drive_vectors[j, 1, l]
                       + (1.0 - c) * drive_vectors[j, 2, l])
    return U


@njit(**JIT)
def external_force(t, gravity, load_vectors, load_params, factors, out):
    """ExternalForces.__call__: f_g + Σ_j s_j(t) b_j (into ``out``; ``factors``: work)."""
    L = load_params.shape[0]
    if L == 0:
        return gravity
    for j in range(L):
        kind, T = load_params[j, 0], load_params[j, 1]
        freq, phase = load_params[j, 2], load_params[j, 3]
        if kind == 1.0:
            factors[j] = min(t / T, 1.0)
        elif kind == 2.0:
            wave = math.sin(2.0 * math.pi * freq * t + phase)
            factors[j] = wave if t >= T else 0.5 * (1.0 - math.cos(math.pi * t / T)) * wave
        else:
            factors[j] = 1.0
    np.dot(factors, load_vectors, out)
    for j in range(out.shape[0]):
        out[j] += gravity[j]
    return out
