"""estimate_mesh: cells and nodes from [geometry] and [mesh] alone, against what Gmsh makes.

The model's constants were fitted to 101 meshes (every section at two lengths and four
sizes, crankshafts of 1, 2, 3 and 4 throws, refinements; docs/geometry_checks.md), where
estimate/actual stayed within 0.63–1.70 for cells and 0.63–1.48 for nodes; the bound
asserted is the factor of 2 that covers them all. The cases here are small ones of the
same families, some at sizes the fit never saw, and connecting rods (not in the fit)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from geometry import build_msh
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from geometry.estimate import MeshEstimate, estimate_mesh

FACTOR = 2.0
FLANGED = {"width": 0.04, "height": 0.05, "flange_thickness": 0.006, "web_thickness": 0.004}


def beam(section: str, length: float, **dims) -> dict:
    return {"kind": "beam", "section": section, "length": length, **dims}


CASES = [
    (beam("square", 0.3, side=0.02), {"size": 0.006, "order": 1}),
    (beam("square", 0.5, side=0.02), {"size": 0.02, "order": 2}),  # coarser than the section
    (beam("rectangle", 1.0, width=0.05, height=0.04), {"size": 0.015, "order": 2}),
    (beam("circle", 0.4, radius=0.015), {"size": 0.004, "order": 2}),
    (beam("tube", 0.2, radius=0.02, thickness=0.003), {"order": 2}),
    (beam("box", 0.3, width=0.04, height=0.03, thickness=0.004), {"size": 0.006, "order": 1}),
    (beam("I", 0.2, **FLANGED), {"size": 0.004, "order": 2}),
    (beam("T", 0.3, **FLANGED), {"order": 1}),
    (beam("C", 0.1, **FLANGED), {"size": 0.003, "order": 2}),
    (beam("L", 0.4, width=0.04, height=0.05, thickness=0.006), {"order": 2}),
    (beam("polygon", 0.2, vertices=[[0, 0], [0.03, 0], [0.03, 0.01], [0, 0.02]]),
     {"size": 0.004, "order": 2}),
    (beam("square", 0.1, side=0.02), {"size": 0.01, "order": 2, "refine": {"end_x0": 0.0025}}),
    ({"kind": "crankshaft", "throws": 3}, {"size": 0.015, "order": 2}),
    ({"kind": "crankshaft", "throws": 1}, {"size": 0.006, "order": 1}),
    ({"kind": "crankshaft", "throws": 2, "counterweights": False, "web_thickness": 0.012},
     {"order": 2, "refine": {"pin_0": 0.004}}),
    ({"kind": "conrod"}, {"order": 2}),
    ({"kind": "conrod", "small_end_width": 0.018}, {"size": 0.005, "order": 1,
                                                    "refine": {"big_end": 0.002}}),
]


@pytest.mark.slow
@pytest.mark.parametrize("geometry, mesh", CASES, ids=[
    f"{g.get('section', g['kind'])}-{i}" for i, (g, _) in enumerate(CASES)])
def test_estimate_is_within_a_factor_of_two_of_gmsh(tmp_path, geometry, mesh):
    geom = parse_geometry(geometry)
    params = parse_mesh(mesh, geom)
    estimate = estimate_mesh(geom, params)
    info = build_msh(geom, params, tmp_path / "m.msh")
    assert 1 / FACTOR <= estimate.cells / info.cells <= FACTOR, (estimate, info.cells)
    assert 1 / FACTOR <= estimate.nodes / info.nodes <= FACTOR, (estimate, info.nodes)
    assert estimate.dofs == 3 * estimate.nodes


def test_a_runaway_size_is_seen_before_meshing():
    """[mesh] size = 1e-5 on a 1 m × 50 × 40 mm beam: V/h³ = 2e12, which Gmsh would try to
    mesh. The estimate scales as size⁻³ there: the surface term is b·P·L/h² against
    a·A·L/h³, a fraction of order P·h/A = 1e-3 at h = 1e-5 and 1e-2 at 1e-4."""
    geom = parse_geometry(beam("rectangle", 1.0, width=0.05, height=0.04))
    at = {size: estimate_mesh(geom, parse_mesh({"size": size}, geom)) for size in (1e-4, 1e-5)}
    assert isinstance(at[1e-5], MeshEstimate)
    assert at[1e-5].cells > 1e12 and at[1e-5].dofs > 1e12
    assert at[1e-5].cells / at[1e-4].cells == pytest.approx(1e3, rel=0.02)


def test_estimating_does_not_load_gmsh():
    code = ("import sys; from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh; "
            "from geometry.estimate import estimate_mesh; "
            "g = parse_geometry({'kind': 'crankshaft'}); estimate_mesh(g, parse_mesh(None, g)); "
            "assert 'gmsh' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("counterweights", [True, False])
def test_web_area_and_perimeter_match_the_kernel(counterweights):
    """The analytic outline (stadium plus counterweight ring sector) against OCC's fused face."""
    import gmsh

    from geometry.crank_layout import web_area_and_perimeter, web_outline
    from geometry.meshing import gmsh_session
    from geometry.occ_shapes import add_face

    geom = parse_geometry({"kind": "crankshaft", "counterweights": counterweights})
    with gmsh_session():
        pieces = [(2, add_face(shape)) for shape in web_outline(geom, 0.7)]
        (face,), _ = gmsh.model.occ.fuse(pieces[:1], pieces[1:])
        gmsh.model.occ.synchronize()
        area = gmsh.model.occ.getMass(*face)
        perimeter = sum(gmsh.model.occ.getMass(1, abs(c))
                        for _, c in gmsh.model.getBoundary([face], oriented=False))
    assert web_area_and_perimeter(geom) == pytest.approx((area, perimeter), rel=1e-9)
