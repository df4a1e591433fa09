"""Geometrically exact Saint Venant–Kirchhoff GCMS (``gcms_fenicsx.dynamics.bodies.svk``) on the
committed six-mode test beam with its SVK coefficients (``beams.BEAM6_SVK``): an analytic
energy, objectivity, the exact tangent against finite differences, the small-strain limit
(the co-rotated linear model) and conservation with the generalized-α integrator.

That the coefficients integrate the same energy as the full finite-element model is checked
where dolfinx is (``tests/test_svk_coefficients.py``).
"""
from __future__ import annotations

import numpy as np
import pytest

from beams import BEAM6_SVK, E_STEEL, HEIGHT_Z, LENGTH, NU_STEEL, WIDTH_Y
from gcms_fenicsx.dynamics.constraints import kkt
from gcms_fenicsx.dynamics.bodies import svk
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.dynamics.bodies.corotated import elastic_state
from gcms_fenicsx.numerics.rotation import rotation_about
from gcms_fenicsx.config.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate, simulate_body
from gcms_fenicsx.files.reduced_model import read_reduced
from test_dynamics import deformed, moved, observed_orders, random_rotation

EPS = np.finfo(float).eps


@pytest.fixture(scope="module")
def beam():
    """(model, body, law) of the six-mode beam with its SVK coefficients."""
    model = read_reduced(BEAM6_SVK)
    assert model.svk is not None and model.schema_version == 3
    body = body_from_reduced(model)
    return model, body, svk.SVKLaw.of(model.svk, body)


def test_uniform_stretch_has_the_analytic_energy_in_any_orientation(beam):
    """x = R F X with F = diag(1 + e, 1, 1): C = diag((1 + e)², 1, 1), so the energy is
    (λ/2 + μ) E₁₁² · volume with E₁₁ = ((1 + e)² − 1) / 2, for every rotation R — exact
    for the GCMS affine fields, so to round-off (the energy of a
    stretch of 1e-3 is 1e-13 of what the naive ½pᵀAp + bᵀp + c would cancel; evaluated about
    the undeformed state it is measured 2.5e-13, bound 1e-11)."""
    _, body, c = beam
    mu = E_STEEL / (2 * (1 + NU_STEEL))
    lam = E_STEEL * NU_STEEL / ((1 + NU_STEEL) * (1 - 2 * NU_STEEL))
    volume = LENGTH * WIDTH_Y * HEIGHT_Z
    Q0 = body.q0.reshape(-1, 3)
    rng = np.random.default_rng(3)
    for e in (1e-3, 0.1, -0.3):
        E11 = ((1 + e) ** 2 - 1) / 2
        expected = (lam / 2 + mu) * E11 ** 2 * volume
        for R in (np.eye(3), random_rotation(rng)):
            A = R @ np.diag([1 + e, 1.0, 1.0])
            assert c.energy((Q0 @ A.T).ravel()) == pytest.approx(expected, rel=1e-11)


def test_rigid_motions_have_no_energy_or_force_and_deformed_states_turn_with_the_body(beam):
    """Objectivity by construction (V depends on Q Qᵀ only): the undeformed body moved rigidly
    has zero force and energy to the round-off of forming δ = svec(Q̃Q̃ᵀ − P0), about
    10 nf ε ‖Q̃‖²: bounded by the force and energy of a 1 mm deformation scaled by that δ
    against its own (V ∝ δ², f ∝ δ). Measured 1e-8 … 3e-7 N against the bound 1.6e-5 N; the
    naive ½pᵀAp + bᵀp + c, cancelling against c, gives 3e-5 … 3e-3 N and fails it. A
    deformed state moved rigidly keeps its energy and turns its force with it."""
    _, body, c = beam
    rng = np.random.default_rng(5)
    nf, pack = body.field_count, svk.packing(body.field_count)
    reference = deformed(body, rng, 1e-3)
    Qr = c.centring @ reference.reshape(-1, 3)
    delta_ref = np.linalg.norm(pack.svec(Qr @ Qr.T - c.reference))
    for scale in (0.0, 1.0, 10.0):
        q = moved(body, body.q0, random_rotation(rng), scale * rng.normal(size=3))
        Qc = c.centring @ q.reshape(-1, 3)
        share = 10 * nf * EPS * np.linalg.norm(Qc) ** 2 / delta_ref
        assert np.linalg.norm(c.force(q)) <= share * np.linalg.norm(c.force(reference))
        assert abs(c.energy(q)) <= share ** 2 * c.energy(reference)
    q = deformed(body, rng, 5e-3)
    f, V = c.force(q), c.energy(q)
    R = random_rotation(rng)
    turned = moved(body, q, R, rng.normal(size=3))
    assert c.energy(turned) == pytest.approx(V, rel=1e-9)
    expected = (f.reshape(-1, 3) @ R.T).ravel()
    assert np.linalg.norm(c.force(turned) - expected) <= 1e-9 * np.linalg.norm(f)


@pytest.mark.parametrize("amplitude_m", [2e-3, 5e-2])
def test_exact_tangent_and_force_match_finite_differences(beam, amplitude_m):
    """At deformed, rotated and translated states (largest displacement 2 mm and 50 mm, a
    tenth of the beam's length): the tangent (3) matches central differences of the force,
    and the force central differences of the energy, to 1e-6 relative; the tangent is
    symmetric to round-off. The energy is a quartic in q whose fourth derivative is of the
    size of A (10⁸ N/m² · m³ here), so the truncation of a central difference of the force
    is ~h² ‖A‖ and of the energy ~h² ‖∂³V‖, the latter 7e-4 relative at h = 1e-6 (measured:
    it falls as h² down to h = 1e-8). Steps: 1e-6 for the force (truncation ~1e-9 measured,
    round-off ~ε‖f‖/h) and 1e-8 for the energy (truncation 7e-8, round-off ε V / h ~ 5e-7 of
    ‖f‖ here), both below 1e-6."""
    _, body, c = beam
    rng = np.random.default_rng(11)
    q = moved(body, deformed(body, rng, amplitude_m), random_rotation(rng), rng.normal(size=3))
    K, f = c.tangent(q), c.force(q)
    n, h, h_energy = body.dofs, 1e-6, 1e-8
    fd, dv = np.empty((n, n)), np.empty(n)
    for j, e_j in enumerate(np.eye(n)):
        fd[:, j] = (c.force(q + h * e_j) - c.force(q - h * e_j)) / (2 * h)
        dv[j] = (c.energy(q + h_energy * e_j) - c.energy(q - h_energy * e_j)) / (2 * h_energy)
    assert np.linalg.norm(fd - K) <= 1e-6 * np.linalg.norm(K)
    assert np.linalg.norm(dv - f) <= 1e-6 * np.linalg.norm(f)
    assert np.abs(K - K.T).max() <= 100 * EPS * np.abs(K).max()


def test_small_strain_limit_is_the_corotated_linear_model(beam):
    """At small amplitude a the SVK forces equal the co-rotated linear ones up to O(a): for a
    deformed and rotated state the relative difference falls 100× (to within 50 %) when the
    amplitude does, and the energies agree to 1e-4. The two models share the kinematics and
    Hooke's law at small strain (the SVK tangent at q0 is Kr to 5e-12, measured); they differ
    in the strain's quadratic part ½ ∇uᵀ∇u. Its force is not small for a slender body: a
    fibre turned by θ is stretched by ½ θ², against the axial stiffness, (L/r)² ≈ 7500
    times the bending one here — stress stiffening's origin. Measured: 2.0 % at a largest
    displacement of 2 µm (θ ~ 1e-5), 0.02 % at 20 nm."""
    _, body, c = beam
    rng = np.random.default_rng(2)
    shape = deformed(body, rng, 1.0) - body.q0
    R = rotation_about(np.array([0.36, 0.48, 0.8]), 0.9)
    diffs = []
    for amplitude in (2e-6, 2e-8):
        q = moved(body, body.q0 + amplitude * shape, R, np.zeros(3))
        linear = elastic_state(body, q)
        diffs.append(np.linalg.norm(c.force(q) - linear.force) / np.linalg.norm(linear.force))
        assert c.energy(q) == pytest.approx(linear.energy, rel=1e-4)
    assert diffs[0] < 0.05, diffs
    assert diffs[1] < 1.5e-2 * diffs[0], diffs


def test_free_spinning_body_conserves_energy_at_second_order(beam, monkeypatch):
    """A free body spinning (ω = 20·(0.3, 1, 0.5) rad/s), drifting and vibrating in its first
    elastic mode (1 mm: the SVK energy of that linear mode shape is 4.9 % above the linear
    one — fibres turned by θ stretch by ½θ²), ρ∞ = 1, with the SVK law: linear momentum is
    conserved to round-off,
    and the energy and angular-momentum drifts over 20 ms shrink at the order of
    generalized-α (observed orders between 1.7 and 2.4 for h, h/2, h/4), as for the co-rotated
    law (``test_dynamics``): a force that were not the gradient of the energy would drift at
    first order. The slender beam's SVK tangent is far from the linear one here, so the
    integrator's Newton switches to the exact tangent (``kkt.TangentKKT``)."""
    model, body, _ = beam
    tangents = []
    prepare = kkt.TangentKKT.prepare
    monkeypatch.setattr(kkt.TangentKKT, "prepare",
                        lambda self, *args, **kw: tangents.append(1) or prepare(self, *args, **kw))
    axis = np.array([0.3, 1.0, 0.5])
    energy, angular = [], []
    for h in (1e-4, 5e-5, 2.5e-5):
        traj, summary = simulate(model, parse_scene(dict(
            end_time=0.02, time_step=h, rho_inf=1.0, elasticity="svk",
            initial={"velocity": [0.1, 0.2, -0.3], "angular_velocity": list(20.0 * axis),
                     "mode": 1, "amplitude": 1e-3},
            solver={"tolerance": 1e-13, "max_iterations": 100})))
        assert summary["complete"], summary["message"]
        p, L = traj.momentum["linear"], traj.momentum["angular"]
        assert np.linalg.norm(p - p[0], axis=1).max() <= 1e-12 * np.linalg.norm(p[0])
        total = traj.energy["kinetic"] + traj.energy["elastic"]
        assert traj.energy["elastic"].max() > 0.05 * total[0]
        energy.append(np.abs(total - total[0]).max() / total[0])
        angular.append(np.linalg.norm(L - L[0], axis=1).max() / np.linalg.norm(L[0]))
    for p_energy, p_angular in zip(observed_orders(energy), observed_orders(angular)):
        assert 1.7 < p_energy < 2.4, (energy, observed_orders(energy))
        assert 1.7 < p_angular < 2.4, (angular, observed_orders(angular))
    assert tangents      # the steps were redone with the exact tangent


def test_svk_scene_needs_the_coefficients_and_the_corotated_scene_ignores_them(beam,
                                                                                beam6_model):
    """A model reduced without the coefficients is refused by an SVK scene, saying what to do;
    the model with them runs a co-rotated scene as the one without does (same body)."""
    model, _, _ = beam
    scene = parse_scene(dict(end_time=2e-4, time_step=1e-4, elasticity="svk"))
    with pytest.raises(SceneError, match='elasticity = "svk" needs the Saint Venant'):
        simulate(beam6_model, scene)
    with pytest.raises(SceneError, match='elasticity = "svk" needs its law'):
        simulate_body(body_from_reduced(model), scene)      # a body alone has no law
    corotated = parse_scene(dict(end_time=1e-3, time_step=1e-4,
                                 initial={"mode": 1, "amplitude": 1e-3}))
    a, _ = simulate(model, corotated)
    b, _ = simulate_body(body_from_reduced(beam6_model), corotated)
    assert np.allclose(a.energy["elastic"], b.energy["elastic"], rtol=1e-9)


def test_a_large_initial_mode_shape_is_reported_as_far_from_the_mode(beam):
    """A linear mode shape scaled to 2 mm has 1.2 times its linear energy under SVK (fibres
    turned by θ stretch by ½θ²): the run says so and which amplitude keeps the two within
    10 %; at 0.1 mm (ratio 1.0005) it says nothing. The run itself goes on."""
    model, _, _ = beam
    for amplitude, warned in ((2e-3, True), (1e-4, False)):
        lines: list[str] = []
        _, summary = simulate(model, parse_scene(dict(
            end_time=2e-5, time_step=1e-5, elasticity="svk",
            initial={"mode": 1, "amplitude": amplitude})), progress=lines.append)
        assert summary["complete"], summary["message"]
        said = [line for line in lines if "[scene.initial] mode 1" in line]
        assert bool(said) == warned, lines
        if warned:
            assert "times its linear elastic energy" in said[0] and "keeps the two within 10%" \
                in said[0]
