"""The compiled step's data: a prepared ``GeneralizedAlpha`` laid out as plain arrays, and the
small mutable state a stretch of compiled steps shares with the NumPy step (docs/design.md
§8.5). NumPy only: this module decides what the compiled kernel (``compiled``) can run and
packs it; nothing here needs Numba.

The compiled kernel runs the same step as ``integrator.GeneralizedAlpha.step`` (its
docstring and the module's give the formulas) on these arrays. Where the NumPy step would do
something the kernel does not — a step redone with the exact SVK tangent, a step that fails
with a message — the kernel leaves the state as it was before that step, and the NumPy step
takes it from there (``kernel.CompiledMarch``). To make that hand-over exact, the kernel works
on the very arrays the NumPy step keeps between steps (the bordered system's rank-9 rows,
the Jacobian policy's counters), restored when a step is handed over.
"""
from __future__ import annotations

from functools import partial
from typing import Any, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.bodies.rotor import RotorBody
from gcms_fenicsx.dynamics.bodies.svk import svk_state
from gcms_fenicsx.dynamics.constraints.jacobian import (LOCAL_REUSE_STEPS, TANGENT_RATE,
                                                        UPGRADE_RATE)
from gcms_fenicsx.dynamics.constraints.kkt import BorderedKKT
from gcms_fenicsx.config.scene import DRIVE_RAMPS

#: The elastic laws the kernel runs: co-rotated on GCMS coordinates, co-rotated on rotor
#: coordinates, Saint Venant–Kirchhoff on GCMS coordinates.
COROTATED, ROTOR, SVK = 0, 1, 2
#: ``Load.time`` as the kernel reads it.
LOAD_TIMES = {"constant": 0, "ramp": 1, "harmonic": 2}
EMPTY1 = np.zeros(0)
EMPTY2 = np.zeros((0, 0))
#: From this many coordinates the kernel applies S₀⁻¹ and its law's stiffness operator (and
#: from this many packed entries the SVK law's coefficients) through one triangle
#: (``compiled.algebra.product``, BLAS dsymv: half the memory a general product streams, at a
#: higher cost per call). Two such products alternating on one core of a 2 MB-L2 Xeon, general
#: against one triangle (2026-12-05): 54 coordinates 0.30 against 0.30 µs, 99: 1.01 against
#: 0.82, 140: 1.59 against 1.27, 189: 3.27 against 2.52, 282: 6.34 against 4.71, 450: 49.8
#: against 15.3.
SYMMETRIC_FROM = 90


class StepData(NamedTuple):
    """What does not change during a run, as arrays (shapes: n coordinates, nf fields, m rows,
    k = m + rank bordered rows, L loads, d driven rows, s packed SVK entries)."""

    law: int
    n: int
    pairs: int                 # rotor: in-plane pairs first, 2·pairs coordinates
    predictor: np.ndarray      # (4, 4)
    update: np.ndarray         # (4,)
    gamma_p: float
    tolerance: float           # m
    total_mass: float
    max_iterations: int
    exact_mode: bool           # jacobian = "exact"
    upgrade_rate: float
    tangent_rate: float
    reuse_steps: int
    gram: np.ndarray           # G (nf, nf): Mr = G ⊗ I3 (GCMS coordinates)
    mass: np.ndarray           # Mr or Mp (n, n) dense (the rotor's product; rank-9 term)
    s0_inverse: np.ndarray     # S₀⁻¹ (n, n)
    s0_symmetric: bool         # S₀⁻¹ applied by one triangle
    stiffness: np.ndarray      # Kr or K̃ (n, n)
    projected: np.ndarray      # (Πᵀ ⊗ I3) Kr (n, n)
    stiffness_symmetric: bool  # projected (rotor: stiffness) applied by one triangle
    affine: np.ndarray         # H (nf, 3)
    unit: np.ndarray           # k1 (nf,): Π = I − k1 (g1/m)ᵀ, Πᵀ = I − (g1/m) k1ᵀ
    unit_dual: np.ndarray      # g1 / m (nf,)
    q0_projected: np.ndarray   # Π Q0 (nf, 3)
    mass_projected: np.ndarray  # Πᵀ G (nf, nf): damping's α term
    q0: np.ndarray             # rotor p0 (n,)
    plane_map: np.ndarray      # rotor (4, n)
    turn: np.ndarray           # rotor P Ĵ (n, n)
    translation: np.ndarray    # rotor: the translation's coordinates (int)
    weights: np.ndarray        # rotor (w_c, w_s) (2, n)
    projectors: np.ndarray     # rotor A1, A2, A3 (3, 3, 3)
    damping: bool
    damping_alpha: float
    damping_beta: float
    rotor_damping: np.ndarray  # rotor P (α Mp + β K̃) P (n, n)
    svk_quadratic: np.ndarray  # A (s, s)
    svk_symmetric: bool        # A applied by one triangle
    svk_reference: np.ndarray  # P0 (nf, nf)
    svk_rows: np.ndarray       # packing rows (s,) int
    svk_cols: np.ndarray       # packing columns (s,) int
    svk_scale: np.ndarray      # packing scale (s,)
    m: int
    rank: int
    directions: np.ndarray     # u_i at θ = 0 (m, 3)
    targets: np.ndarray        # d (m,)
    frame_solves: np.ndarray   # (6, n): (S₀⁻¹ Hₓ)ᵀ and (S₀⁻¹ U₂)ᵀ (``compiled._relinearise``)
    vector_index: np.ndarray   # (m,) int: the row's vector k (``Constraints.index``)
    rows_all: np.ndarray       # (3 nv + rank, n): c_k(e_l) (row 3k + l), then G_x (per relinearisation)
    solves_all: np.ndarray     # (3 nv + rank, n): S₀⁻¹ c_k(e_l)ᵀ, then B_x
    unit_capacitance: np.ndarray  # W = rows_all solves_allᵀ, its rank blocks per relinearisation
    drive_rows: np.ndarray     # (d,) int
    drive_vectors: np.ndarray  # (d, 3, 3): u, e × u, e (e · u)
    drive_params: np.ndarray   # (d, 3): Ω, T, ramp (0 cosine, 1 cycloidal)
    gravity: np.ndarray        # f_g (n,)
    load_vectors: np.ndarray   # b_j (L, n)
    load_params: np.ndarray    # (L, 4): time kind, T, f, φ (rad)
    pad_plain: np.ndarray      # (m, m)
    border_exact: np.ndarray   # Bᵀ (m + rank, n)
    rows_exact: np.ndarray     # G (m + rank, n)
    pad_exact: np.ndarray      # (m + rank, m + rank)


def unsupported(integrator: Any) -> str | None:
    """Why the kernel cannot run this stepper (a message), or None when it can."""
    if not isinstance(integrator.linear, BorderedKKT):
        return f'jacobian = "{integrator.solver.jacobian}" (the assembled baseline)'
    body = integrator.body
    if not isinstance(body.mass, np.ndarray) or not isinstance(body.stiffness, np.ndarray):
        return "a sparse body (the full-order model)"
    if not hasattr(integrator.linear.solve0, "__self__"):
        return "another factorisation than the dense inverse"
    full = body.full if isinstance(body, RotorBody) else body
    if not isinstance(full.projections.stiffness, np.ndarray):
        return (f"a body of {full.field_count} fields, whose projections are kept as rank-one "
                "updates, not matrices")
    if integrator.law_kind is None:
        return "another elastic law than co-rotated or Saint Venant–Kirchhoff"
    return None


def step_data(integrator: Any) -> StepData:
    """The arrays of a stepper the kernel can run (:func:`unsupported` is None)."""
    body, c, linear = integrator.body, integrator.constraints, integrator.linear
    law = integrator.law_kind
    full = body.full if isinstance(body, RotorBody) else body
    n = body.dofs
    pr = full.projections
    m = c.count
    damping = integrator.damping
    arr = np.ascontiguousarray
    rotor = isinstance(body, RotorBody)
    svk = law == SVK
    if svk:
        law_obj = integrator.elastic.args[1]          # partial(svk_state, body, law)
        pack = law_obj.packing
    drives = sorted(c.drives)
    turning = {i: (u, e_u, along) for i, _, u, e_u, along in c.turning} if drives else {}
    loads = integrator.forces.loads
    kept = linear.kinds
    plain, exact = kept[False], kept[True]
    G = np.asarray(full.gram)
    s0_inverse = arr(linear.solve0.__self__)
    units = (np.ascontiguousarray(c.unit_rows()).reshape(-1, n) if m else np.zeros((0, n)))
    solves = (s0_inverse @ units.T).T
    rank = linear.kinds[True][0].shape[0] - m
    rows_all = np.vstack((units, np.zeros((rank, n))))
    solves_all = np.vstack((solves, np.zeros((rank, n))))
    return StepData(
        law=law, n=n, pairs=body.frame.pairs if rotor else 0,
        predictor=arr(integrator.predictor), update=arr(integrator.update.ravel()),
        gamma_p=float(integrator.gamma_p),
        tolerance=float(integrator.tolerance_m), total_mass=float(body.total_mass_kg),
        max_iterations=int(integrator.solver.max_iterations),
        exact_mode=integrator.solver.jacobian == "exact", upgrade_rate=UPGRADE_RATE,
        tangent_rate=TANGENT_RATE, reuse_steps=LOCAL_REUSE_STEPS,
        gram=arr(G), mass=arr(body.mass), s0_inverse=s0_inverse,
        s0_symmetric=n >= SYMMETRIC_FROM and symmetric(s0_inverse),
        stiffness_symmetric=n >= SYMMETRIC_FROM and symmetric(
            body.stiffness if rotor else pr.stiffness),
        stiffness=arr(body.stiffness),
        projected=arr(pr.stiffness) if not rotor else EMPTY2,
        affine=arr(full.affine), unit=arr(full.unit, dtype=float),
        unit_dual=arr(full.field_mass / full.total_mass_kg), q0_projected=arr(pr.q0),
        mass_projected=arr(np.asarray(pr.force) @ G),
        q0=arr(body.q0) if rotor else EMPTY1,
        plane_map=arr(body.plane_map) if rotor else EMPTY2,
        turn=arr(body.turn) if rotor else EMPTY2,
        translation=np.array(body.basis.translation if rotor else (), dtype=np.int64),
        weights=arr(body.weights) if rotor else EMPTY2,
        projectors=arr(np.array(body.frame._projectors)) if rotor else np.zeros((3, 3, 3)),
        damping=damping.active, damping_alpha=float(damping.alpha),
        damping_beta=float(damping.beta),
        rotor_damping=(arr(integrator.damping_force.operator) if rotor and damping.active
                       else EMPTY2),
        svk_quadratic=arr(law_obj.quadratic) if svk else EMPTY2,
        svk_symmetric=svk and len(law_obj.quadratic) >= SYMMETRIC_FROM and symmetric(
            law_obj.quadratic),
        svk_reference=arr(law_obj.reference) if svk else EMPTY2,
        svk_rows=arr(pack.rows, dtype=np.int64) if svk else np.zeros(0, np.int64),
        svk_cols=arr(pack.cols, dtype=np.int64) if svk else np.zeros(0, np.int64),
        svk_scale=arr(pack.scale) if svk else EMPTY1,
        m=m, rank=rank,
        directions=arr(c.directions, dtype=float).reshape(m, 3),
        targets=arr(c.targets, dtype=float),
        frame_solves=(frame_solves(full, s0_inverse) if not rotor else np.zeros((6, n))),
        vector_index=np.asarray(c.index, dtype=np.int64), rows_all=rows_all,
        solves_all=solves_all,
        unit_capacitance=rows_all @ solves_all.T,
        drive_rows=np.array(drives, dtype=np.int64),
        drive_vectors=np.array([turning[i] for i in drives]).reshape(len(drives), 3, 3),
        drive_params=np.array([(d.angular_velocity, d.ramp_time_s, DRIVE_RAMPS.index(d.ramp))
                               for d, _ in (c.drives[i] for i in drives)]).reshape(-1, 3),
        gravity=arr(integrator.forces.gravity_force, dtype=float),
        load_vectors=arr(np.asarray(integrator.forces.load_vectors).T).reshape(len(loads), n),
        load_params=np.array([(LOAD_TIMES[ld.time], ld.ramp_time_s, ld.frequency_hz,
                               np.radians(ld.phase_deg)) for ld in loads]).reshape(-1, 4),
        pad_plain=plain[2],
        border_exact=exact[0], rows_exact=exact[1], pad_exact=exact[2])


def symmetric(A: np.ndarray) -> bool:
    """Whether A equals its transpose exactly: then one triangle is the very matrix the NumPy
    step applies (S₀⁻¹ and (Πᵀ ⊗ I3) Kr are made so: ``factorization.dense_factorization``,
    ``body.projected_stiffness``); one symmetric only to round-off would move the two steps apart
    by more than round-off (1.4e-12 of q on the Nm = 20 pendulum, against 1.6e-14)."""
    A = np.asarray(A)
    return bool(np.array_equal(A, A.T))


def frame_solves(body: Body, s0_inverse: np.ndarray) -> np.ndarray:
    """(S₀⁻¹ Hₓ)ᵀ and (S₀⁻¹ U₂)ᵀ (6 × n), Hₓ[(f, a), j] = (h_f × e_a)_j and U₂[(f, j), k] =
    −(h_f × e_k)_j: the rank-9 term's columns Wᵀ = Hₓ S⁻¹ᵀ and U₂ (``corotated.local_frame_update``)
    times S₀⁻¹, once per run."""
    n = body.dofs
    crossed = np.cross(body.affine[:, None, :], np.eye(3)[None, :, :])   # [f, a, j]
    Hx = crossed.reshape(n, 3)
    U2 = -crossed.transpose(0, 2, 1).reshape(n, 3)
    return np.ascontiguousarray(np.vstack(((s0_inverse @ Hx).T, (s0_inverse @ U2).T)))


def law_kind(body: Body | RotorBody, elastic: Any, corotated: bool) -> int | None:
    """The kernel's law for a stepper: co-rotated (either basis), SVK (``svk.svk_state`` bound
    to a law), or None (another law: a reference's)."""
    if isinstance(body, RotorBody):
        return ROTOR
    if corotated:
        return COROTATED
    return SVK if isinstance(elastic, partial) and elastic.func is svk_state else None
