"""Stress recovery in the body's own law (``dynamics.run.stress_recovery``), NumPy only:
objectivity of both laws, the invariants on stresses whose values are known, and the stress
modes' sparse product against a dense one."""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.dynamics.run.stress_recovery import (StressRecovery, StressSetup, principal,
                                                       von_mises)
from gcms_fenicsx.files.stress_nodes import SparseRows, StressNodes
from gcms_fenicsx.numerics.rotation import rotation_about

#: The Lamé parameters (μ, λ) of the test beam's steel (E = 210 GPa, ν = 0.3).
MU, LAMBDA = 210e9 / 2.6, 210e9 * 0.3 / (1.3 * 0.4)


def _recovery(body, law: str, nodes: int = 40, seed: int = 1) -> StressRecovery:
    """A recovery at ``nodes`` nodes whose gradient operator B is random: objectivity holds
    for any D = B F, so no mesh is needed."""
    return StressRecovery(StressSetup(_nodes(body, nodes, seed), (MU, LAMBDA),
                                      StressOutputs(("all",))), body, law)


def _nodes(body, nodes: int, seed: int, group: str = "all") -> StressNodes:
    """Stress nodes of ``body``, all in ``group``, with a random gradient operator (12
    nonzeros a row)."""
    rng = np.random.default_rng(seed)
    N = len(body.nodes_m)
    rows = rng.choice(N, nodes, replace=False)
    dense = np.zeros((3 * nodes, N))
    for r in range(3 * nodes):
        dense[r, rng.choice(N, 12, replace=False)] = rng.normal(size=12)
    indptr = np.concatenate([[0], np.cumsum((dense != 0).sum(axis=1))])
    indices = np.concatenate([np.flatnonzero(row) for row in dense])
    B = SparseRows(indptr, indices, dense[dense != 0], dense.shape)
    return StressNodes(key="", node_count=N, gradient_nodes=np.sort(rows),
                       requested=np.arange(nodes), groups={group: np.arange(nodes)},
                       gradient=B, cells=np.zeros((0, 10), dtype=np.int64))


def test_sparse_rows_product_equals_the_dense_one(beam6_body):
    """SparseRows.dot, a block of rows at a time, against the dense product (round-off)."""
    rng = np.random.default_rng(0)
    recovery = _recovery(beam6_body, "corotated", nodes=300)
    B = recovery.setup.nodes.gradient
    dense = np.zeros(B.shape)
    for r in range(B.shape[0]):
        dense[r, B.indices[B.indptr[r]:B.indptr[r + 1]]] = B.data[B.indptr[r]:B.indptr[r + 1]]
    X = rng.normal(size=(B.shape[1], 7))
    np.testing.assert_allclose(B.dot(X), dense @ X, rtol=0, atol=1e-12 * np.abs(dense @ X).max())


@pytest.mark.parametrize("law", ["corotated", "svk"])
def test_a_rigid_rotation_leaves_the_body_frame_stress_and_turns_the_global_one(beam6_body,
                                                                               law):
    """A deformed state (the undeformed one plus 1e-3 of a random q) turned rigidly by a large
    rotation Rot (Q → Q Rotᵀ: x → Rot x): the co-rotated law's σ_loc, and the invariants,
    are unchanged to round-off, and σ → Rot σ Rotᵀ (SVK: its Cauchy stress likewise)."""
    body = beam6_body
    rng = np.random.default_rng(3)
    recovery = _recovery(body, law)
    Q = (body.q0 + 1e-3 * rng.normal(size=body.dofs) * np.abs(body.q0).max()).reshape(-1, 3)
    turn = rotation_about(np.array([1.0, 2.0, -0.5]) / np.sqrt(5.25), 1.9)
    invariant, sigma = recovery.stresses(recovery.recorded, Q[None])
    invariant_t, sigma_t = recovery.stresses(recovery.recorded, (Q @ turn.T)[None])
    scale = np.abs(sigma).max()
    assert scale > 1e6                      # a state that is stressed (Pa)
    turned = turn @ sigma @ turn.T
    np.testing.assert_allclose(sigma_t, turned, rtol=0, atol=1e-9 * scale)
    if law == "corotated":
        np.testing.assert_allclose(invariant_t, invariant, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(von_mises(sigma_t), von_mises(sigma), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(principal(sigma_t), principal(sigma), rtol=0, atol=1e-9 * scale)


def test_invariants_of_known_stresses():
    """Uniaxial σ: von Mises |σ|; pure shear τ: √3 τ; hydrostatic p: 0; principal stresses of
    a diagonal tensor turned by any rotation are its diagonal, sorted."""
    sigma = np.zeros((3, 3, 3))
    sigma[0, 0, 0] = -2.5e8
    sigma[1, 0, 1] = sigma[1, 1, 0] = 1e8
    sigma[2] = 7e7 * np.eye(3)
    np.testing.assert_allclose(von_mises(sigma), [2.5e8, np.sqrt(3) * 1e8, 0.0], atol=1e-6)
    turn = rotation_about(np.array([0.0, 0.6, 0.8]), 0.7)
    diagonal = np.diag([3e7, -1e8, 5e7])
    np.testing.assert_allclose(principal(turn @ diagonal @ turn.T), [5e7, 3e7, -1e8],
                               rtol=1e-12)


def test_peaks_and_group_series_of_a_block(beam6_body):
    """The peak over rows is each node's largest von Mises stress with its row's time, and a
    group's series is its largest node's, with that node's principal stresses."""
    body = beam6_body
    rng = np.random.default_rng(5)
    recovery = _recovery(body, "corotated")
    rows = np.stack([(body.q0 + a * rng.normal(size=body.dofs) * np.abs(body.q0).max())
                     .reshape(-1, 3) for a in (1e-4, 3e-4, 2e-4)])
    times = np.array([0.1, 0.2, 0.3])
    block = recovery.block(times, rows)
    vm = block["stress/von_mises"].astype(float)
    invariant, _ = recovery.stresses(recovery.recorded, rows)
    np.testing.assert_allclose(vm, von_mises(invariant), rtol=1e-6)      # float32
    np.testing.assert_allclose(recovery.peak, von_mises(invariant).max(axis=0), rtol=1e-12)
    np.testing.assert_array_equal(recovery.peak_time, times[von_mises(invariant).argmax(axis=0)])
    np.testing.assert_allclose(block["stress/groups/all/von_mises"],
                               von_mises(invariant).max(axis=1), rtol=1e-12)
    top = von_mises(invariant).argmax(axis=1)
    np.testing.assert_allclose(block["stress/groups/all/principal"],
                               principal(invariant[np.arange(3), top]), rtol=1e-12)


def test_a_rotor_run_recovers_the_stresses_of_its_full_basis_coordinates(beam6_model,
                                                                        beam6_body):
    """In the rotor basis the recorder lifts p to the full basis's q = B p before the
    recovery: the recorded peaks and series are those of the recorded coordinates/q (the
    full basis's), recovered anew (float32 series: 1e-6)."""
    from gcms_fenicsx.config.scene import parse_scene
    from gcms_fenicsx.dynamics.run.simulate import simulate

    pin = {"name": "pin", "type": "revolute", "group": "end_x0", "axis": [0.0, 0.0, 1.0]}
    scene = parse_scene({"end_time": 0.02, "time_step": 1e-3, "gravity": [0.0, -9.81, 0.0],
                         "joints": [pin], "outputs": {"coordinates": True,
                                                      "stress_groups": ["end_x0"]}})
    traj, summary = simulate(beam6_model, scene, basis="rotor",
                             stress_nodes=_nodes(beam6_body, 30, 7, "end_x0"))
    assert summary["basis"] == "rotor" and summary["stress"]["law"] == "corotated"
    again = _recovery(beam6_body, "corotated", nodes=30, seed=7)
    q = traj.coordinates["q"]
    invariant, _ = again.stresses(again.recorded, q.reshape(len(q), -1, 3))
    expected = von_mises(invariant)
    np.testing.assert_allclose(traj.stress["stress/von_mises"], expected, rtol=1e-6)
    np.testing.assert_allclose(traj.stress["stress/peak_von_mises"], expected.max(axis=0),
                               rtol=1e-12)
    assert summary["stress"]["peak_von_mises_pa"] == pytest.approx(expected.max(), rel=1e-12)


def test_stress_modes_of_other_groups_or_another_mesh_are_refused(beam6_model, beam6_body):
    """Stress modes that are not the scene's — other groups, no cells for stress_times, a
    mesh of another node count — are refused in one line naming what differs."""
    from gcms_fenicsx.config.scene import SceneError, parse_scene
    from gcms_fenicsx.dynamics.run.simulate import simulate

    def scene(outputs: dict):
        return parse_scene({"end_time": 0.002, "time_step": 1e-3, "outputs": outputs})

    nodes = _nodes(beam6_body, 30, 7, "end_x0")
    with pytest.raises(SceneError, match=r"hold the groups \['end_x0'\], the scene asks for "
                       r"\['surface'\]"):
        simulate(beam6_model, scene({"stress_groups": "surface"}), stress_nodes=nodes)
    with pytest.raises(SceneError, match="without the whole body"):
        simulate(beam6_model, scene({"stress_groups": ["end_x0"], "stress_times": [0.001]}),
                 stress_nodes=nodes)
    other = StressNodes(key="", node_count=nodes.node_count + 1,
                        gradient_nodes=nodes.gradient_nodes, requested=nodes.requested,
                        groups=nodes.groups, gradient=nodes.gradient, cells=nodes.cells)
    with pytest.raises(SceneError, match="another body"):
        simulate(beam6_model, scene({"stress_groups": ["end_x0"]}), stress_nodes=other)


@pytest.mark.parametrize("width, topology", [(10, "Tetrahedron_10"), (4, "Tetrahedron")])
def test_stress_xdmf_names_the_cells_it_holds(tmp_path, width, topology):
    """stress.xdmf's topology is that of the cells written (P2: Tetrahedron_10, P1:
    Tetrahedron), and every DataItem is a dataset of stress.h5 of the stated dimensions."""
    import xml.etree.ElementTree as ElementTree

    import h5py

    from gcms_fenicsx.files.stress_fields import write_stress_fields

    rng = np.random.default_rng(2)
    nodes, cells = rng.normal(size=(12, 3)), rng.integers(0, 12, size=(5, width))
    fields = [(t, rng.normal(size=(12, 3)), rng.random(12), rng.normal(size=(12, 6)))
              for t in (0.1, 0.2)]
    write_stress_fields(tmp_path, nodes, cells, fields)
    root = ElementTree.parse(tmp_path / "stress.xdmf").getroot()
    assert {t.get("TopologyType") for t in root.iter("Topology")} == {topology}
    with h5py.File(tmp_path / "stress.h5") as f:
        for item in root.iter("DataItem"):
            name = item.text.split(":", 1)[1]
            assert f[name].shape == tuple(int(d) for d in item.get("Dimensions").split())
