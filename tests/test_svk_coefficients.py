"""The Saint Venant–Kirchhoff coefficients of ``gcms reduce`` (``fe.svk_coefficients``,
docs/design.md §7.2): the reduced energy is the full finite-element SVK energy of the same
displacement (an independent assembly by dolfinx), two ranks give the serial coefficients,
and reduced.h5 carries them under schema 3, cached with the elastic law in its key.

The forces, tangent and integration are tested without the finite-element stack
(``tests/dynamics/test_svk.py``).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from dolfinx import fem

from beams import beam_svk_study
from conftest import gcms, gcms_reduce, mpirun
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.study import parse_config
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.dynamics.bodies.body import body_from_reduced
from gcms_fenicsx.numerics.rotation import rotation_about
from gcms_fenicsx.dynamics.bodies.svk import SVKLaw
from gcms_fenicsx.fe.mesh import read_mesh
from gcms_fenicsx.fe.node_order import input_node_indices
from gcms_fenicsx.files import reduced_model as rm
from gcms_fenicsx.files.versioned import open_versioned
from gcms_fenicsx.references.full_order import svk_forms


@pytest.fixture(scope="module")
def reduced(tmp_path_factory):
    """(folder, model): ``gcms reduce`` of the six-mode test beam with an SVK scene."""
    folder = tmp_path_factory.mktemp("svk")
    gcms_reduce(beam_svk_study(6), folder / "study.toml", folder)
    return folder, rm.read_reduced(folder / "reduced.h5")


@pytest.mark.slow
def test_reduced_energy_is_the_full_order_svk_energy(reduced):
    """For states of every size — a small and a 30 % deformation of the elastic fields, turned
    by 0.9 rad — the reduced SVK energy (from the coefficients alone) equals the SVK energy
    dolfinx assembles for the displacement F Q − X on the same mesh (reference (b)'s forms,
    same quadrature): the coefficients integrate the energy exactly, as Galerkin demands.
    Measured agreement 1.3e-13 (small) and 2e-16 (30 %); bound 1e-9 (the round-off of sums
    over 10⁴ points of terms that cancel to the small state's energy)."""
    folder, model = reduced
    body = body_from_reduced(model)
    law = SVKLaw.of(model.svk, body)
    mesh = read_mesh(folder / "mesh.msh", {}).mesh
    V = fem.VectorFunctionSpace(mesh, ("Lagrange", mesh.geometry.cmap.degree))
    Vs = fem.FunctionSpace(mesh, ("Lagrange", mesh.geometry.cmap.degree))
    index = input_node_indices(Vs)
    u = fem.Function(V)
    _, energy = svk_forms(V, Material(**model.material), u)
    energy_form = fem.form(energy)
    rng = np.random.default_rng(4)
    elastic = np.repeat(np.arange(body.field_count) >= 4, 3)
    R = rotation_about(np.array([0.36, 0.48, 0.8]), 0.9)
    for size in (1e-4, 0.3):
        step = rng.normal(size=body.dofs) * elastic
        q = body.q0 + size * step / np.abs(body.displacement(body.q0 + step)).max()
        q = (q.reshape(-1, 3) @ R.T).ravel()
        u.x.array[:] = body.displacement(q)[index].ravel()
        full = fem.assemble_scalar(energy_form)
        assert full > 0
        assert law.energy(q) == pytest.approx(full, rel=1e-9)


@pytest.mark.slow
def test_two_ranks_give_the_serial_coefficients(reduced, tmp_path):
    """The same fields on the same mesh file, summed over two ranks' cells: the coefficients
    agree with the serial ones to round-off (bound 1e-12 relative, measured 4e-17 and 1e-16:
    the same points summed in another order), with the same number of quadrature points."""
    folder, model = reduced
    result = tmp_path / "two_ranks.npz"
    run = mpirun(["tests/mpi_svk_coefficients.py", str(folder), str(result)], n=2)
    assert run.returncode == 0, run.stderr
    two = np.load(result)
    assert np.abs(two["quadratic"] - model.svk.quadratic).max() \
        <= 1e-12 * np.abs(model.svk.quadratic).max()
    assert np.abs(two["linear"] - model.svk.linear).max() <= 1e-12 * np.abs(model.svk.linear).max()
    assert float(two["constant"]) == pytest.approx(model.svk.constant, rel=1e-12)
    report = json.loads((folder / "selection.json").read_text())["svk_coefficients"]
    assert int(two["points"]) == report["quadrature_points"]


@pytest.mark.slow
def test_reduced_file_schema_report_and_cache(reduced, tmp_path):
    """reduced.h5 with the coefficients is schema 3, which a schema-2 reader refuses as newer;
    selection.json reports their size and time; a rerun reuses the file, and so does the same
    study with the co-rotated law (the coefficients are a superset it ignores). A co-rotated
    reduction in a fresh folder is schema 2 without them, and the SVK study then rebuilds only
    the reduction (modes reused), saying that the elasticity changed."""
    folder, model = reduced
    assert model.schema_version == 3 and model.svk is not None
    nf = len(model.field_names)
    report = json.loads((folder / "selection.json").read_text())["svk_coefficients"]
    assert report["fields"] == nf and report["packed_size"] == nf * (nf + 1) // 2
    assert report["bytes"] == model.svk.nbytes and report["seconds"] > 0
    with pytest.raises(rm.ReducedModelError, match="newer gcms-fenicsx: schema 3, this reader "
                       "understands up to 2"):
        with open_versioned(folder / "reduced.h5", rm.ReducedModelError, "reduced model",
                            "schema", 2, checksums_since=2):
            pass
    config = folder / "study.toml"
    rerun = gcms("reduce", str(config), "--out", str(folder))
    assert rerun.returncode == 0, rerun.stderr
    assert "reduced model: reused" in rerun.stdout
    corotated = tmp_path / "corotated.toml"
    corotated.write_text(config.read_text().replace('elasticity = "svk"', ""))
    same = gcms("reduce", str(corotated), "--out", str(folder))
    assert same.returncode == 0, same.stderr
    assert "reduced model: reused" in same.stdout
    fresh = tmp_path / "fresh"
    plain_run = gcms("reduce", str(corotated), "--out", str(fresh))
    assert plain_run.returncode == 0, plain_run.stderr
    plain = rm.read_reduced(fresh / "reduced.h5")
    assert plain.schema_version == 2 and plain.svk is None
    assert "svk_coefficients" not in json.loads((fresh / "selection.json").read_text())
    again = gcms("reduce", str(config), "--out", str(fresh))
    assert again.returncode == 0, again.stderr
    assert "modes: reusing" in again.stderr and "Saint Venant" in again.stderr
    assert "was made without the SVK coefficients ([scene] elasticity changed)" in again.stderr
    assert rm.read_reduced(fresh / "reduced.h5").svk is not None


@pytest.mark.parametrize("scene, message", [
    ({"elasticity": "neo-hookean"}, "must be one of 'corotated', 'svk'"),
    ({"elasticity": "svk", "damping": {"beta": 1e-4}}, "runs without [scene.damping]"),
    ({"elasticity": "svk", "solver": {"jacobian": "exact"}}, 'jacobian = "rotated"'),
])
def test_elasticity_settings_are_checked(scene, message):
    """[scene] elasticity takes "corotated" or "svk"; "svk" refuses damping and another
    Jacobian than "rotated", naming the key, its value and what is allowed."""
    study = {"geometry": {"kind": "beam", "section": "square", "side": 0.02, "length": 1.0},
             "mesh": {"size": 0.02}, "scene": dict(end_time=1.0, time_step=1e-3, **scene)}
    with pytest.raises(ConfigError) as info:
        parse_config(study)
    assert "[scene] elasticity" in str(info.value) and message in str(info.value)


def test_coefficients_too_large_for_the_memory_are_refused_before_any_work():
    """The coefficients hold s² doubles (s = nf (nf + 1) / 2): 154 fields (50 modes) need
    4 copies of 1.1 GB; with less available the request is refused, naming the setting, the
    size and what to change."""
    from gcms_fenicsx.fe.svk_coefficients import check_memory
    check_memory(154, available=5e9)
    with pytest.raises(ConfigError, match=r'\[scene\] elasticity = \'svk\': its coefficients '
                       r'for 154 fields need 4.25 GiB .*s = nf \(nf \+ 1\) / 2 = 11935.*fewer '
                       r'\[modes\] count'):
        check_memory(154, available=4e9)


@pytest.mark.parametrize("nu", [0.3, -0.5])
def test_coefficient_sums_are_the_pointwise_energy_also_for_negative_poisson_ratio(nu):
    """For random gradients D at 1000 points (added in two parts) and a random P = Q Qᵀ,
    ½ pᵀAp + bᵀp + c equals
    Σ w (λ/2 (tr E)² + μ E : E) with E = ½ (Dᵀ P D − I) evaluated point by point, to 1e-12
    relative; also for ν < 0, where λ < 0 (a square root of λ would give NaN)."""
    from gcms_fenicsx.numerics.packing import packing
    from gcms_fenicsx.fe.svk_coefficients import GramSums
    rng = np.random.default_rng(5)
    nf = 7
    D, weights = rng.normal(size=(1000, nf, 3)), rng.uniform(0.1, 1.0, size=1000)
    material = Material(E=2.0e9, nu=nu, rho=1000.0)
    sums = GramSums.zeros(nf)
    sums.add(D[:600], weights[:600])      # two additions: the sums accumulate
    sums.add(D[600:], weights[600:])
    A, b, c = sums.coefficients(material)
    assert np.all(np.isfinite(A))
    Q = rng.normal(size=(nf, 3))
    P = Q @ Q.T
    p = packing(nf).svec(P)
    mu, lmbda = material.lame
    E = 0.5 * (np.einsum("wai,ab,wbj->wij", D, P, D) - np.eye(3))
    W = 0.5 * lmbda * np.trace(E, axis1=1, axis2=2) ** 2 + mu * np.einsum("wij,wij->w", E, E)
    assert 0.5 * p @ A @ p + b @ p + c == pytest.approx(weights @ W, rel=1e-12)
