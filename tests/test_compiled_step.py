"""The compiled step (``gcms_fenicsx.dynamics.stepping.compiled``) against the NumPy step, the
reference, on the same scenes: the committed six-mode test beam (66 coordinates) swinging on
a pin, damped, loaded, driven, spinning free, in the rotor basis, with the exact Newton
matrix, and under the Saint Venant–Kirchhoff law (whose slow steps the kernel hands to the
NumPy step, which redoes them with the exact tangent). Both paths give the same Newton
iterations at every step and the same trajectory to 1e-12 of its size.

The multipliers and the velocities are compared at the round-off their formulas amplify:
a step computes q̈ and q̇ from q as β'(q − q_pred) and γ'(q − q_pred), and λ from Mr q̈ and
the elastic forces, so a difference of one unit of round-off in q, ε max|q|, shows in λ as
β' m ε max|q| and in q̇ as γ' ε max|q| (m the body's mass); the bounds below are a thousand
times these, and the measured differences are written beside them.

These tests need Numba (scripts/setup.sh installs it); ``tests/dynamics`` checks the NumPy
path alone where the finite-element stack — SciPy, whose BLAS Numba's products call — is
absent.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from typing import NamedTuple

import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled step needs Numba (scripts/setup.sh)")

from beams import BEAM6, BEAM6_SVK  # noqa: E402
from gcms_fenicsx.config.scene import SceneError, parse_scene  # noqa: E402
from gcms_fenicsx.dynamics.bodies import body as body_module  # noqa: E402
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced  # noqa: E402
from gcms_fenicsx.dynamics.run.simulate import simulate  # noqa: E402
from gcms_fenicsx.dynamics.stepping import kernel, kernel_data  # noqa: E402
from gcms_fenicsx.dynamics.stepping.alpha import AlphaParameters, newton_coefficients  # noqa: E402
from gcms_fenicsx.files.reduced_model import read_reduced  # noqa: E402

EPS = float(np.finfo(float).eps)
PIN = {"type": "revolute", "group": "end_x0", "axis": [0.0, 1.0, 0.0]}
GRAVITY = [0.0, 0.0, -9.81]
#: Each case a scene table (h = 1e-4 s unless it says, 200 steps or fewer) and a basis.
CASES = {
    "pendulum": ({"joints": [PIN], "gravity": GRAVITY}, "full"),
    "damped and loaded": ({"joints": [PIN], "gravity": GRAVITY,
                           "damping": {"alpha": 0.5, "beta": 4e-5},
                           "loads": [{"group": "end_xL", "force": [0.0, 30.0, 0.0],
                                      "time": "harmonic", "frequency_hz": 120.0,
                                      "ramp_time": 0.005, "phase_deg": 30.0},
                                     {"group": "end_xL", "force": [5.0, 0.0, -20.0],
                                      "time": "ramp", "ramp_time": 0.01},
                                     {"group": "end_x0", "force": [0.0, 0.0, 3.0]}]}, "full"),
    "exact Newton matrix": ({"joints": [PIN], "gravity": GRAVITY,
                             "solver": {"jacobian": "exact"}}, "full"),
    "driven": ({"joints": [{"type": "revolute", "group": "end_x0", "axis": [1.0, 0.0, 0.0],
                            "drive": {"angular_velocity": 60.0, "ramp_time": 0.01,
                                      "ramp": "cycloidal"}},
                           {"type": "spherical", "group": "end_xL"}],
                "damping": {"beta": 2e-5}, "gravity": GRAVITY}, "full"),
    "free spin": ({"joints": [], "initial": {"angular_velocity": [10.0, 20.0, 30.0],
                                             "mode": 1, "amplitude": 1e-3}}, "full"),
    "rotor basis": ({"joints": [{"type": "revolute", "group": "end_x0", "axis": [0.0, 0.0, 1.0],
                                 "drive": {"angular_velocity": 40.0, "ramp_time": 0.01}}],
                     "damping": {"alpha": 0.2, "beta": 2e-5},
                     "loads": [{"group": "end_xL", "force": [0.0, 10.0, 0.0],
                                "time": "harmonic", "frequency_hz": 50.0}]}, "rotor"),
}


@pytest.fixture(scope="module")
def beam6():
    return read_reduced(BEAM6)


def both(model, table: dict, basis: str = "full", **options):
    """(NumPy run, compiled run): each (trajectory, summary), q recorded at every step."""
    table = dict({"end_time": 0.02, "time_step": 1e-4}, **table)
    scene = parse_scene(dict(table, outputs={"every": 1, "coordinates": True,
                                             "groups": ["end_xL"]}))
    runs = []
    for name in ("numpy", "numba"):
        s = replace(scene, solver=replace(scene.solver, kernel=name))
        runs.append(simulate(model, s, basis=basis, **options))
    assert runs[1][1]["kernel"]["name"] == "numba", runs[1][1]["kernel"]
    return runs


def kernel_data_made(monkeypatch) -> list:
    """The ``kernel_data.StepData`` of every compiled run from here on, in a list."""
    made: list = []

    def spy(integrator):
        made.append(kernel_data.step_data(integrator))
        return made[-1]

    monkeypatch.setattr(kernel, "step_data", spy)
    return made


def differences(a, b) -> dict[str, float]:
    """The largest differences of q, q̇ and λ over the run, each relative to its largest value."""
    out = {}
    for key, x, y in (("q", a.coordinates["q"], b.coordinates["q"]),
                      ("v", a.coordinates["v"], b.coordinates["v"]),
                      ("lambda", a.multipliers, b.multipliers)):
        scale = np.abs(x).max() if x.size else 0.0
        out[key] = float(np.abs(x - y).max() / scale) if scale else 0.0
    return out


def round_off(model, scene_table: dict, traj) -> dict[str, float]:
    """The bounds of the module docstring: 1000 ε max|q| carried into q̇ by γ' and into λ by
    β' m, relative to their largest values."""
    h = scene_table.get("time_step", 1e-4)
    beta_p, gamma_p = newton_coefficients(AlphaParameters.from_rho_inf(0.8), h)
    q = np.abs(traj.coordinates["q"]).max()
    mass = body_from_reduced(model).total_mass_kg
    unit = 1e3 * EPS * q
    lam = np.abs(traj.multipliers).max() if traj.multipliers.size else 1.0
    return {"q": 1e-12, "v": gamma_p * unit / np.abs(traj.coordinates["v"]).max(),
            "lambda": beta_p * mass * unit / lam}


@pytest.mark.slow
@pytest.mark.parametrize("triangle", [False, True], ids=["general", "one triangle"])
@pytest.mark.parametrize("case", list(CASES))
def test_compiled_step_is_the_numpy_step(beam6, case, triangle, monkeypatch):
    """Same iterations, trajectory to 1e-12. Measured (q, q̇, λ against their bounds):
    pendulum 8e-15, 2e-10 / 8e-9, 1e-7 / 8e-6; damped and loaded 1e-15, 1e-11 / 3e-9,
    3e-9 / 3e-7; exact 6e-15, 2e-10 / 8e-9, 1e-7 / 8e-6; driven 7e-16, 5e-13 / 1e-10,
    2e-8 / 3e-6; free spin (2.6 iterations a step: slow steps upgrade the matrix) 2e-14,
    3e-12 / 3e-10; rotor basis 7e-16, 3e-13 / 1e-10, 1e-10 / 2e-8. With S₀⁻¹ and the
    stiffness applied through one triangle (what the kernel does from
    ``kernel_data.SYMMETRIC_FROM`` coordinates on; the beam has 66) the same bounds hold."""
    table, basis = CASES[case]
    flags = kernel_data_made(monkeypatch)
    if triangle:
        monkeypatch.setattr(kernel_data, "SYMMETRIC_FROM", 0)
    (a, sa), (b, sb) = both(beam6, table, basis)
    assert [(d.s0_symmetric, d.stiffness_symmetric) for d in flags] == [(triangle, triangle)]
    assert sa["complete"] and sb["complete"], (sa["message"], sb["message"])
    assert sa["basis"] == sb["basis"] == basis
    assert np.array_equal(a.newton_iterations, b.newton_iterations)
    diff, bound = differences(a, b), round_off(beam6, table, a)
    for key in diff:
        assert diff[key] <= bound[key], (key, diff, bound)
    for key in ("kinetic", "elastic", "balance_error", "damping_dissipation", "load_work",
                "constraint_work"):
        scale = max(np.abs(a.energy["kinetic"]).max(), np.abs(a.energy["elastic"]).max())
        assert np.abs(a.energy[key] - b.energy[key]).max() <= 1e-9 * scale, key
    # the kernel's angular momentum Σ Q_f × (G Q̇)_f comes from the Mr q̇ it keeps as it steps
    # (predicted and corrected with Z), the NumPy step's from G Q̇: within q̇'s bound (measured
    # 1e-14 … 8e-12 of its largest value, against 1e-10 … 8e-9)
    L_numpy, L_kernel = a.momentum["angular"], b.momentum["angular"]
    assert np.abs(L_kernel - L_numpy).max() <= bound["v"] * np.abs(L_numpy).max()


@pytest.mark.slow
@pytest.mark.parametrize("triangle", [False, True], ids=["general", "one triangle"])
def test_steps_the_kernel_hands_over_are_the_numpy_steps(beam6, triangle, monkeypatch):
    """The SVK law's slow steps are redone by the NumPy step with the exact tangent (the kernel
    hands them over): a free body spinning and vibrating in its first mode, as
    ``tests/dynamics/test_svk`` steps it, takes the same iterations and path in both — with
    its 253 coefficients applied as a general matrix and through one triangle."""
    model = read_reduced(BEAM6_SVK)
    table = {"end_time": 0.01, "time_step": 1e-4, "rho_inf": 1.0, "elasticity": "svk",
             "initial": {"angular_velocity": [6.0, 20.0, 10.0], "mode": 1, "amplitude": 1e-3}}
    monkeypatch.setattr(kernel_data, "SYMMETRIC_FROM", 253 if triangle else 254)
    flags = kernel_data_made(monkeypatch)
    (a, sa), (b, sb) = both(model, table)
    assert [d.svk_symmetric for d in flags] == [triangle]
    assert sa["complete"] and sb["complete"]
    assert a.newton_iterations.max() > 3          # some steps needed the tangent
    assert np.array_equal(a.newton_iterations, b.newton_iterations)
    assert differences(a, b)["q"] <= 1e-12


class _Held(NamedTuple):
    count: int
    a: np.ndarray
    inner: tuple


def test_unowned_views_are_the_callers_arrays():
    """``compiled.unowned`` (a stretch reads its arguments so, without reference counts) gives
    the very arrays of a named tuple nested with tuples: a write through a view shows in the
    caller's array, the strides and the other entries are kept; and a view of it has no owner
    (returned to Python, its base is None, where a counted view's is Numba's owner)."""
    from numba import njit

    from gcms_fenicsx.dynamics.stepping.compiled.unowned import unowned

    @njit
    def write_through(held):
        view = unowned(held)
        view.a[1, 2] = 7.0
        view.inner[1][0] = -1.0
        return view.count, view.a.strides[0], view.inner[0].sum(), view.a.sum()

    @njit
    def views(a):
        return a[1:], unowned(a)[1:]

    held = _Held(5, np.zeros((3, 4)), (np.arange(4.0), np.ones(2)))
    assert write_through(held) == (5, 32, 6.0, 7.0)
    assert held.a[1, 2] == 7.0 and held.inner[1][0] == -1.0
    x = np.arange(4.0)
    counted, uncounted = views(x)      # x is held here, so the uncounted view stays valid
    assert counted.base is not None and uncounted.base is None, "the view has no owner"
    assert uncounted[0] == 1.0


def test_a_body_of_many_fields_is_stepped_by_numpy(beam6, monkeypatch):
    """A body of more than ``body.DENSE_PROJECTION_FIELDS`` fields keeps Π as rank-one updates,
    which the kernel does not take: "auto" runs the NumPy step and says why (before, packing
    the kernel's data failed on them). The limit lowered to 10 makes the beam (22 fields) one."""
    monkeypatch.setattr(body_module, "DENSE_PROJECTION_FIELDS", 10)
    scene = parse_scene({"joints": [PIN], "gravity": GRAVITY, "end_time": 0.002,
                         "time_step": 1e-4})
    _, summary = simulate(beam6, scene)
    assert summary["complete"], summary["message"]
    assert summary["kernel"]["name"] == "numpy"
    assert "22 fields, whose projections are kept as rank-one" in summary["kernel"]["reason"]


@pytest.mark.slow
def test_a_failing_step_fails_as_in_numpy(beam6):
    """A step that does not converge ends both runs at the same step with the same message
    (the NumPy step says it), and the steps before it are recorded alike."""
    table = {"joints": [PIN], "gravity": GRAVITY, "solver": {"max_iterations": 1}}
    (a, sa), (b, sb) = both(beam6, table)
    assert not sa["complete"] and not sb["complete"]
    assert sa["message"] == sb["message"] and "did not converge" in sa["message"]
    assert sa["steps"] == sb["steps"]
    assert np.array_equal(a.time, b.time)


@pytest.mark.slow
def test_snapshots_and_blocks_are_recorded_alike(beam6, monkeypatch):
    """Field snapshots at their times and rows streamed in many small blocks (the kernel stops
    at a snapshot and at a full block) give the NumPy run's results."""
    monkeypatch.setattr("gcms_fenicsx.files.results.BLOCK_BYTES", 4000)
    monkeypatch.setattr("gcms_fenicsx.dynamics.run.recorder.BLOCK_BYTES", 4000)
    table = {"joints": [PIN], "gravity": GRAVITY}
    scene = parse_scene(dict(table, end_time=0.02, time_step=1e-4,
                             outputs={"every": 3, "field_times": [0.0031, 0.0107, 0.02]}))
    runs = [simulate(beam6, replace(scene, solver=replace(scene.solver, kernel=name)))
            for name in ("numpy", "numba")]
    (a, _), (b, _) = runs
    assert np.array_equal(a.time, b.time)
    assert np.array_equal(a.field_time, b.field_time) and len(a.field_time) == 3
    assert np.abs(a.displacement - b.displacement).max() <= 1e-12 * np.abs(
        a.displacement).max()
    assert np.array_equal(a.newton_iterations, b.newton_iterations)


def test_the_kernel_choice_is_said_and_kept(beam6, monkeypatch):
    """``kernel = "numpy"`` and ``GCMS_KERNEL=numpy`` step in NumPy; "auto" without Numba steps
    in NumPy and says why; "numba" where it cannot run refuses, naming why."""
    scene = parse_scene({"end_time": 2e-4, "time_step": 1e-4})
    lines: list[str] = []
    _, summary = simulate(beam6, replace(scene, solver=replace(scene.solver, kernel="numpy")))
    assert summary["kernel"]["name"] == "numpy"
    monkeypatch.setenv("GCMS_KERNEL", "numpy")
    _, summary = simulate(beam6, scene)
    assert summary["kernel"] == {"name": "numpy", "reason": "asked for", "compile_s": None,
                                 "loaded_from_cache": None}
    monkeypatch.setenv("GCMS_KERNEL", "fast")
    with pytest.raises(SceneError, match="GCMS_KERNEL = 'fast' must be one of 'auto'"):
        simulate(beam6, scene)
    monkeypatch.delenv("GCMS_KERNEL")
    monkeypatch.setattr(kernel, "numba_missing", lambda: "Numba is not installed (test)")
    _, summary = simulate(beam6, scene, progress=lines.append)
    assert summary["kernel"]["name"] == "numpy"
    assert "simulate: stepping in NumPy (Numba is not installed (test))" in lines
    numba = replace(scene, solver=replace(scene.solver, kernel="numba"))
    with pytest.raises(SceneError, match='kernel = "numba" cannot run this scene: Numba is not'):
        simulate(beam6, numba)
    monkeypatch.undo()
    assembled = replace(numba, solver=replace(numba.solver, jacobian="assembled"))
    with pytest.raises(SceneError, match='cannot run this scene: jacobian = "assembled"'):
        simulate(beam6, assembled)


def test_a_kernel_that_does_not_compile_leaves_the_run_to_numpy(beam6, monkeypatch):
    """A compile failure (here: forced) is one warning, and the run steps in NumPy."""
    def broken(self, recorder, state):
        raise RuntimeError("no LLVM here\nmore")
    monkeypatch.setattr(kernel.CompiledStepper, "warm_up", broken)
    lines: list[str] = []
    _, summary = simulate(beam6, parse_scene({"end_time": 2e-4, "time_step": 1e-4}),
                          progress=lines.append)
    assert summary["complete"] and summary["kernel"]["name"] == "numpy"
    assert ("warning: simulate: stepping in NumPy (the kernel did not compile: RuntimeError: "
            "no LLVM here)") in lines


@pytest.mark.parametrize("chosen", [None, "host"])
def test_the_kernel_compiles_for_the_generic_model_unless_the_user_chose_one(chosen):
    """``kernel.compile_for_generic_model``: in a new process, the kernel's codegen takes LLVM's
    generic CPU model with this machine's instruction set (the host's model cost 3.2× the
    compile on one machine); a ``NUMBA_CPU_NAME`` the user set is kept."""
    script = ("from gcms_fenicsx.dynamics.stepping import kernel; kernel.kernel_module(); "
              "from numba.core import registry; from numba.core.codegen import "
              "get_host_cpu_features as host; c = registry.cpu_target.target_context.codegen(); "
              "print(c._get_host_cpu_name(), c._get_host_cpu_features() == host())")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CPU_")}
    if chosen:
        env["NUMBA_CPU_NAME"] = chosen
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=300, env=env)
    assert run.returncode == 0, run.stderr
    name, same_features = run.stdout.split()
    assert (name, same_features) == (chosen or "generic", "True")


@pytest.mark.slow
def test_a_damaged_kernel_cache_is_compiled_again(beam6, tmp_path):
    """A cached kernel file that does not load (its bytes overwritten) is removed with its
    folder and the kernel compiled afresh, in a new process as a user's next run: the run
    steps compiled, not in NumPy.

    The damaged cache is a copy of this machine's, under a ``NUMBA_CACHE_DIR`` of its own
    (``kernel.cache_folder``), so the shared cache stays intact for every other test (and
    test process); the new process recompiles at ``NUMBA_OPT=0``, which exercises the same
    recovery in less time (54 s against 76 s at the default level on the slowest machine
    measured: the compile is mostly LLVM's optimisation) and writes only into that copy."""
    import shutil

    scene = parse_scene({"end_time": 2e-4, "time_step": 1e-4, "solver": {"kernel": "numba"}})
    simulate(beam6, scene)                        # the machine's cache, to copy and damage
    own = tmp_path / "gcms-fenicsx" / kernel.cache_folder().name
    shutil.copytree(kernel.cache_folder(), own)
    damaged = list(own.rglob("step.run_stretch*.nbc"))
    assert damaged
    for path in damaged:
        path.write_bytes(b"\x00not a pickle" * 64)
    script = ("import json, sys; from gcms_fenicsx.dynamics import parse_scene, read_reduced, "
              "simulate; s = simulate(read_reduced(sys.argv[1]), parse_scene({'end_time': 2e-4, "
              "'time_step': 1e-4, 'solver': {'kernel': 'numba'}}))[1]; print(json.dumps(s['kernel']))")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), NUMBA_OPT="0")
    run = subprocess.run([sys.executable, "-c", script, str(BEAM6)], capture_output=True,
                         text=True, timeout=600, env=env)
    assert run.returncode == 0, run.stderr
    choice = json.loads(run.stdout.strip().splitlines()[-1])
    assert choice["name"] == "numba" and choice["loaded_from_cache"] is False, choice
    assert not any(path.exists() and path.read_bytes().startswith(b"\x00not a pickle")
                   for path in damaged)
