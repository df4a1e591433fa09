"""Degenerate geometry ends in one ConfigError before Gmsh runs: features below the kernel's
resolution (KERNEL_RESOLUTION of the largest extent) or far below the mesh size
(MIN_FEATURE_PER_SIZE[order]); what the kernel still refuses becomes a ConfigError naming
the geometry's keys and the kernel's message."""
from __future__ import annotations

import math

import gmsh
import numpy as np
import pytest

from gcms_fenicsx.config.table import ConfigError
from geometry.errors import GeometryError
from geometry import build_msh
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from geometry.features import KERNEL_RESOLUTION, MIN_FEATURE_PER_SIZE, features, rounded_down
from geometry.meshing import TETRAHEDRON, gmsh_initialized, gmsh_session

BEAM = {"kind": "beam", "length": 0.1}
FLANGED = {"width": 0.04, "height": 0.05, "flange_thickness": 0.006, "web_thickness": 0.004}
SQUARE = [[0, 0], [0.02, 0], [0.02, 0.02], [0, 0.02]]


def beam(section: str, **dims) -> dict:
    return {**BEAM, "section": section, **dims}


def spike(width: float) -> list[list[float]]:
    """A 20 mm square with a 20 mm spike of base ``width`` on its top edge."""
    return [[0, 0], [0.02, 0], [0.02, 0.02], [0.01 + width / 2, 0.02], [0.01, 0.04],
            [0.01 - width / 2, 0.02], [0, 0.02]]


def rejected(geometry: dict, mesh: dict | None = None) -> ConfigError:
    """The ConfigError that parsing the two tables raises (what every command does first)."""
    with pytest.raises(ConfigError) as caught:
        parse_mesh(mesh, parse_geometry(geometry))
    assert "\n" not in str(caught.value)
    return caught.value


# Each of these built past HEAD's checks and ended inside Gmsh/OCC: "PLC Error", "Line Loop
# is not closed", "Could not create line", "BRepSweep_Prism", "Fuse operation cannot be
# performed", "Invalid boundary mesh"; the box meshed a 1e-8 m wall into flat cells, and
# the tube's default size (2A/P ~ 1e-9 m) never finished.
KERNEL_CASES = [
    (beam("tube", radius=0.02, thickness=1e-9), "[geometry] thickness", "the wall", 0.1),
    (beam("box", width=0.04, height=0.03, thickness=1e-8), "[geometry] thickness", "the wall",
     0.1),
    (beam("I", **{**FLANGED, "web_thickness": 1e-8}), "[geometry] web_thickness", "the web", 0.1),
    (beam("I", **{**FLANGED, "flange_thickness": 1e-8}), "[geometry] flange_thickness",
     "a flange", 0.1),
    (beam("L", width=0.04, height=0.05, thickness=1e-8), "[geometry] thickness", "a leg", 0.1),
    (beam("polygon", vertices=[[0, 0], [0.02, 0], [0.01, 1e-8]]), "[geometry] vertices",
     "2·area/perimeter", 0.1),
    (beam("polygon", vertices=spike(2e-9)), "[geometry] vertices", "narrowest spike", 0.1),
    ({**beam("square", side=0.02), "length": 1e-8}, "[geometry] length", "the length", 0.02),
    ({"kind": "crankshaft", "web_thickness": 1e-7}, "[geometry] web_thickness", "a web", None),
    ({"kind": "crankshaft", "journal_length": 1e-7}, "[geometry] journal_length",
     "a main journal", None),
    ({"kind": "crankshaft", "pin_length": 1e-7}, "[geometry] pin_length", "a crank pin", None),
    ({"kind": "crankshaft", "web_width": 0.055 + 2e-8}, "[geometry] web_width", "rim", None),
]


@pytest.mark.parametrize("geometry, key, what, extent", KERNEL_CASES)
def test_feature_below_the_kernel_resolution(geometry, key, what, extent):
    err = rejected(geometry)
    assert err.key == key and what in err.allowed
    given = geometry[key.split()[1]]
    assert err.value == (tuple(map(tuple, given)) if key.endswith("vertices") else given)
    assert f"{KERNEL_RESOLUTION:g} × the body's largest extent" in err.allowed
    if extent is not None:
        assert f"extent {extent:g} m = {KERNEL_RESOLUTION * extent:.3g} m" in err.allowed


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("geometry, key, feature, size", [
    (beam("tube", radius=0.02, thickness=0.0005), "[geometry] thickness", 0.0005, 0.01),
    (beam("box", width=0.04, height=0.03, thickness=0.0002), "[geometry] thickness", 0.0002,
     0.005),
    (beam("polygon", vertices=spike(1e-4)), "[geometry] vertices", None, 0.005),
    (beam("C", **{**FLANGED, "web_thickness": 0.0399}), "[geometry] web_thickness", 1e-4, 0.005),
    ({"kind": "crankshaft", "web_thickness": 0.001}, "[geometry] web_thickness", 0.001, 0.0108),
    ({"kind": "crankshaft", "pin_length": 0.0005}, "[geometry] pin_length", 0.0005, 0.0108),
])
def test_feature_far_below_the_mesh_size(geometry, key, feature, size, order):
    """Sizes well inside the kernel's resolution, but below MIN_FEATURE_PER_SIZE of h: the
    message names the key, the feature, the mesh size compared with and the largest size
    that would do."""
    ratio = MIN_FEATURE_PER_SIZE[order]
    err = rejected(geometry, {"size": size, "order": order})
    assert err.key == key
    assert f"{ratio:g} × [mesh] size {size:g} m = {ratio * size:.3g} m at order {order}" in str(err)
    smallest = min(f.size for f in features(parse_geometry(geometry)))
    assert smallest < ratio * size
    suggested = rounded_down(smallest / ratio)   # rounded down: the size suggested passes
    assert suggested <= smallest / ratio
    assert f"smaller [mesh] size (<= {suggested:g} m)" in str(err)
    if feature is not None:
        assert smallest == pytest.approx(feature, rel=1e-9)


def test_default_crankshaft_size_follows_a_thin_web_and_a_short_journal_is_named():
    """The default size is 0.6·web_thickness, so a thin web alone passes; a journal far
    shorter than that size does not."""
    crank = parse_geometry({"kind": "crankshaft", "web_thickness": 0.004})
    assert parse_mesh(None, crank).size == pytest.approx(0.0024)
    err = rejected({"kind": "crankshaft", "journal_length": 0.0002})
    assert err.key == "[geometry] journal_length" and err.value == 0.0002


def folded_or_flat_cells(order: int) -> int:
    """Cells of the current Gmsh mesh whose Jacobian is <= 0 at a Gauss point."""
    kind = TETRAHEDRON[order]
    points, _ = gmsh.model.mesh.getIntegrationPoints(kind, "Gauss4")
    _, det, _ = gmsh.model.mesh.getJacobians(kind, points)
    return int(np.sum(det.reshape(-1, len(points) // 3).min(axis=1) <= 0.0))


@pytest.mark.parametrize("order", [1, 2])
def test_a_tube_wall_at_the_allowed_ratio_meshes_into_valid_cells(tmp_path, order):
    """The boundary of the check is on the safe side: a 20 mm tube whose wall is exactly
    MIN_FEATURE_PER_SIZE[order] of h = 5 mm meshes, every cell with a positive Jacobian
    (the measured failures were at 0.03 h for order 1 and 0.1 h for order 2)."""
    size = 0.005
    geom = parse_geometry(beam("tube", radius=0.02, thickness=MIN_FEATURE_PER_SIZE[order] * size))
    build_msh(geom, parse_mesh({"size": size, "order": order}, geom), tmp_path / "m.msh")
    with gmsh_session():
        gmsh.merge(str(tmp_path / "m.msh"))
        assert folded_or_flat_cells(order) == 0


@pytest.mark.parametrize("geometry, patched, message, key", [
    (beam("I", **FLANGED), "gmsh.model.mesh.generate",
     "PLC Error:  A segment and a facet intersect at point", "[geometry] section = 'I'"),
    ({"kind": "crankshaft", "throws": 1}, "gmsh.model.occ.fuse",
     "Fuse operation cannot be performed", "[geometry] kind = 'crankshaft'"),
])
def test_kernel_failure_is_a_config_error_naming_the_keys(tmp_path, monkeypatch, geometry,
                                                           patched, message, key):
    """Gmsh raises a bare Exception with the kernel's last error; build_msh reports it in
    one line (a GeometryError, the configuration's ConfigError in a command) with the
    geometry's keys and the mesh size, writes nothing, finalizes Gmsh."""
    geom = parse_geometry(geometry)
    mesh = parse_mesh({"size": 0.02}, geom)

    def fail(*args, **kwargs):
        raise Exception(message)

    monkeypatch.setattr(patched, fail)
    with pytest.raises(GeometryError) as caught:
        build_msh(geom, mesh, tmp_path / "m.msh")
    text = str(caught.value)
    assert text.startswith(key + ": the geometry kernel could not build or mesh")
    assert " ".join(message.split()) in text and "[mesh] size = 0.02" in text
    expected_keys = (["section", *FLANGED, "length"] if geom.kind == "beam"
                     else ["throws", "stroke", "web_thickness", "journal_length"])
    assert all(k in text for k in expected_keys)
    assert list(tmp_path.iterdir()) == [] and not gmsh_initialized()


def test_a_fusion_into_two_solids_is_a_config_error(tmp_path, monkeypatch):
    """The crankshaft builder's own check (the fusion must give one solid) is a kernel
    failure too; before, it was a RuntimeError with a traceback."""
    geom = parse_geometry({"kind": "crankshaft", "throws": 1})
    fuse = gmsh.model.occ.fuse
    monkeypatch.setattr("gmsh.model.occ.fuse",
                        lambda a, b, **kw: fuse(a, b, **kw) if len(b) < 4 else (a + b, []))
    with pytest.raises(GeometryError, match=r"^\[geometry\] kind = 'crankshaft': .*fusion gave"):
        build_msh(geom, parse_mesh({"size": 0.02}, geom), tmp_path / "m.msh")


def test_polygon_feature_measures():
    """Shortest edge and narrowest gap (a vertex's distance to an edge not ending at it:
    the side of a square, a triangle's smallest altitude, a spike's base) on shapes whose
    answers are known."""
    from geometry.polygon import narrowest_gap, shortest_edge
    square = tuple(map(tuple, SQUARE))
    assert shortest_edge(square) == pytest.approx(0.02)
    assert narrowest_gap(square) == pytest.approx(0.02)
    assert narrowest_gap(((0, 0), (1, 0), (0, 1))) == pytest.approx(2 * 0.5 / 2**0.5)
    width, height = 1e-4, 0.02  # the spike's base vertex to its far side: 2·area/side
    assert narrowest_gap(tuple(map(tuple, spike(width)))) == pytest.approx(
        width * height / math.hypot(height, width / 2), rel=1e-9)


@pytest.mark.parametrize("section, dims, depth", [
    ("rectangle", {"width": 0.05, "height": 0.02}, 0.02),
    ("circle", {"radius": 0.01}, 3**0.5 * 0.01),  # √(12 · πr⁴/4 / πr²)
    ("tube", {"radius": 0.02, "thickness": 0.004}, (12 * (0.02**2 + 0.016**2) / 4) ** 0.5),
    # a 70.7 × 14.1 mm rectangle turned by 45°: the depth is its width, not its box
    ("polygon", {"vertices": [[0, 0], [0.05, 0.05], [0.04, 0.06], [-0.01, 0.01]]}, 0.01 * 2**0.5),
])
def test_bending_depth_is_the_weakest_radius_of_gyration(section, dims, depth):
    profile = parse_geometry(beam(section, **dims)).profile()
    assert profile.bending_depth == pytest.approx(depth, rel=1e-12)
