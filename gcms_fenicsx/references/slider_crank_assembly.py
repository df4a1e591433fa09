"""The IVP Test Set's flexible slider crank (``references.slider_crank``) as an assembly with
a 3D conrod (docs/design.md §10, docs/slider_crank.md).

The conrod is a straight beam (x from 0 to L2 in its own coordinates, its end faces
``end_x0`` and ``end_xL`` the pins), placed with its crank-pin face at the crank pin
(L1, 0, 0) at t = 0, along +x. The crank is rigid and turns at Ω about z through the origin,
so the crank pin is a prescribed point (``rows.circle_path``); the conrod's crank-pin face
follows it (``coincide``) and keeps its z direction (``keep_axis``: a revolute joint about z);
its slider-pin face moves with the slider (``coincide``: a spherical joint), a point mass on
the x axis (``on_line``). It starts undeformed on the rigid trajectory (the test set's second
initial state): crank angle 0, conrod turning at −Ω L1/L2, slider at rest.

The midpoint deflection is the benchmark's q1: the mid-section's centre from the chord
between the pin centres, in the plane of motion, positive to the left of the chord from the
crank pin to the slider pin. The mid-section's centre is the mean position of the nodes
within ``SLAB_M`` of the mid-plane plus R (X_mid − X̄), the offset of the undeformed centre
X_mid = (X_A + X_B)/2 of the end faces' centres from the nodes' mean X̄ (9e-5 m on the 3 mm
mesh, whose nodes are not symmetric about the axis) turned by the body's frame R =
polar(Qᵀ H): left unturned, it would add 9e-5 (1 − cos φ2) m, 0.6 % of the peak, as the
conrod turns by φ2. The mean over the slab differs from the centre's displacement by the
curvature times the slab's width squared, 1e-7 of the deflection here. NumPy and SciPy
(the benchmark's port); no finite-element stack.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.linalg import null_space

from gcms_fenicsx.dynamics.bodies.body import Body, mass_normalised_modes
from gcms_fenicsx.dynamics.constraints.factorization import Factorize, dense_factorization
from gcms_fenicsx.dynamics.stepping.state import State
from gcms_fenicsx.dynamics.system import rows
from gcms_fenicsx.dynamics.system.assembly import Assembly, assemble
from gcms_fenicsx.dynamics.system.members import Flexible, PointMass, placed_coordinates
from gcms_fenicsx.numerics.rotation import polar
from gcms_fenicsx.references.slider_crank import B, E, H, L1, L2, M3, NU, OMEGA, RHO

SLAB_M = 1e-3
Z_AXIS = np.array([0.0, 0.0, 1.0])

#: The conrod's study: the test set's beam (8 × 8 mm, 0.30 m pin to pin, steel), with the
#: attachment modes of its two pins (``[basis] attachment = "scene"``: the scene is not run,
#: its joints say where the assembly's joints act). Without them ten modes are 2.6 % of the
#: peak off the full-order conrod, with them 0.01 % (docs/slider_crank.md).
CONROD_STUDY = {
    "geometry": {"kind": "beam", "section": "rectangle", "width": B, "height": H,
                 "length": L2},
    "material": {"E": E, "nu": NU, "rho": RHO},
    "basis": {"attachment": "scene"},
    "scene": {"end_time": 0.1, "time_step": 2e-5,
              "joints": [{"name": "crank_pin", "type": "revolute", "group": "end_x0",
                          "axis": [0.0, 0.0, 1.0]},
                         {"name": "slider_pin", "type": "spherical", "group": "end_xL"}]},
}


def slider_crank(conrod: Body, factorize: Factorize = dense_factorization) -> Assembly:
    """The assembly (module docstring); ``factorize`` inverts the conrod's S₀ (a sparse LU for
    the full-order conrod)."""
    pin_start = np.array([L1, 0.0, 0.0])
    placed = pin_start - conrod.groups["end_x0"].center_m
    rod = Flexible("conrod", conrod, placed_coordinates(conrod, position=placed),
                   factorize=factorize)
    slider = PointMass("slider", M3, placed + conrod.groups["end_xL"].center_m)
    pin = rows.circle_path(np.zeros(3), pin_start, Z_AXIS, OMEGA)
    return assemble((rod, slider), (
        rows.coincide("crank_pin", rows.group_point(rod, "end_x0"), pin),
        rows.keep_axis("crank_pin_axis", rod, "end_x0", Z_AXIS),
        rows.coincide("slider_pin", rows.group_point(rod, "end_xL"), rows.mass_point(slider)),
        rows.on_line("guide", rows.mass_point(slider), np.array([1.0, 0.0, 0.0]))))


def rigid_start_velocity(assembly: Assembly) -> np.ndarray:
    """q̇ at t = 0 on the rigid trajectory: the conrod turning at ω = −Ω L1/L2 about z with its
    crank-pin face moving at Ω L1 along y, the slider at rest."""
    rod = assembly.member("conrod")
    body, q = rod.body, rod.q_start
    omega = np.array([0.0, 0.0, -OMEGA * L1 / L2])
    pin = body.groups["end_x0"].position @ q.reshape(-1, 3)
    center = body.center_of_mass(q)
    velocity = np.array([0.0, OMEGA * L1, 0.0]) + np.cross(omega, center - pin)
    return np.concatenate([body.rigid_velocity(q, velocity, omega), np.zeros(3)])


def midpoint_deflection(body: Body) -> Callable[[State], float]:
    """state ↦ the conrod's midpoint deflection (m; module docstring), for the conrod's
    coordinates first in q."""
    a, b = body.groups["end_x0"], body.groups["end_xL"]
    axis = b.center_m - a.center_m
    middle = 0.5 * (a.center_m + b.center_m)
    slab = np.abs((body.nodes_m - middle) @ axis / np.linalg.norm(axis)) < SLAB_M
    if not slab.any():
        raise ValueError(f"no node within {SLAB_M} m of the conrod's mid-plane")
    fields = np.asarray(body.node_fields[np.flatnonzero(slab)].todense()
                        if hasattr(body.node_fields, "todense") else body.node_fields[slab])
    mean_field, offset = fields.mean(axis=0), middle - body.nodes_m[slab].mean(axis=0)
    n = body.dofs

    def deflection(s: State) -> float:
        Q = s.q[:n].reshape(-1, 3)
        x_a, x_b = a.position @ Q, b.position @ Q
        centre = mean_field @ Q + polar(Q.T @ body.affine).rotation @ offset
        chord = (x_b - x_a) / np.linalg.norm(x_b - x_a)
        return float((centre - x_a) @ np.cross(Z_AXIS, chord))
    return deflection


def rigid_closed_form(t: np.ndarray, conrod_mass_kg: float, center_m: float,
                      inertia_kgm2: float) -> dict[str, np.ndarray]:
    """The rigid slider crank driven at Ω (φ1 = Ω t): the slider's position x3 and the force
    F_B (x, y) the slider applies to the conrod at the slider pin, for a rigid conrod of mass m
    whose centre of mass lies on the chord ``center_m`` from the crank pin, with moment of
    inertia J_A about the crank pin's axis.

    Kinematics: sin φ2 = −(L1/L2) sin φ1, φ̇2 = −L1 Ω cos φ1 / (L2 cos φ2), φ̈2 = (L1 Ω² sin φ1
    + L2 φ̇2² sin φ2) / (L2 cos φ2), x3 = L1 cos φ1 + L2 cos φ2, ẍ3 = −L1 Ω² cos φ1 − L2 (φ̇2²
    cos φ2 + φ̈2 sin φ2). The slider moves along x only, so F_Bx = −M3 ẍ3; the conrod's
    moments about the accelerating crank pin A, J_A φ̈2 + m (r_AC × a_A)_z = (r_AB × F_B)_z
    with a_A = −Ω² r_A, give F_By.
    """
    phi1 = OMEGA * np.asarray(t, float)
    s1, c1 = np.sin(phi1), np.cos(phi1)
    s2 = -L1 / L2 * s1
    c2 = np.sqrt(1.0 - s2 * s2)
    rate2 = -L1 * OMEGA * c1 / (L2 * c2)
    accel2 = (L1 * OMEGA ** 2 * s1 + L2 * rate2 ** 2 * s2) / (L2 * c2)
    x3 = L1 * c1 + L2 * c2
    accel3 = -L1 * OMEGA ** 2 * c1 - L2 * (rate2 ** 2 * c2 + accel2 * s2)
    force_x = -M3 * accel3
    a_pin = -OMEGA ** 2 * L1 * np.stack([c1, s1])
    moment_pin = center_m * (c2 * a_pin[1] - s2 * a_pin[0])       # (r_AC × a_A)_z
    force_y = (inertia_kgm2 * accel2 + conrod_mass_kg * moment_pin + L2 * s2 * force_x) / (L2 * c2)
    return {"slider_m": x3, "pin_force_n": np.stack([force_x, force_y], axis=1)}


def rigid_reference(conrod: Body, t: np.ndarray, pin: str = "end_x0") -> dict[str, np.ndarray]:
    """:func:`rigid_closed_form` for a rigid conrod with ``conrod``'s own mass, centre of mass
    (its distance from the centre of the crank-pin group ``pin``) and moment of inertia about
    the crank pin's axis, J_c,zz + m s² (J_c,zz = J_xx + J_yy of the second moment about the
    centre)."""
    J = conrod.second_moment
    centre = float(np.linalg.norm(conrod.center_of_mass(conrod.q0)
                                  - conrod.groups[pin].center_m))
    inertia = float(J[0, 0] + J[1, 1]) + conrod.total_mass_kg * centre ** 2
    return rigid_closed_form(t, conrod.total_mass_kg, centre, inertia)


def pinned_bending_hz(conrod: Body) -> tuple[float, float]:
    """The conrod's two lowest bending frequencies in the plane of motion (Hz), held as in the
    assembly with the slider fixed (pinned–pinned: the benchmark's two modes): the modes of
    (Kr, Mr) on the null space of the held rows, the in-plane ones those whose nodal
    displacements are mostly along y."""
    a = slider_crank(conrod)
    n = conrod.dofs
    held = [i for i, r in enumerate(a.rows) if r.joint != "guide"]
    N = null_space(a.matrix[held, :n])
    K, M = N.T @ np.asarray(conrod.stiffness) @ N, N.T @ np.asarray(conrod.mass) @ N
    values, vectors = mass_normalised_modes(0.5 * (K + K.T), 0.5 * (M + M.T))
    found = []
    for value, vector in zip(values, vectors.T):
        u = np.asarray(conrod.node_fields @ (N @ vector).reshape(-1, 3))
        if (u[:, 1] ** 2).sum() > (u[:, 2] ** 2).sum():
            found.append(float(np.sqrt(value) / (2 * np.pi)))
        if len(found) == 2:
            return found[0], found[1]
    raise ValueError("the conrod has fewer than two bending modes in the plane of motion")
