"""The IVP Test Set's flexible slider crank as an assembly with a 3D GCMS conrod
(``references.slider_crank_assembly``, ``dynamics.system``; docs/slider_crank.md).

- the conrod (8 × 8 mm × 0.30 m steel, P2 cells of 3 mm, ten free-free modes and the
  attachment modes of its pins: 159 coordinates) has the pinned–pinned bending frequencies of
  Timoshenko's beam, Euler–Bernoulli's (the test set's) lowered by (n²π²/2)(r/L)²(1 + E/κG)
  (shear and rotary inertia: 0.12 % and 0.48 %), to 0.05 %;
- started undeformed on the rigid trajectory, its midpoint deflection stays within 2 % of the
  peak (1.986 mm) of the ported test set whose two bending frequencies are the 3D conrod's and
  whose axial mass is consistent (``slider_crank.conrod_variant``; h = 2e-5 0.72 % measured). Against the test set as published it is 2.97 %, as the full-order
  conrod's: the Euler–Bernoulli frequencies put the benchmark's vibration out of phase by
  0.46 % of a period of the second mode a period (docs/slider_crank.md);
- with E × 1e4 the slider follows the rigid slider crank's closed form to 1e-8 of its travel
  and, once the start's transient has decayed (from 5 ms), the force at the slider pin the
  closed form's to 1e-3 of its peak (measured 3.4e-5).
"""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.app import pipeline
from gcms_fenicsx.config.study import parse_config
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.dynamics.system.march import march
from gcms_fenicsx.dynamics.system.stepper import AssemblyStepper, StepSettings, initial_state
from gcms_fenicsx.references import slider_crank as ref
from gcms_fenicsx.references import slider_crank_assembly as sca

pytestmark = pytest.mark.slow


def conrod(folder, stiffness_factor: float = 1.0):
    """The conrod's reduced body: 3 mm cells, ten modes and the attachment modes of its pins,
    E times ``stiffness_factor``."""
    material = dict(sca.CONROD_STUDY["material"])
    material["E"] *= stiffness_factor
    cfg = parse_config({**sca.CONROD_STUDY, "material": material, "mesh": {"size": 0.003},
                        "modes": {"count": 10}})
    folder.mkdir(parents=True, exist_ok=True)
    ff = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    return body_from_reduced(pipeline.reduction_stage(
        pipeline.basis_stage(ff.assembly.model, ff.modes, ff.body), cfg.selection))


def run(body, h: float, **probes):
    assembly = sca.slider_crank(body)
    stepper = AssemblyStepper(assembly, StepSettings(h, 0.8))
    return assembly, march(stepper, initial_state(stepper, sca.rigid_start_velocity(assembly)),
                           0.1, every=round(1e-4 / h), probes=probes)


def test_the_gcms_conrod_deflects_as_the_test_set_with_its_bending_frequencies(tmp_path):
    body = conrod(tmp_path)
    assert body.dofs == 159 and body.total_mass_kg == pytest.approx(ref.M2, rel=1e-9)
    bending = sca.pinned_bending_hz(body)
    kappa, shear = 10 * (1 + ref.NU) / (12 + 11 * ref.NU), 2 * (1 + ref.NU)
    slender = ref.H ** 2 / 12 / ref.L2 ** 2
    for n, (f, f_eb) in enumerate(zip(bending, ref.bending_frequencies_hz()), start=1):
        timoshenko = 1 - (n * np.pi) ** 2 / 2 * slender * (1 + shear / kappa)
        assert f / f_eb == pytest.approx(timoshenko, abs=5e-4)
    _, result = run(body, 2e-5, deflection=sca.midpoint_deflection(body))
    times = np.minimum(np.round(result.time_s, 12), 0.1)
    published = ref.midpoint_deflection(ref.solve("second", 0.1, times=times, rtol=1e-9,
                                                  atol=1e-12))
    matched = ref.midpoint_deflection(ref.solve("second", 0.1, times=times, rtol=1e-9,
                                                atol=1e-12,
                                                conrod=ref.conrod_variant(bending, True)))
    peak = np.abs(published).max()
    assert peak == pytest.approx(1.986e-3, rel=1e-3)
    error = np.abs(result.probes["deflection"] - matched).max() / peak
    assert error <= 0.02, error
    assert result.energy_drift_rel <= 1e-3


def test_a_stiff_conrod_moves_as_the_rigid_closed_form(tmp_path):
    body = conrod(tmp_path, 1e4)
    assembly, result = run(body, 5e-5, slider=lambda s: s.q[-3])
    pin = [i for i, r in enumerate(assembly.rows) if r.joint == "slider_pin"][:2]
    rigid = sca.rigid_reference(body, result.time_s)
    assert np.abs(result.probes["slider"] - rigid["slider_m"]).max() <= 1e-8 * 2 * ref.L1
    late = result.time_s >= 5e-3
    force = -result.multipliers[late][:, pin]
    peak = np.abs(rigid["pin_force_n"]).max(axis=0)
    assert (np.abs(force - rigid["pin_force_n"][late]).max(axis=0) <= 1e-3 * peak).all()
