"""The flexible pendulum: the integrator's validation case against full-order references.

A soft beam (1 m, 20 mm square, E = 100 MPa: a soft polymer) is pinned at its end face
``end_x0`` by a revolute joint about y, released horizontally at rest, and swings under
gravity. The quantity compared is the tip's deviation from the rigid pendulum,

    d(t) = x_tip(t) − x_tip,rigid(t),

over the first half period of the swing; the rigid pendulum has the same mass
distribution (the body's own mass, centre of mass and second moments, so only the
flexibility differs) and is integrated to 1e-10 by RK4 with a fine step. The error of a
model against a reference is max_t |d − d_ref| / max_t |d_ref|.

NumPy only: the finite-element side of the study is in ``workflows/flexible_pendulum.py``
and the tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.numerics.rotation import rotation_about

LENGTH_M = 1.0
#: The study tables of the pendulum (as in a TOML file).
STUDY = {
    "geometry": {"kind": "beam", "section": "square", "side": 0.02, "length": LENGTH_M},
    "mesh": {"size": 0.01, "order": 2},
    "material": {"E": 1.0e8, "nu": 0.35, "rho": 1150.0},
    "modes": {"count": 10},
    "scene": {
        "end_time": 1.0, "time_step": 1e-3, "rho_inf": 0.8, "gravity": [0.0, 0.0, -9.81],
        "joints": [{"type": "revolute", "group": "end_x0", "axis": [0.0, 1.0, 0.0]}],
        "outputs": {"groups": ["end_xL"]},
    },
}
PIN, TIP, AXIS = "end_x0", "end_xL", np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class RigidPendulum:
    """θ(t) of the rigid body turning about ``axis`` through ``pivot``: I θ̈ = e · (r(θ) × m g)."""

    time: np.ndarray
    angle: np.ndarray
    pivot: np.ndarray
    tip0: np.ndarray
    axis: np.ndarray

    def tip(self, t: np.ndarray) -> np.ndarray:
        """Rigid tip positions at times t (interpolated; the RK4 step is far finer than t's)."""
        theta = np.interp(t, self.time, self.angle)
        arm = self.tip0 - self.pivot
        return np.array([self.pivot + rotation_about(self.axis, th) @ arm for th in theta])

    @property
    def half_period_s(self) -> float:
        """Time of the first extreme of θ: release to the far side."""
        return float(self.time[np.argmax(self.angle)]) if self.angle[-1] < self.angle.max() \
            else float(self.time[-1])


def rigid_pendulum(body: Body, gravity: np.ndarray, end_time_s: float,
                   step_s: float = 1e-5) -> RigidPendulum:
    """The rigid pendulum of ``body`` (mass, centre of mass, second moments from its rigid
    fields) pinned at the centroid of group PIN about AXIS, released at rest."""
    m = body.total_mass_kg
    second = body.second_moment
    inertia = np.trace(second) * np.eye(3) - second
    pivot, tip0 = body.groups[PIN].center_m, body.groups[TIP].center_m
    arm = body.center_of_mass(body.q0) - pivot
    e = AXIS
    I_axis = e @ inertia @ e + m * (arm @ arm - (arm @ e) ** 2)
    force = m * np.asarray(gravity, float)

    def accel(theta: float) -> float:
        return float(e @ np.cross(rotation_about(e, theta) @ arm, force)) / I_axis

    n = int(round(end_time_s / step_s))
    angle = np.zeros(n + 1)
    th, om = 0.0, 0.0
    for i in range(n):  # classical RK4 on θ̈ = accel(θ)
        k1 = (om, accel(th))
        k2 = (om + 0.5 * step_s * k1[1], accel(th + 0.5 * step_s * k1[0]))
        k3 = (om + 0.5 * step_s * k2[1], accel(th + 0.5 * step_s * k2[0]))
        k4 = (om + step_s * k3[1], accel(th + step_s * k3[0]))
        th += step_s / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        om += step_s / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        angle[i + 1] = th
    return RigidPendulum(time=np.linspace(0.0, n * step_s, n + 1), angle=angle, pivot=pivot,
                         tip0=tip0, axis=e)


def tip_deviation(rigid: RigidPendulum, time: np.ndarray, tip: np.ndarray) -> np.ndarray:
    """d(t) = tip − rigid tip at the recorded times."""
    return tip - rigid.tip(time)


def deviation_error(time: np.ndarray, d: np.ndarray, d_ref: np.ndarray, until_s: float) -> float:
    """max |d − d_ref| / max |d_ref| over t ≤ until_s (same recorded times)."""
    k = time <= until_s + 1e-12
    return float(np.linalg.norm(d[k] - d_ref[k], axis=1).max()
                 / np.linalg.norm(d_ref[k], axis=1).max())
