"""Units and scale: a body given in other units (every length and mesh size times 1e-3 or
1e3) gets the same mesh, scaled: same node and cell counts, the same nodes in the same
order to round-off, and mass properties scaled by s³ (volume), s (centre of mass, box) and
s⁵ (inertia)."""
from __future__ import annotations

import gmsh
import numpy as np
import pytest

from geometry import build_msh
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from geometry.meshing import gmsh_session
from geometry.params import CONROD_DEFAULTS, CRANKSHAFT_DEFAULTS

SCALES = (1e-3, 1.0, 1e3)
EPS = np.finfo(float).eps
I_BEAM = {"kind": "beam", "section": "I", "width": 0.04, "height": 0.05,
          "flange_thickness": 0.006, "web_thickness": 0.004, "length": 0.3}
TWO_THROWS = {"kind": "crankshaft", "throws": 2,
              **{k: v for k, v in CRANKSHAFT_DEFAULTS.items() if isinstance(v, float)}}
NOT_LENGTHS = {"kind", "section", "throws", "crank_angles_deg"}


def scaled(table: dict, s: float) -> dict:
    """A [geometry] or [mesh] table with every length times ``s``."""
    return {key: ([[y * s, z * s] for y, z in value] if key == "vertices"
                  else value if key in NOT_LENGTHS or not isinstance(value, float) else value * s)
            for key, value in table.items()}


def nodes_of(path) -> np.ndarray:
    """The node coordinates of a .msh file, in its node-tag order."""
    with gmsh_session():
        gmsh.merge(str(path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
    return xyz.reshape(-1, 3)[np.argsort(tags)]


@pytest.mark.slow
@pytest.mark.parametrize("geometry, mesh", [
    (I_BEAM, {"size": 0.01, "order": 2}),
    ({"kind": "beam", "section": "tube", "radius": 0.02, "thickness": 0.004, "length": 0.2},
     {"size": 0.01, "order": 1, "refine": {"end_x0": 0.004}}),
    (TWO_THROWS, {"size": 0.02, "order": 2}),
    ({"kind": "conrod", **CONROD_DEFAULTS}, {"size": 0.005, "order": 2}),
], ids=["I", "tube-refined", "crankshaft", "conrod"])
def test_scaled_bodies_get_the_scaled_mesh(tmp_path, geometry, mesh):
    """Before, Gmsh's and OCC's absolute tolerances made the I beam 6540 / 6526 / 6516 nodes
    at 1e-3 / 1 / 1e3 and the 1e-3 crankshaft folded curved cells. Each coordinate in
    metres is the model's coordinate times the unit (one rounding) and is divided by s
    here (another), the units of two scales differing by a rounding of 10**k: |Δx| <=
    4 ε max|x|, asserted at 8 ε."""
    built = {}
    for s in SCALES:
        geom = parse_geometry(scaled(geometry, s))
        mesh_s = {**scaled({k: v for k, v in mesh.items() if k != "refine"}, s),
                  **({"refine": scaled(mesh["refine"], s)} if "refine" in mesh else {})}
        info = build_msh(geom, parse_mesh(mesh_s, geom), tmp_path / f"{s:g}.msh")
        built[s] = info, nodes_of(tmp_path / f"{s:g}.msh") / s
    info_1, x_1 = built[1.0]
    tol = 8 * EPS * np.abs(x_1).max()
    mp_1 = info_1.mass_properties
    for s in (1e-3, 1e3):
        info, x = built[s]
        assert (info.nodes, info.cells) == (info_1.nodes, info_1.cells)
        assert np.abs(x - x_1).max() <= tol
        mp = info.mass_properties
        assert mp["volume_m3"] / s**3 == pytest.approx(mp_1["volume_m3"], rel=16 * EPS)
        assert np.allclose(np.array(mp["center_of_mass_m"]) / s, mp_1["center_of_mass_m"],
                           rtol=0, atol=tol)
        assert np.allclose(np.array(mp["inertia_m5"]) / s**5, mp_1["inertia_m5"], rtol=0,
                           atol=16 * EPS * np.abs(mp_1["inertia_m5"]).max())
        assert np.allclose(np.array(mp["bounding_box_m"]) / s, mp_1["bounding_box_m"], rtol=0,
                           atol=tol)
