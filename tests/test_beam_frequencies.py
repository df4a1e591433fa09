"""Free-free frequencies of slender beams (L/h = 20) meshed by the project's Gmsh builders
at their default order-2 mesh, against beam theory (references in ``beam_theory``)."""
from __future__ import annotations

import numpy as np
import pytest

from gcms_fenicsx.references.beam_theory import bar_hz, cowper_kappa, rectangle_torsion_constant, timoshenko_hz, torsion_hz
from gcms_fenicsx.app import pipeline
from gcms_fenicsx.fe import algebra, assembly, modes
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.modes import ModesConfig
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh

STEEL = Material()
G = STEEL.E / (2 * (1 + STEEL.nu))
L = 1.0
WIDTH, HEIGHT, RADIUS = 0.05, 0.04, 0.025  # rectangle b × h (L/b = 20), circle L/d = 20


def classify(model: assembly.FEModel, modes: modes.Modes) -> list[str]:
    """Name each elastic mode by its M-weighted content: axial (u_x), torsion ((u_y, u_z)
    tangential to circles about the axis), or bending in y or z; a bending pair of a round
    section, in whatever basis the solver returns it, is 'bending'."""
    y, z = model.nodes[:, 1], model.nodes[:, 2]
    r = np.hypot(y, z)
    ty, tz = np.divide(-z, r, out=np.zeros_like(r), where=r > 0), np.divide(y, r, out=np.zeros_like(r), where=r > 0)
    out = []
    for phi in modes.elastic_vectors.T:
        u = phi.reshape(-1, 3)
        Mu = np.column_stack([_ms(model, u[:, k]) for k in range(3)])
        energy = np.einsum("ik,ik->k", u, Mu)
        share = energy / energy.sum()
        tangential = u[:, 1] * ty + u[:, 2] * tz
        twist = np.dot(tangential, _ms(model, tangential)) / (energy[1] + energy[2])
        if share[0] > 0.8:
            out.append("axial")
        elif twist > 0.8:
            out.append("torsion")
        elif share[1] > 0.8:
            out.append("bending_y")
        elif share[2] > 0.8:
            out.append("bending_z")
        else:
            out.append("bending")
    return out


def _ms(model: assembly.FEModel, values: np.ndarray) -> np.ndarray:
    return algebra.mat_dense(model.Ms, values[:, None])[:, 0]


def _solve(tmp_path, geometry: dict, mesh_table: dict | None = None):
    geom = parse_geometry({"kind": "beam", "length": L, **geometry})
    mesh = parse_mesh(mesh_table or {}, geom)
    chain = pipeline.free_free(geom, mesh, STEEL, ModesConfig(count=12), tmp_path)
    model, modes = chain.assembly.model, chain.modes
    return model, modes, classify(model, modes), mesh.size


def _first(freqs: np.ndarray, kinds: list[str], kind: str) -> float:
    return freqs[kinds.index(kind)]


@pytest.mark.slow
def test_rectangle_beam(tmp_path):
    model, modes, kinds, size = _solve(tmp_path, {"section": "rectangle", "width": WIDTH,
                                                  "height": HEIGHT})
    f = modes.elastic_frequencies_hz
    A = WIDTH * HEIGHT
    kappa = cowper_kappa("rectangle", STEEL.nu)
    # bending in z bends about y: I = b h³/12; bending in y: I = h b³/12
    for kind, inertia in (("bending_z", WIDTH * HEIGHT ** 3 / 12),
                          ("bending_y", HEIGHT * WIDTH ** 3 / 12)):
        ref = timoshenko_hz(1, STEEL.E, STEEL.nu, kappa, STEEL.rho, A, inertia, L)
        assert _first(f, kinds, kind) == pytest.approx(ref, rel=5e-3), (kind, size)
    assert _first(f, kinds, "axial") == pytest.approx(bar_hz(1, STEEL.E, STEEL.rho, L), rel=5e-3)


@pytest.mark.slow
def test_rectangle_beam_torsion(tmp_path):
    """The warping of a rectangle's section needs a finer mesh than bending: at the
    default size (22 mm, two elements through the height) torsion is 1.5 % stiff, at
    10 mm 0.15 %, at 6.7 mm 0.04 % (St-Venant, no warping inertia)."""
    J = rectangle_torsion_constant(WIDTH, HEIGHT)
    Ip = WIDTH * HEIGHT * (WIDTH ** 2 + HEIGHT ** 2) / 12
    ref = torsion_hz(1, G, J, STEEL.rho, Ip, L)
    geometry = {"section": "rectangle", "width": WIDTH, "height": HEIGHT}
    _, coarse, kinds, _ = _solve(tmp_path, geometry)
    assert 1.0 < _first(coarse.elastic_frequencies_hz, kinds, "torsion") / ref < 1.02
    _, fine, kinds, _ = _solve(tmp_path, geometry, {"size": 0.01})
    assert _first(fine.elastic_frequencies_hz, kinds, "torsion") == pytest.approx(ref, rel=3e-3)


@pytest.mark.slow
def test_circle_beam(tmp_path):
    model, modes, kinds, size = _solve(tmp_path, {"section": "circle", "radius": RADIUS})
    f = modes.elastic_frequencies_hz
    A, inertia = np.pi * RADIUS ** 2, np.pi * RADIUS ** 4 / 4
    ref = timoshenko_hz(1, STEEL.E, STEEL.nu, cowper_kappa("circle", STEEL.nu), STEEL.rho, A,
                        inertia, L)
    bending = [fi for fi, k in zip(f, kinds) if k.startswith("bending")]
    assert bending[0] == pytest.approx(ref, rel=5e-3), size
    assert bending[1] == pytest.approx(ref, rel=5e-3), size
    Ip = np.pi * RADIUS ** 4 / 2  # J = Ip for a circle: no warping
    assert _first(f, kinds, "torsion") == pytest.approx(
        torsion_hz(1, G, Ip, STEEL.rho, Ip, L), rel=5e-3)
    assert _first(f, kinds, "axial") == pytest.approx(bar_hz(1, STEEL.E, STEEL.rho, L), rel=5e-3)
    pair = modes.clusters()[0]
    assert pair["modes"] == [0, 1] and pair["relative_split"] < 1e-3  # unstructured mesh
