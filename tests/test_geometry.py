"""Building and meshing: every beam section and crankshafts of 1, 2, 4 and 6 throws build
one solid with the named groups, OCC mass properties match the parameters, the .msh file
is written atomically and reads into dolfinx (order 1 and curved order 2), and Gmsh is
always left as it was found."""
from __future__ import annotations

import json
import math
from pathlib import Path

import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from gcms_fenicsx.fe.mesh import read_mesh
from gcms_fenicsx.config.table import ConfigError
from geometry.errors import GeometryError
from geometry import MeshInfo, MeshParams, build_msh, section_area
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from geometry.crankshaft import add_crankshaft
from geometry.meshing import gmsh_initialized, gmsh_session
from test_config_geometry import ANALYTIC_AREAS

LENGTH = 0.1


def read_dolfinx(path: Path, info: MeshInfo):
    """The mesh as the pipeline reads it, on this process alone."""
    body = read_mesh(path, info.groups, MPI.COMM_SELF)
    return body.mesh, body.facet_tags


def mesh_volume(mesh) -> float:
    return fem.assemble_scalar(fem.form(fem.Constant(mesh, 1.0) * ufl.dx(domain=mesh)))


@pytest.fixture(scope="module")
def beams(tmp_path_factory) -> dict:
    """Every section at order 1 and 2, built once: (section, order) → (geom, info, path)."""
    folder = tmp_path_factory.mktemp("beams")
    built = {}
    for section, dims, _ in ANALYTIC_AREAS:
        geom = parse_geometry({"kind": "beam", "section": section, "length": LENGTH, **dims})
        for order in (1, 2):
            path = folder / f"{section}-{order}.msh"
            info = build_msh(geom, parse_mesh({"order": order}, geom), path)
            built[section, order] = geom, info, path
    return built


CASES = [(section, order) for section, _, _ in ANALYTIC_AREAS for order in (1, 2)]
ROUND = {"circle", "tube"}


@pytest.mark.slow
@pytest.mark.parametrize("section, order", CASES)
def test_beam_section_builds_with_groups_centroid_on_axis_and_exact_volume(beams, section, order):
    geom, info, path = beams[section, order]
    assert path.is_file() and info.nodes > 0 and info.cells > 0
    assert info.groups == {"body": (3, 1), "end_x0": (2, 2), "end_xL": (2, 3)}
    mp = info.mass_properties
    assert mp["volume_m3"] == pytest.approx(section_area(geom) * LENGTH, rel=1e-9)
    assert mp["center_of_mass_m"] == pytest.approx([LENGTH / 2, 0.0, 0.0], abs=1e-12)
    (x0, *_), (x1, *_) = mp["bounding_box_m"]
    assert (x0, x1) == pytest.approx((0.0, LENGTH), abs=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("section, order", CASES)
def test_beam_mesh_reads_into_dolfinx_with_the_right_volume(beams, section, order):
    """Straight-edged sections exactly; round ones to 1e-4 at order 2 (curved cells) with
    the default size 2A/P (circle r = 10 mm: 10 mm; tube 20 x 4 mm: 4 mm) and 16 elements
    around a circle; order 1 facets them (a 16-gon has 2.6 % less area than its circle)."""
    geom, info, path = beams[section, order]
    mesh, facet_tags = read_dolfinx(path, info)
    assert mesh.geometry.cmap.degree == order
    assert mesh.topology.index_map(3).size_local == info.cells
    assert set(np.unique(facet_tags.values)) == {2, 3}
    exact = section_area(geom) * LENGTH
    rel = 1e-9 if section not in ROUND else (1e-4 if order == 2 else 2.6e-2)
    assert mesh_volume(mesh) == pytest.approx(exact, rel=rel)


def test_inertia_is_about_the_centre_of_mass_with_negative_products(tmp_path):
    """OCC's matrix of inertia is J = ∫ (|r|² I − r rᵀ) dV about the centre of mass: check a
    rectangle beam's diagonal and an L beam's product J_yz = −L·∫ y z dA (two rectangles)."""
    b, h, t = 0.04, 0.03, 0.01
    rect = parse_geometry({"kind": "beam", "section": "rectangle", "width": b, "height": h,
                           "length": LENGTH})
    angle = parse_geometry({"kind": "beam", "section": "L", "width": b, "height": h,
                            "thickness": t, "length": LENGTH})
    j_rect, j_angle = (
        np.array(build_msh(geom, parse_mesh({"size": LENGTH / 2, "order": 1}, geom),
                           tmp_path / "mesh.msh").mass_properties["inertia_m5"])
        for geom in (rect, angle))
    v = b * h * LENGTH
    assert np.diag(j_rect) == pytest.approx([v * (b**2 + h**2) / 12, v * (LENGTH**2 + h**2) / 12,
                                             v * (LENGTH**2 + b**2) / 12], rel=1e-9)
    legs = [(b * t, b / 2, t / 2), ((h - t) * t, t / 2, (h + t) / 2)]  # (area, y_c, z_c)
    area = sum(a for a, _, _ in legs)
    cy, cz = (sum(a * y for a, y, _ in legs) / area, sum(a * z for a, _, z in legs) / area)
    product = sum(a * y * z for a, y, z in legs) - area * cy * cz  # ∫ (y − c_y)(z − c_z) dA
    assert product < 0
    assert j_angle[1, 2] == pytest.approx(-LENGTH * product, rel=1e-9)
    assert j_angle[0, 1] == pytest.approx(0.0, abs=1e-15) and j_angle[1, 2] > 0


@pytest.fixture(scope="module")
def crankshafts(tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("cranks")
    built = {}
    for throws in (1, 2, 4, 6):
        geom = parse_geometry({"kind": "crankshaft", "throws": throws})
        path = folder / f"crank{throws}.msh"
        built[throws] = geom, build_msh(geom, parse_mesh({"size": 0.02}, geom), path), path
    return built


@pytest.mark.parametrize("throws", [1, 2, 4, 6])
def test_crankshaft_builds_one_solid_with_journal_and_pin_groups(throws):
    geom = parse_geometry({"kind": "crankshaft", "throws": throws})
    with gmsh_session():
        body = add_crankshaft(geom)
        assert gmsh.model.getEntities(3) == [(3, body.volume)]
        # each group is the whole cylinder: lateral area π d L
        for i in range(throws + 1):
            area = sum(gmsh.model.occ.getMass(2, f) for f in body.surfaces[f"journal_{i}"])
            assert area == pytest.approx(math.pi * geom.journal_diameter * geom.journal_length,
                                         rel=1e-9)
        for i in range(throws):
            area = sum(gmsh.model.occ.getMass(2, f) for f in body.surfaces[f"pin_{i}"])
            assert area == pytest.approx(math.pi * geom.pin_diameter * geom.pin_length, rel=1e-9)
            centre = gmsh.model.occ.getCenterOfMass(2, body.surfaces[f"pin_{i}"][0])
            angle = math.radians(geom.crank_angles_deg[i])
            assert centre[1:] == pytest.approx([geom.stroke / 2 * math.cos(angle),
                                                geom.stroke / 2 * math.sin(angle)], abs=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("throws", [1, 2, 4, 6])
def test_crankshaft_mesh_has_every_group_and_reads_into_dolfinx(crankshafts, throws):
    geom, info, path = crankshafts[throws]
    expected = ({"body", "end_x0", "end_xL"} | {f"journal_{i}" for i in range(throws + 1)}
                | {f"pin_{i}" for i in range(throws)})
    assert set(info.groups) == expected
    assert info.groups["journal_0"] == (2, 100)
    assert info.groups[f"pin_{throws - 1}"] == (2, 199 + throws)
    mesh, facet_tags = read_dolfinx(path, info)
    surface_tags = {tag for dim, tag in info.groups.values() if dim == 2}
    assert set(np.unique(facet_tags.values)) == surface_tags
    volume = info.mass_properties["volume_m3"]
    assert mesh_volume(mesh) == pytest.approx(volume, rel=5e-4)  # curved order 2, size 20 mm


@pytest.mark.slow
def test_inline_four_is_balanced_and_symmetric(crankshafts):
    """0/180/180/0 with counterweights: centre of mass on the axis."""
    geom, info, _ = crankshafts[4]
    com = info.mass_properties["center_of_mass_m"]
    assert com[1:] == pytest.approx([0.0, 0.0], abs=1e-12)


@pytest.mark.slow
def test_default_crankshaft_mesh_is_modest(tmp_path):
    geom = parse_geometry({"kind": "crankshaft"})
    info = build_msh(geom, parse_mesh(None, geom), tmp_path / "crank.msh")
    assert 10_000 < info.nodes <= 30_000


def test_refinement_makes_smaller_elements_near_the_group(tmp_path):
    geom = parse_geometry({"kind": "beam", "section": "square", "side": 0.02, "length": LENGTH})
    plain = build_msh(geom, parse_mesh({"size": 0.01, "order": 1}, geom), tmp_path / "a.msh")
    fine = build_msh(geom, parse_mesh({"size": 0.01, "order": 1, "refine": {"end_x0": 0.002}},
                                      geom), tmp_path / "b.msh")
    assert fine.nodes > 2 * plain.nodes
    mesh, _ = read_dolfinx(tmp_path / "b.msh", fine)
    x = mesh.geometry.x[:, 0]
    assert np.sum(x < 0.01) > 3 * np.sum(x > LENGTH - 0.01)


def test_mesh_info_to_json_and_summary(beams):
    _, info, _ = beams["T", 2]
    assert isinstance(info, MeshInfo)
    plain = json.loads(json.dumps(info.to_json()))
    assert plain["nodes"] == info.nodes and plain["groups"]["end_xL"] == [2, 3]
    assert set(plain["mass_properties"]) == {"volume_m3", "center_of_mass_m", "inertia_m5",
                                             "bounding_box_m"}
    assert np.shape(plain["mass_properties"]["inertia_m5"]) == (3, 3)
    summary = info.summary()
    assert f"{info.nodes} nodes" in summary and "end_x0" in summary


def test_failure_leaves_no_file_and_gmsh_finalized(tmp_path, monkeypatch):
    geom = parse_geometry({"kind": "beam", "section": "circle", "radius": 0.01, "length": LENGTH})
    mesh = parse_mesh({"order": 1}, geom)
    target = tmp_path / "mesh.msh"
    target.write_text("previous")

    def partial_write(name: str) -> None:
        Path(name).write_bytes(b"$MeshFormat\n4.1 0 8")
        raise RuntimeError("disk full")

    monkeypatch.setattr(gmsh, "write", partial_write)
    with pytest.raises(RuntimeError, match="disk full"):
        build_msh(geom, mesh, target)
    assert [p.name for p in tmp_path.iterdir()] == ["mesh.msh"]
    assert target.read_text() == "previous"
    assert not gmsh_initialized()

    monkeypatch.undo()
    monkeypatch.setattr(gmsh.model.mesh, "generate", lambda dim: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        build_msh(geom, mesh, tmp_path / "other.msh")
    assert [p.name for p in tmp_path.iterdir()] == ["mesh.msh"]
    assert not gmsh_initialized()


def test_folded_curved_cells_are_rejected_without_a_file(tmp_path):
    """A 0.5 mm tube wall meshed at 10 mm: parse_mesh refuses the size (the wall is below
    MIN_FEATURE_PER_SIZE[2] = 0.2 of it); given to build_msh anyway, curving the order-2
    edges folds cells, and the mesher's own check refuses them."""
    geom = parse_geometry({"kind": "beam", "section": "tube", "radius": 0.02,
                           "thickness": 0.0005, "length": 0.05})
    with pytest.raises(ConfigError, match=r"^\[geometry\] thickness = 0.0005: the wall"):
        parse_mesh({"size": 0.01}, geom)
    with pytest.raises(GeometryError, match=r"^\[mesh\] size = 0.01: folds \d+ curved"):
        build_msh(geom, MeshParams(size=0.01, order=2), tmp_path / "mesh.msh")
    assert list(tmp_path.iterdir()) == [] and not gmsh_initialized()
    build_msh(geom, MeshParams(size=0.01, order=1), tmp_path / "mesh.msh")


def test_someone_elses_gmsh_session_is_left_alone(tmp_path):
    geom = parse_geometry({"kind": "beam", "section": "square", "side": 0.02, "length": LENGTH})
    gmsh.initialize()
    try:
        gmsh.model.add("theirs")
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        build_msh(geom, parse_mesh({"order": 1}, geom), tmp_path / "mesh.msh")
        assert gmsh_initialized()
        assert gmsh.model.getCurrent() == "theirs"
        assert gmsh.model.getEntities(3) == [(3, 1)]
        assert gmsh.option.getNumber("Mesh.MeshSizeMax") == 0.5
        assert gmsh.option.getNumber("General.Terminal") == 1
    finally:
        gmsh.finalize()
    assert (tmp_path / "mesh.msh").is_file()


def test_no_gmsh_call_before_the_first_initialize(monkeypatch):
    """Before a process has initialized Gmsh, asking whether it is initialized must not call
    the Gmsh API: Gmsh 4.8 then reads options that were never set and may exit the process."""
    if hasattr(gmsh, "isInitialized"):
        pytest.skip("this Gmsh answers isInitialized itself")
    from geometry import meshing

    def fatal():
        raise AssertionError("gmsh.model.list called before gmsh.initialize")

    monkeypatch.setattr(meshing, "_ever_initialized", False)
    monkeypatch.setattr(gmsh.model, "list", fatal)
    assert not gmsh_initialized()
