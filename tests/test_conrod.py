"""The connecting rod (``[geometry] kind = "conrod"``): its volume against the parameters',
its two bore groups on their cylinders, one-line refusals of lengths that do not fit, and
its free-free modes through ``gcms reduce``."""
from __future__ import annotations

import json
import math

import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from conftest import gcms_reduce
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from gcms_fenicsx.files.modes_file import read_modes
from geometry import build_msh, estimate_mesh
from geometry.__main__ import params_from_json, params_to_json
from geometry.element_order import element_order_warning
from geometry.meshing import gmsh_session
from geometry.params import ConrodParams, model_unit
from test_config_geometry import assert_rejected
from test_geometry import mesh_volume, read_dolfinx

#: The default rod's lengths, spelled out here so the analytic volume does not read the code.
L, D_BIG, BORE_BIG, W_BIG = 0.145, 0.068, 0.048, 0.022
D_SMALL, BORE_SMALL, W_SMALL = 0.032, 0.022, 0.020
H, W, TF, TW = 0.024, 0.018, 0.005, 0.006
E, NU, RHO = 210e9, 0.3, 7850.0
#: Gmsh places a surface node on the CAD to its own round-off: measured ~1e-16 m here.
ON_CYLINDER = 1e-9


def conrod(**keys) -> dict:
    return {"kind": "conrod", **keys}


def analytic_volume() -> float:
    """Two annular eyes plus the I-section shank where it lies outside both eyes' discs:
    a strip of the section at height y reaches from x = √(R_big² − y²) to L − √(R_small² −
    y²), so each of its three rectangles (two flanges, the web) adds its width times
    ∫ (L − √(R_big² − y²) − √(R_small² − y²)) dy over its heights."""
    def arc(y: float, r: float) -> float:  # ∫₀^y √(r² − s²) ds
        return 0.5 * (y * math.sqrt(r * r - y * y) + r * r * math.asin(y / r))

    def strip(y0: float, y1: float) -> float:
        return L * (y1 - y0) - sum(arc(y1, r) - arc(y0, r) for r in (D_BIG / 2, D_SMALL / 2))

    eyes = (math.pi / 4 * ((D_BIG**2 - BORE_BIG**2) * W_BIG
                           + (D_SMALL**2 - BORE_SMALL**2) * W_SMALL))
    shank = (W * (strip(H / 2 - TF, H / 2) + strip(-H / 2, -H / 2 + TF))
             + TW * strip(-H / 2 + TF, H / 2 - TF))
    return eyes + shank


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The default rod at its default mesh (size 3 mm, order 2): (geom, mesh, info, path)."""
    geom = parse_geometry(conrod())
    mesh = parse_mesh(None, geom)
    path = tmp_path_factory.mktemp("conrod") / "conrod.msh"
    return geom, mesh, build_msh(geom, mesh, path), path


def test_defaults_fit_the_default_crankshaft():
    geom = parse_geometry(conrod())
    assert geom == ConrodParams() and geom.kind == "conrod"
    assert (geom.length, geom.big_end_bore, geom.shank_height) == (L, BORE_BIG, H)
    crank = parse_geometry({"kind": "crankshaft"})
    assert geom.big_end_bore == crank.pin_diameter and geom.big_end_width < crank.pin_length
    assert parse_mesh(None, geom).size == pytest.approx(0.6 * min(TF, TW))
    assert params_from_json(json.loads(json.dumps(params_to_json(geom, parse_mesh(
        None, geom))))) == (geom, parse_mesh(None, geom))


def test_p1_warning_reads_the_shank():
    """P1 at the default 3 mm across the shank's bending depth √(12 I_y/A) = 15 mm: 6 %."""
    geom = parse_geometry(conrod())
    assert "the shank's bending depth" in element_order_warning(geom, parse_mesh({"order": 1},
                                                                                  geom))
    assert element_order_warning(geom, parse_mesh(None, geom)) is None


def test_volume_matches_the_parameters(built):
    """OCC's volume is the analytic one to round-off (1e-9). The curved P2 mesh's is within
    3e-5: straight walls are exact, and a round surface meshed at ≤ 1/16 of its circle with
    its edge midpoints on the CAD is within ~3e-5 (``params.ELEMENTS_PER_CIRCLE``); measured
    4e-7."""
    geom, _, info, path = built
    exact = analytic_volume()
    mp = info.mass_properties
    assert mp["volume_m3"] == pytest.approx(exact, rel=1e-9)
    assert mp["center_of_mass_m"][1:] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert np.allclose(mp["bounding_box_m"], [[-D_BIG / 2, -D_BIG / 2, -W_BIG / 2],
                                              [L + D_SMALL / 2, D_BIG / 2, W_BIG / 2]], atol=1e-6)
    mesh, _ = read_dolfinx(path, info)
    assert mesh_volume(mesh) == pytest.approx(exact, rel=3e-5)
    estimate = estimate_mesh(geom, parse_mesh(None, geom))
    assert 0.5 <= estimate.nodes / info.nodes <= 2.0 and 0.5 <= estimate.cells / info.cells <= 2.0


def test_bore_groups_lie_on_the_bores(built):
    """Every node of ``big_end`` and ``small_end`` (vertices and edge midpoints) is on its
    bore's cylinder to 1e-9 of the model unit and within the eye's width, and the groups'
    areas are the whole bores' π d w (curved P2 facets: 3e-5)."""
    geom, _, info, path = built
    assert info.groups == {"body": (3, 1), "big_end": (2, 300), "small_end": (2, 301)}
    unit = model_unit(L + D_BIG / 2 + D_SMALL / 2)
    with gmsh_session():
        gmsh.merge(str(path))
        for tag, centre, bore, width in ((300, 0.0, BORE_BIG, W_BIG), (301, L, BORE_SMALL, W_SMALL)):
            _, xyz = gmsh.model.mesh.getNodesForPhysicalGroup(2, tag)
            x = xyz.reshape(-1, 3)
            radius = np.hypot(x[:, 0] - centre, x[:, 1])
            assert np.abs(radius - bore / 2).max() <= ON_CYLINDER * unit
            assert np.abs(x[:, 2]).max() == pytest.approx(width / 2, abs=1e-12)
            assert len(x) > 100
    mesh, facet_tags = read_dolfinx(path, info)
    assert set(np.unique(facet_tags.values)) == {300, 301}
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    one = fem.Constant(mesh, 1.0)
    for tag, bore, width in ((300, BORE_BIG, W_BIG), (301, BORE_SMALL, W_SMALL)):
        area = fem.assemble_scalar(fem.form(one * ds(tag)))
        assert area == pytest.approx(math.pi * bore * width, rel=3e-5)
    assert MPI.COMM_WORLD.size == 1


@pytest.mark.parametrize("keys, key, fragment", [
    (conrod(length=-0.1), "[geometry] length", "> 0"),
    (conrod(big_end_bore=0.07), "[geometry] big_end_bore",
     "must be < big_end_diameter = 0.068 (its default): the big eye needs a wall"),
    (conrod(small_end_diameter=0.02), "[geometry] small_end_diameter",
     "must be > small_end_bore = 0.022 (its default)"),
    (conrod(shank_height=0.04), "[geometry] shank_height",
     "must be < small_end_diameter = 0.032 (its default)"),
    (conrod(shank_width=0.021), "[geometry] shank_width", "must be <= small_end_width = 0.02"),
    (conrod(web_thickness=0.018), "[geometry] web_thickness", "must be < shank_width = 0.018"),
    (conrod(flange_thickness=0.012), "[geometry] flange_thickness", "shank_height/2 = 0.012"),
    (conrod(length=0.05), "[geometry] length",
     "must be > (big_end_diameter + small_end_diameter)/2 = 0.05"),
    (conrod(big_end_diameter=0.26, shank_height=0.03, small_end_diameter=0.04),
     "[geometry] big_end_diameter", "must be < 2·length − small_end_diameter = 0.25"),
    (conrod(lenght=0.15), "[geometry] lenght", "unknown key"),
    (conrod(web_thickness=1e-7), "[geometry] web_thickness", "the geometry kernel merges"),
    (conrod(small_end_width=0.0181), "[geometry] shank_width", "the step from the shank"),
])
def test_lengths_that_do_not_fit_are_one_line_errors(keys, key, fragment, tmp_path):
    err = assert_rejected(keys, None, key, tmp_path, fragment)
    assert "\n" not in str(err)


def test_a_feature_below_the_mesh_size_is_refused(tmp_path):
    assert_rejected(conrod(), {"size": 0.03}, "[geometry] shank_width", tmp_path,
                    "must be >= 0.2 × [mesh] size 0.03 m")


MODES_STUDY = """
[geometry]
kind = "conrod"

[mesh]
size = 0.004

[material]
E = 210e9
nu = 0.3
rho = 7850.0

[modes]
count = 6
"""


def euler_bernoulli_free_free_hz(second_moment: float, area: float, length: float) -> float:
    """First free-free bending frequency of a uniform Euler–Bernoulli beam: (β L)² = 22.373."""
    return 4.730041**2 / (2 * math.pi * length**2) * math.sqrt(E * second_moment / (RHO * area))


def test_free_free_modes_of_the_default_rod(tmp_path):
    """Six rigid modes at zero (|λ| < 1e-8 λ_7; deflated, measured 1e-12); the first elastic
    mode bends the shank out of the rod's plane (z, the section's weak axis) and the first
    mode in the plane (no z motion) comes later. Against an Euler–Bernoulli free-free beam
    of the shank's section over the centre distance, only a loose bound: the eyes carry
    two thirds of the mass, so the rod's in-plane bending is far lower (measured 0.35 of
    it at the default mesh); it must lie between 0.2 and 1 of it."""
    out = gcms_reduce(MODES_STUDY, tmp_path / "study.toml", tmp_path)
    basis = read_modes(out / "modes.h5").basis
    eigenvalues, rigid = basis.eigenvalues, basis.rigid_count
    assert rigid == 6 and basis.mode_count == 6
    assert np.abs(eigenvalues[:rigid]).max() < 1e-8 * eigenvalues[rigid]
    frequencies = np.sqrt(eigenvalues[rigid:]) / (2 * math.pi)
    assert np.all(np.diff(frequencies) >= 0) and frequencies[0] > 0
    amplitude = np.array([np.sqrt((basis.fields[:, 4 + 3 * m:7 + 3 * m] ** 2).mean(axis=0))
                          for m in range(basis.mode_count)])  # rms of x, y, z per mode
    assert np.argmax(amplitude[0]) == 2
    in_plane = [m for m in range(basis.mode_count) if amplitude[m, 2] < 0.05 * amplitude[m].max()]
    assert in_plane and in_plane[0] > 0
    area = 2 * W * TF + (H - 2 * TF) * TW
    i_z = 2 * (W * TF**3 / 12 + W * TF * ((H - TF) / 2) ** 2) + TW * (H - 2 * TF) ** 3 / 12
    ratio = frequencies[in_plane[0]] / euler_bernoulli_free_free_hz(i_z, area, L)
    assert 0.2 < ratio < 1.0, (frequencies, ratio)
