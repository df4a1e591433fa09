"""Issue 27, item 4, the NumPy-only parts (``tests/test_reliability_small.py`` has the rest):
the energy drift of a body at rest and a run too long to finish.

On the committed six-mode test beam (``beams``).
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.dynamics.run.capacity import MAX_STEPS, Capacity, check_capacity
from gcms_fenicsx.dynamics.constraints.joints import build_constraints
from gcms_fenicsx.dynamics.run.recorder import ENERGY_FLOOR_TOLERANCES, record_plan
from gcms_fenicsx.config.scene import SceneError, parse_scene
from gcms_fenicsx.dynamics.run.simulate import simulate_body

CLAMP = {"type": "fixed", "group": "end_x0", "name": "clamp"}


def test_a_body_at_rest_has_a_small_relative_energy_drift_and_its_absolute_one(beam6_body):
    """The clamped beam without gravity or loads stays at rest: its balance error is round-off
    of energies that are themselves round-off, so the relative drift is measured against the
    floor (the kinetic energy of the body moving ENERGY_FLOOR_TOLERANCES Newton tolerances
    per step)
    and far below 1; the absolute drift is the largest |balance error| recorded. Dropped under
    gravity, the beam moves far above the floor, which then changes nothing."""
    body = beam6_body
    scene = parse_scene({"end_time": 0.01, "time_step": 1e-4, "joints": [CLAMP]})
    resolved = ENERGY_FLOOR_TOLERANCES * scene.solver.tolerance * body.size_m
    floor = 0.5 * body.total_mass_kg * (resolved / scene.time_step_s) ** 2
    rest, summary = simulate_body(body, scene)
    assert summary["complete"], summary["message"]
    balance = np.abs(rest.energy["balance_error"]).max()
    motion = (rest.energy["kinetic"] + rest.energy["elastic"]).max()
    assert motion < floor                                   # at rest: below the floor
    assert summary["energy_drift_rel"] == balance / floor
    assert summary["energy_drift_rel"] < 1e-6   # measured 4.3e-8 (1.1e-19 J of 2.5e-12 J)
    assert summary["energy_drift_abs_j"] == balance
    dropped, summary = simulate_body(body, parse_scene({
        "end_time": 0.01, "time_step": 1e-4, "joints": [CLAMP], "gravity": [0, 0, -9.81]}))
    energy = dropped.energy
    motion = (energy["kinetic"] + energy["elastic"]).max()
    assert motion > 1e3 * floor
    scale = max(motion, np.abs(energy["load_work"]).max(),
                np.abs(energy["constraint_work"]).max())
    assert summary["energy_drift_rel"] == np.abs(energy["balance_error"]).max() / scale


def test_an_end_time_that_would_step_for_days_is_refused_in_one_line(beam6_body):
    """``end_time = 1e12`` at 1 ms with sparse outputs fits the disk but is 1e15 steps (years
    at any rate): the check every run makes before its first step (``check_capacity``, in
    ``prepare_run``) refuses it, naming [scene] end_time, the steps and the bound. At the
    bound (MAX_STEPS steps) it passes."""
    body, sparse = beam6_body, {"time_step": 1e-3, "outputs": {"every": 10**9}}
    for end_time, refused in ((1e12, True), (MAX_STEPS * 1e-3, False)):
        scene = parse_scene(dict(sparse, end_time=end_time))
        plan = record_plan(body, build_constraints(body, (), body.q0), scene)
        capacity = Capacity(plan.total_bytes, "free on /nowhere")   # the results fit
        if not refused:
            assert plan.steps == MAX_STEPS
            check_capacity(plan, capacity, scene)
            continue
        with pytest.raises(SceneError) as caught:
            check_capacity(plan, capacity, scene)
        text = str(caught.value)
        assert text.startswith("[scene] end_time = 1e+12: 1e+15 steps of 0.001 s")
        assert f"more than the {MAX_STEPS:.3g}" in text and "\n" not in text
