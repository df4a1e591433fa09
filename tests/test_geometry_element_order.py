"""element_order_warning: P1 meshes whose first bending frequency is predicted more than
WARNING_THRESHOLD too high get a one-line warning recommending order = 2; the prediction is
checked against the finite elements on small meshes (Timoshenko for slender beams, a P2
mesh for a stubby block)."""
from __future__ import annotations

import pytest
from mpi4py import MPI

from gcms_fenicsx.references.beam_theory import cowper_kappa, timoshenko_hz
from gcms_fenicsx.app import pipeline
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.fe.mesh import read_mesh
from gcms_fenicsx.config.modes import ModesConfig
from geometry import build_msh
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from geometry.element_order import WARNING_THRESHOLD, element_order_warning, p1_frequency_error
from test_beam_frequencies import classify

STEEL = Material()
SIDE = 0.02


def square_beam(slenderness: float) -> dict:
    return {"kind": "beam", "section": "square", "side": SIDE, "length": slenderness * SIDE}


def first_bending_hz(tmp_path, geometry: dict, mesh: dict) -> float:
    """The lowest elastic frequency the classifier calls bending (either direction)."""
    geom = parse_geometry(geometry)
    params = parse_mesh(mesh, geom)
    path = tmp_path / f"o{params.order}.msh"
    info = build_msh(geom, params, path)
    model = pipeline.assembly_stage(read_mesh(path, info.groups, MPI.COMM_SELF).mesh, STEEL).model
    modes = pipeline.modes_stage(model, ModesConfig(count=4))
    kinds = classify(model, modes)
    return min(f for f, kind in zip(modes.elastic_frequencies_hz, kinds)
               if kind.startswith("bending"))


def timoshenko_square_hz(slenderness: float) -> float:
    area, inertia = SIDE**2, SIDE**4 / 12
    return timoshenko_hz(1, STEEL.E, STEEL.nu, cowper_kappa("rectangle", STEEL.nu), STEEL.rho,
                         area, inertia, slenderness * SIDE)


def test_slender_p1_beam_warns_and_the_p2_one_does_not(tmp_path):
    """L/h = 100 at the default size (2A/P = h/2): P1 is measured 40 % stiff against
    Timoshenko; the warning says so in one line and recommends order = 2."""
    geometry = square_beam(100)
    geom = parse_geometry(geometry)
    measured = first_bending_hz(tmp_path, geometry, {"order": 1}) / timoshenko_square_hz(100) - 1
    assert measured > WARNING_THRESHOLD
    warning = element_order_warning(geom, parse_mesh({"order": 1}, geom))
    assert warning is not None and "\n" not in warning
    assert warning.startswith("[mesh] order = 1:") and "use order = 2" in warning
    assert element_order_warning(geom, parse_mesh({"order": 2}, geom)) is None
    assert element_order_warning(geom, parse_mesh(None, geom)) is None  # default order 2


@pytest.mark.slow
def test_prediction_matches_the_finite_elements_where_it_decides(tmp_path):
    """At s/h = 0.25 (near the 5 % threshold's s/h = 0.18) the law was fitted within
    0.86–1.09 of the measurements; a fresh P1 mesh of L/h = 20 is asked to agree within
    0.8–1.25 (the fit's spread plus the mesh-to-mesh scatter of ±5 % seen there)."""
    geometry, mesh = square_beam(20), {"size": 0.25 * SIDE, "order": 1}
    geom = parse_geometry(geometry)
    measured = first_bending_hz(tmp_path, geometry, mesh) / timoshenko_square_hz(20) - 1
    predicted = p1_frequency_error(geom, parse_mesh(mesh, geom))
    assert 0.8 <= predicted / measured <= 1.25
    assert element_order_warning(geom, parse_mesh(mesh, geom)) is not None


@pytest.mark.slow
def test_a_stubby_p1_block_meshed_finely_does_not_warn(tmp_path):
    """L/h = 2 at h/8: the bending pair of P1 is measured within 5 % of a P2 mesh at h/4
    (P2 at h/2 was within 1e-4 of the finest mesh on the bench beam), and nothing is said.
    The same block at its default size (Gmsh's cap makes s = h/4) is measured 8 % off and
    is warned about: what matters is the elements across the section, not the slenderness."""
    geometry = square_beam(2)
    geom = parse_geometry(geometry)
    reference = first_bending_hz(tmp_path, geometry, {"size": SIDE / 4, "order": 2})
    fine = {"size": SIDE / 8, "order": 1}
    assert first_bending_hz(tmp_path, geometry, fine) / reference - 1 < WARNING_THRESHOLD
    assert element_order_warning(geom, parse_mesh(fine, geom)) is None
    default = {"order": 1}
    assert first_bending_hz(tmp_path, geometry, default) / reference - 1 > WARNING_THRESHOLD
    assert element_order_warning(geom, parse_mesh(default, geom)) is not None


@pytest.mark.parametrize("size, warns", [(None, True), (0.003, False)])
def test_crankshaft_warning_follows_web_thickness_over_size(size, warns):
    """The default inline-4's P1 first frequency was measured 25 % high at s/t = 0.56 and
    4 % at s/t = 0.17 (docs/element_order.md)."""
    geom = parse_geometry({"kind": "crankshaft"})
    mesh = parse_mesh({"order": 1, **({"size": size} if size else {})}, geom)
    warning = element_order_warning(geom, mesh)
    assert (warning is not None) == warns
    if warns:
        assert "web_thickness = 0.018 m" in warning
