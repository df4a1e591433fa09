"""The flexible slider crank of the IVP Test Set in Exudyn, the conrod an
ObjectFFRFreducedOrder (floating frame of reference + free-free eigenmodes).

Mechanism (SI units, planar motion in x-y, no gravity):

- crank: rigid, 0.15 m, about the z axis through the origin, driven at Omega = 150 rad/s
  (crank angle Omega*t). Modelled as a NodeRigidBody2D/ObjectRigidBody2D whose x, y are
  held at 0 and whose angle is driven by a velocity-level CoordinateConstraint
  (phi_t = Omega), so that no Python user function is called during the integration.
- conrod: the exported 3D P2 FE model (M, K, nodes), reduced with its lowest free-free
  elastic eigenmodes (default 10) through Exudyn's FEMinterface and
  ObjectFFRFreducedOrderInterface; the rigid-body motion is carried by the floating frame
  (NodeRigidBodyEP). Its face x = 0 is joined to the crank pin by a GenericJoint acting as a
  revolute joint about z (MarkerSuperElementRigid with the face's node weights); its face
  x = 0.30 is joined to the slider by a SphericalJoint (MarkerSuperElementPosition with that
  face's node weights).
- slider: a mass point (0.075552 kg, NodePoint + MassPoint) held on the x axis by two
  CoordinateConstraints (y = z = 0).

Initial state: the conrod along +x from (0.15, 0, 0) to (0.45, 0, 0), undeformed, moving
rigidly at -75 rad/s about z with its x = 0 face centre at (0, 22.5, 0) m/s; slider at rest.
Time integration: Exudyn's generalized-alpha (index 3), fixed step, 0 <= t <= 0.1 s.

Recorded every 1e-4 s:
- midpoint deflection: the mid-section centre (undeformed (0.15, 0, 0) moved by the mean
  displacement of the nodes with |x - 0.15| < 1e-3 m) measured from the chord between the
  two end-face centres (node-weighted means), positive along z x chord (left normal);
- slider x position.
The deflection is reconstructed exactly from the recorded conrod coordinates (frame
position, frame rotation matrix, modal coordinates) and the mode shapes (`deflection`).

    EXUDYN_PYTHON workflows/exudyn/slider_crank_ffrf.py --data DIR --time-step 2e-5 --out R.json

run by ``workflows/slider_crank_speed.py`` with a Python that imports Exudyn (not the project's:
``python3 -m venv DIR && DIR/bin/pip install exudyn scipy``), on the conrod's finite-element
data it exports (DIR: M.npz, K.npz, conrod.npz).

The JSON has `time_s`, `midpoint_deflection_m`, `slider_x_m`, `wall_time_s` (the time
integration alone), `setup_s` (with its parts), `steps`, `coordinates`, the Exudyn version
and the solver settings.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy/SciPy: one BLAS thread

import argparse
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

import exudyn as exu
import exudyn.itemInterface as eii
from exudyn.FEM import FEMinterface, ObjectFFRFreducedOrderInterface

# ---- mechanism data (SI) --------------------------------------------------------------------
L1 = 0.15                    # crank length
L2 = 0.30                    # conrod length (pin to pin)
OMEGA = 150.0                # crank rate (rad/s)
SLIDER_MASS = 0.075552       # kg (half the conrod's 0.151104 kg)
T_END = 0.1                  # s
RECORD_S = 1e-4              # output spacing
MID_X, MID_TOL = 0.15, 1e-3  # the mid-section's nodes: |x - 0.15| < 1e-3 in the mesh


def arguments() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--time-step", type=float, default=2e-5, help="h (s)")
    p.add_argument("--out", type=Path, required=True, help="JSON result file")
    p.add_argument("--modes", type=int, default=10, help="free-free elastic modes")
    p.add_argument("--rho-inf", type=float, default=0.8, help="generalized-alpha spectral radius")
    p.add_argument("--newton-rtol", type=float, default=1e-10,
                   help="Newton relativeTolerance (absoluteTolerance = 1e-2 of it)")
    p.add_argument("--modified-newton", action="store_true",
                   help="Exudyn's modified Newton (Jacobian kept while it contracts); "
                        "default: full Newton, Jacobian every iteration")
    p.add_argument("--data", type=Path, required=True,
                   help="folder of M.npz, K.npz, conrod.npz")
    args = p.parse_args()
    steps = T_END / args.time_step
    if args.modes < 1 or abs(steps - round(steps)) > 1e-9 * steps:
        p.error("--modes >= 1 and --time-step must divide 0.1 s")
    return args


# ---- FE data and modes ----------------------------------------------------------------------
def load_fe(folder: Path) -> dict:
    """Mass, stiffness (scipy CSR, DOF 3*i+k), node coordinates and the node groups
    (end faces with their weights; the mid-section with equal weights)."""
    d = np.load(folder / "conrod.npz")
    nodes = np.asarray(d["nodes"], dtype=float)
    mid = np.flatnonzero(np.abs(nodes[:, 0] - MID_X) < MID_TOL)
    return {"M": sp.load_npz(folder / "M.npz").tocsr(), "K": sp.load_npz(folder / "K.npz").tocsr(),
            "nodes": nodes,
            "x0": (d["end_x0_nodes"].astype(int), d["end_x0_weights"].astype(float)),
            "xL": (d["end_xL_nodes"].astype(int), d["end_xL_weights"].astype(float)),
            "mid": (mid, np.full(len(mid), 1.0 / len(mid)))}


def rigid_modes(nodes: np.ndarray) -> np.ndarray:
    """The 6 rigid-body displacement fields (3 translations, 3 small rotations), 3N x 6."""
    r = np.zeros((3 * len(nodes), 6))
    for c in range(3):
        r[c::3, c] = 1.0
    x, y, z = nodes.T
    r[1::3, 3], r[2::3, 3] = -z, y
    r[0::3, 4], r[2::3, 4] = z, -x
    r[0::3, 5], r[1::3, 5] = -y, x
    return r


def free_free_modes(M, K, nodes: np.ndarray, n_modes: int, n_rigid: int = 6):
    """The n_modes lowest elastic free-free eigenpairs (K phi = w^2 M phi), M-orthonormal.

    Computed here rather than by FEMinterface.ComputeEigenmodes, which makes the same eigsh
    call but shift-inverts at sigma = 0 (factorising the singular K) from a random start
    vector: a shift sigma < 0 (K - sigma M positive definite) and a fixed start vector make
    this robust and repeatable. The bending modes of the square section come in degenerate
    pairs (y and z); each pair is rotated within its eigenspace so that its first member is
    in-plane (least z motion) and the second out-of-plane, and where the cut at n_modes
    splits a pair the in-plane member is kept (it is what the planar motion excites).
    The n_rigid rigid-body modes are dropped; the elastic ones are M-orthogonal to them."""
    k = n_rigid + n_modes + 2  # two spare: to see whether the cut splits a degenerate pair
    lam, vec = eigsh(K, k=k, M=M, sigma=-(2 * np.pi * 10.0) ** 2, which="LM",
                     v0=np.ones(M.shape[0]))
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    if lam[n_rigid - 1] > 1e-6 * lam[n_rigid]:
        raise RuntimeError(f"expected {n_rigid} rigid-body modes, eigenvalues {lam[:n_rigid + 1]}")
    lam, vec = lam[n_rigid:], vec[:, n_rigid:]
    i = 0
    while i < len(lam):  # groups of equal eigenvalues; rotate the pairs
        j = i + 1
        while j < len(lam) and abs(lam[j] - lam[i]) < 1e-4 * lam[i]:
            j += 1
        if j - i == 2:
            _, _, vt = np.linalg.svd(vec[2::3, i:j], full_matrices=False)  # z components
            vec[:, i:j] = vec[:, i:j] @ vt[::-1].T  # first: least z motion
        i = j
    for c in range(vec.shape[1]):  # a fixed sign: the largest entry positive
        vec[:, c] *= np.sign(vec[np.argmax(np.abs(vec[:, c])), c])
    info = {"frequencies_hz": (np.sqrt(lam[:n_modes]) / (2 * np.pi)).tolist(),
            "next_frequencies_hz": (np.sqrt(lam[n_modes:]) / (2 * np.pi)).tolist(),
            "z_share": [float(np.linalg.norm(vec[2::3, c]) / np.linalg.norm(vec[:, c]))
                        for c in range(n_modes)]}
    lam, vec = lam[:n_modes], vec[:, :n_modes]
    info["orthonormality_error"] = float(np.abs(vec.T @ (M @ vec) - np.eye(n_modes)).max())
    info["rigid_mode_coupling"] = float(np.abs(rigid_modes(nodes).T @ (M @ vec)).max())
    return lam, vec, info


# ---- model ----------------------------------------------------------------------------------
def build(fe: dict, psi: np.ndarray, lam: np.ndarray) -> dict:
    """The Exudyn system, assembled; returns the handles needed to simulate and to
    post-process, and the time of the FFRF invariants."""
    fem = FEMinterface()  # set directly: there is no importer for plain scipy matrices
    fem.nodes = {"Position": fe["nodes"]}
    fem.massMatrix, fem.stiffnessMatrix = fe["M"], fe["K"]
    fem.modeBasis = {"matrix": psi, "type": "NormalModes"}
    fem.eigenValues = lam

    t0 = time.perf_counter()
    # reduced M and K, mass, inertia, centre of mass and the PsiTilde products (FFRF invariants)
    cms = ObjectFFRFreducedOrderInterface(fem)
    t_cms = time.perf_counter() - t0

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()

    # conrod: its frame origin is the mesh origin = the x = 0 face centre, put at the crank pin;
    # rigid initial motion: -75 rad/s about z, so that the slider pin (x = 0.45) is at rest
    omega_rod = -L1 * OMEGA / L2
    rod = cms.AddObjectFFRFreducedOrder(
        mbs, positionRef=[L1, 0.0, 0.0], initialVelocity=[0.0, L1 * OMEGA, 0.0],
        initialAngularVelocity=[0.0, 0.0, omega_rod], name="conrod")
    o_rod = rod["oFFRFreducedOrder"]

    n_ground = mbs.AddNode(eii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    m_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))

    def hold(node, coordinate, value=0.0, velocity_level=False):
        """CoordinateConstraint: the node's coordinate (its rate if velocity_level) = value."""
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=coordinate))
        return mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[m_ground, m], offset=value,
                                                      velocityLevel=velocity_level))

    # crank: planar rigid body about the origin, angle driven by phi_t = OMEGA (its mass and
    # inertia only enter its own reactions; any positive values do)
    n_crank = mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0],
                                              initialVelocities=[0.0, 0.0, OMEGA]))
    o_crank = mbs.AddObject(eii.ObjectRigidBody2D(nodeNumber=n_crank, mass=0.1,
                                                  inertia=0.1 * L1 ** 2 / 3))
    hold(n_crank, 0)
    hold(n_crank, 1)
    hold(n_crank, 2, OMEGA, velocity_level=True)
    m_crank_pin = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=o_crank, localPosition=[L1, 0.0, 0.0]))

    # conrod face x = 0 -> crank pin: revolute about z (all but the relative z rotation fixed)
    nodes0, w0 = fe["x0"]
    m_rod0 = mbs.AddMarker(eii.MarkerSuperElementRigid(bodyNumber=o_rod, meshNodeNumbers=nodes0,
                                                       weightingFactors=w0))
    mbs.AddObject(eii.GenericJoint(markerNumbers=[m_crank_pin, m_rod0],
                                   constrainedAxes=[1, 1, 1, 1, 1, 0]))

    # slider: point mass on the x axis; conrod face x = L2 -> slider: spherical joint
    n_slider = mbs.AddNode(eii.NodePoint(referenceCoordinates=[L1 + L2, 0.0, 0.0]))
    mbs.AddObject(eii.MassPoint(nodeNumber=n_slider, mass=SLIDER_MASS))
    hold(n_slider, 1)
    hold(n_slider, 2)
    nodesL, wL = fe["xL"]
    m_rodL = mbs.AddMarker(eii.MarkerSuperElementPosition(bodyNumber=o_rod, meshNodeNumbers=nodesL,
                                                          weightingFactors=wL))
    m_slider = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=n_slider))
    mbs.AddObject(eii.SphericalJoint(markerNumbers=[m_slider, m_rodL]))

    # sensors, stored internally every RECORD_S: all the deflection and slider need
    def sensor(node, kind):
        return mbs.AddSensor(eii.SensorNode(nodeNumber=node, outputVariableType=kind,
                                            storeInternal=True, writeToFile=False))
    OVT = exu.OutputVariableType
    sensors = {"frame_position": sensor(rod["nRigidBody"], OVT.Position),
               "frame_rotation": sensor(rod["nRigidBody"], OVT.RotationMatrix),
               "modal": sensor(rod["nGenericODE2"], OVT.Coordinates),
               "slider": sensor(n_slider, OVT.Position),
               "crank": sensor(n_crank, OVT.Rotation)}
    mbs.Assemble()
    return {"SC": SC, "mbs": mbs, "rod": rod, "sensors": sensors, "t_cms": t_cms}


def settings(args) -> exu.SimulationSettings:
    """Generalized-alpha with a fixed step and tight Newton settings."""
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = int(round(T_END / args.time_step))
    ti.endTime = T_END
    ti.adaptiveStep = False                           # fixed step: fail rather than shrink h
    ti.generalizedAlpha.spectralRadius = args.rho_inf
    ti.generalizedAlpha.useNewmark = False            # generalized-alpha, not Newmark
    ti.generalizedAlpha.useIndex2Constraints = False  # index 3 (position-level constraints)
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = args.modified_newton
    ti.newton.relativeTolerance = args.newton_rtol
    ti.newton.absoluteTolerance = 1e-2 * args.newton_rtol
    ti.newton.maxIterations = 25
    ti.verboseMode = 0
    s.solution.file.write = False             # no solution file: sensors only, stored internally
    s.solution.sensors.writePeriod = RECORD_S
    s.linearSolver.solverType = exu.LinearSolverType.EXUdense  # small system (~25 unknowns)
    s.show.computationTime = False
    s.show.statistics = False
    return s


# ---- post-processing ------------------------------------------------------------------------
def group_map(psi: np.ndarray, nodes: np.ndarray, group) -> tuple[np.ndarray, np.ndarray]:
    """(weighted mean reference position (3,), weighted mean mode shape (3, n_modes))."""
    idx, w = group
    shapes = psi.reshape(len(nodes), 3, -1)[idx]              # (n_group, 3, n_modes)
    return w @ nodes[idx], np.einsum("i,ijk->jk", w, shapes)


def deflection(fe: dict, psi: np.ndarray, p: np.ndarray, A: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Midpoint deflection at each recorded time from the frame position p (T, 3), rotation
    matrix A (T, 3, 3) and modal coordinates q (T, n): a point with local position
    x + Psi q is at p + A (x + Psi q). The mid-section centre is the undeformed centre
    (0.15, 0, 0) moved by the mid nodes' mean displacement (their mean reference offset
    from (0.15, 0, 0) is left out); the deflection is its distance from the end-face chord,
    in x-y, along z x chord."""
    nodes = fe["nodes"]
    x0, P0 = group_map(psi, nodes, fe["x0"])
    xL, PL = group_map(psi, nodes, fe["xL"])
    _, Pm = group_map(psi, nodes, fe["mid"])
    xm = np.array([MID_X, 0.0, 0.0])

    def world(x_ref, shape):
        local = x_ref[None, :] + q @ shape.T                  # (T, 3)
        return p + np.einsum("tij,tj->ti", A, local)

    c0, cL, cm = world(x0, P0), world(xL, PL), world(xm, Pm)
    chord = (cL - c0)[:, :2]
    normal = np.stack([-chord[:, 1], chord[:, 0]], axis=1) / np.linalg.norm(chord, axis=1)[:, None]
    return np.einsum("ti,ti->t", normal, (cm - c0)[:, :2])


# ---- run ------------------------------------------------------------------------------------
def main() -> None:
    args = arguments()
    setup = {}
    t0 = time.perf_counter()
    fe = load_fe(args.data)
    setup["load_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    lam, psi, mode_info = free_free_modes(fe["M"], fe["K"], fe["nodes"], args.modes)
    setup["modes_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    model = build(fe, psi, lam)
    setup["ffrf_invariants_s"] = model["t_cms"]
    setup["model_s"] = time.perf_counter() - t0 - model["t_cms"]
    mbs, sensors = model["mbs"], model["sensors"]
    sim = settings(args)

    # the time integration alone: Exudyn's solver initialisation (incl. the initial
    # accelerations) and the 0.1 s of steps; not the modes, FFRF invariants or Assemble()
    t0 = time.perf_counter()
    ok = mbs.SolveDynamic(sim, solverType=exu.DynamicSolverType.GeneralizedAlpha)
    wall = time.perf_counter() - t0
    if not ok:
        raise RuntimeError("Exudyn's time integration failed")
    it = mbs.sys["dynamicSolver"].it

    data = {k: mbs.GetSensorStoredData(v) for k, v in sensors.items()}
    t = data["modal"][:, 0]
    p = data["frame_position"][:, 1:4]
    A = data["frame_rotation"][:, 1:10].reshape(-1, 3, 3)
    q = data["modal"][:, 1:]
    w = deflection(fe, psi, p, A, q)
    slider = data["slider"][:, 1]
    crank_err = float(np.abs(data["crank"][:, 3] - OMEGA * data["crank"][:, 0]).max())
    steps = int(sim.timeIntegration.numberOfSteps)
    peak = int(np.argmax(np.abs(w)))

    n_rod = 7 + args.modes  # frame: 3 positions + 4 Euler parameters; modal coordinates
    result = {
        "time_s": t.tolist(),
        "midpoint_deflection_m": w.tolist(),
        "slider_x_m": slider.tolist(),
        "wall_time_s": wall,
        "setup_s": sum(setup.values()),
        "setup_parts_s": setup,
        "steps": steps,
        "steps_per_s": steps / wall,
        "newton_iterations": int(it.newtonStepsCount),
        "jacobian_updates": int(it.newtonJacobiCount),
        "peak_deflection_m": float(w[peak]),
        "peak_time_s": float(t[peak]),
        "crank_angle_error_rad": crank_err,
        "coordinates": {"conrod_ode2": n_rod,
                        "system_ode2": len(mbs.systemData.GetODE2Coordinates()),
                        "system_algebraic": len(mbs.systemData.GetAECoordinates())},
        "modes": mode_info,
        "model": {"conrod": f"ObjectFFRFreducedOrder, NodeRigidBodyEP frame + {args.modes} "
                            "free-free elastic eigenmodes (M-orthonormal, rigid-body modes "
                            "excluded)",
                  "crank": "ObjectRigidBody2D at the origin; x, y held, angle rate held at "
                           "Omega by a velocity-level CoordinateConstraint",
                  "crank_pin": "GenericJoint constrainedAxes [1,1,1,1,1,0]: crank "
                               "MarkerBodyRigid -> MarkerSuperElementRigid (face x = 0)",
                  "slider_pin": "SphericalJoint: slider MarkerNodePosition -> "
                                "MarkerSuperElementPosition (face x = 0.30)",
                  "slider": "MassPoint, y and z held by CoordinateConstraints"},
        "exudyn_version": exu.__version__,
        "solver": {"type": "GeneralizedAlpha (index 3)", "time_step_s": args.time_step,
                   "spectral_radius": args.rho_inf,
                   "newton": "modified" if args.modified_newton else "full",
                   "newton_relative_tolerance": args.newton_rtol,
                   "newton_absolute_tolerance": 1e-2 * args.newton_rtol,
                   "linear_solver": str(sim.linearSolver.solverType),
                   "adaptive_step": False, "threads": int(sim.parallel.numberOfThreads)},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result))
    print(f"h = {args.time_step:g} s: peak {w[peak] * 1e3:.4f} mm at {t[peak] * 1e3:.2f} ms; "
          f"integration {wall:.2f} s ({steps / wall:.0f} steps/s, "
          f"{it.newtonStepsCount / steps:.2f} Newton its/step); setup {sum(setup.values()):.1f} s "
          f"{ {k: round(v, 2) for k, v in setup.items()} }")


if __name__ == "__main__":
    main()
