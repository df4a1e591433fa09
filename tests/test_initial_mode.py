"""``[scene.initial] mode``: its shape no longer depends on the basis the eigen-solver returns
for a repeated pair, nor on the sign it returns (``dynamics.initial``, rule in ``scene``).

Two square beams (30 × 30 mm, 0.5 m and 0.5001 m: near-identical, so their bending pairs are
split only by their meshes, 1e-6..1e-5, and the solver returns a differently turned basis of
each pair) and the rectangular test beam of ``beams``.
"""
from __future__ import annotations

import numpy as np
import pytest

from conftest import gcms_reduce
from gcms_fenicsx.dynamics.body import Body, body_from_reduced
from gcms_fenicsx.dynamics.initial import (TIE, mode_cluster, nodal_displacements,
                                           oriented_shape)
from gcms_fenicsx.dynamics.scene import Initial, parse_scene
from gcms_fenicsx.dynamics.simulate import elastic_modes, initial_coordinates
from gcms_fenicsx.files.reduced_model import read_reduced
from gcms_fenicsx.config.table import ConfigError

EPS = np.finfo(float).eps
DIRECTION = np.array([0.0, 1.0, 2.0]) / np.sqrt(5.0)
SQUARE = """
[geometry]
kind = "beam"
section = "square"
side = 0.03
length = {length}

[mesh]
size = 0.012

[modes]
count = 6
"""


@pytest.fixture(scope="module")
def square_beams(tmp_path_factory) -> list[Body]:
    bodies = []
    for length in (0.5, 0.5001):
        folder = tmp_path_factory.mktemp("square")
        gcms_reduce(SQUARE.format(length=length), folder / "study.toml", folder)
        bodies.append(body_from_reduced(read_reduced(folder / "reduced.h5")))
    return bodies


def group_displacement(body: Body, q: np.ndarray, group: str) -> np.ndarray:
    return (q - body.q0).reshape(-1, 3).T @ body.groups[group].position


def angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0)))


@pytest.mark.parametrize("mode", [1, 3])
def test_direction_gives_near_identical_beams_the_same_shape(square_beams, mode):
    """Mode 1 (first bending pair, symmetric: both ends move alike) and mode 3 (second pair,
    antisymmetric) with direction = (0, 1, 2)/√5: the two beams start in the same shape — the
    displacements of both end faces agree — and the end face x = 0, where the pair reaches
    farthest (tied with x = L, which the tie rule resolves), moves along the direction.

    Tolerance from the problem: the beams differ by 1e-4 in length and by their meshes, which
    changes the pair's eigenvalue by Δλ/λ; an eigenvector changes by at most O(√(Δλ/λ))
    (first order in the change for a change of the problem, the square root bounds it
    when the eigenvalue error is of second order), so tol = √(Δλ/λ). Without the direction
    the solver's bases differ by far more than that (checked: the test is not vacuous)."""
    a, b = square_beams
    lam_a, lam_b = (elastic_modes(body)[0][5 + mode] for body in square_beams)
    tol = np.sqrt(abs(lam_a - lam_b) / lam_a)
    shapes, raw = [], []
    for body in square_beams:
        q = initial_coordinates(body, Initial(mode=mode, amplitude_m=1e-3,
                                              direction=tuple(DIRECTION)))
        start = group_displacement(body, q, "end_x0")
        assert angle(start, DIRECTION) <= tol
        shapes.append(np.concatenate([start, group_displacement(body, q, "end_xL")]))
        _, psi = elastic_modes(body)
        raw.append(group_displacement(body, body.q0 + psi[:, 5 + mode], "end_x0"))
    np.testing.assert_allclose(shapes[0], shapes[1], rtol=0, atol=tol * np.abs(shapes[0]).max())
    assert min(angle(raw[0], raw[1]), angle(raw[0], -raw[1])) > 10 * tol, (raw, tol)


def test_direction_does_not_depend_on_the_basis_of_the_pair(square_beams):
    """The oriented shape is a function of the pair's subspace: the solver's basis turned by
    40° or reflected gives the same shape, to the round-off of the few products of length
    k = 2 that form it (bound 10 (4k + 2) ε of its largest entry)."""
    body = square_beams[0]
    lam, psi = elastic_modes(body)
    cluster = mode_cluster(lam, 6)
    assert len(cluster) == 2
    pair = psi[:, cluster.start:cluster.stop]
    c, s = np.cos(0.7), np.sin(0.7)
    shape = oriented_shape(body, pair, DIRECTION)
    for turn in (np.array([[c, -s], [s, c]]), np.array([[c, s], [s, -c]])):
        other = oriented_shape(body, pair @ turn, DIRECTION)
        assert np.abs(other - shape).max() <= 10 * (4 * 2 + 2) * EPS * np.abs(shape).max()


def test_sign_rule_without_direction(beam6_reduced, square_beams):
    """Without a direction every elastic mode starts with the sign the rule gives: its largest
    nodal displacement's largest-magnitude component is positive (nodes within TIE of the
    largest tie, the first in (x, y, z) order wins; likewise components), and its largest
    nodal displacement is the amplitude. Today the sign is the solver's."""
    for body in (body_from_reduced(read_reduced(beam6_reduced)), *square_beams):
        order = np.lexsort(np.round(body.nodes_m / (1e-6 * body.size_m)).T[::-1])
        for mode in range(1, 7):
            q = initial_coordinates(body, Initial(mode=mode, amplitude_m=1e-3))
            D = nodal_displacements(body, (q - body.q0)[:, None])[:, :, 0]
            size = np.linalg.norm(D, axis=1)
            assert size.max() == pytest.approx(1e-3, rel=1e-9)
            node = next(i for i in order if size[i] >= (1 - TIE) * size.max())
            component = next(k for k in range(3)
                             if abs(D[node, k]) >= (1 - TIE) * np.abs(D[node]).max())
            assert D[node, component] > 0, (mode, D[node])


def test_direction_needs_a_mode_and_a_non_zero_vector():
    """direction without mode, and a zero direction, are refused naming the key."""
    base = {"end_time": 1.0, "time_step": 0.1}
    with pytest.raises(ConfigError, match=r"\[scene.initial\] direction = \[0, 1, 0\]: needs "
                                          "mode = N"):
        parse_scene({**base, "initial": {"direction": [0, 1, 0]}})
    with pytest.raises(ConfigError, match=r"\[scene.initial\] direction = \[0.0, 0.0, 0.0\]: "
                                          "must be a non-zero vector"):
        parse_scene({**base, "initial": {"mode": 1, "amplitude": 1e-3, "direction": [0, 0, 0]}})
    scene = parse_scene({**base, "initial": {"mode": 1, "amplitude": 1e-3, "direction": [0, 3, 4]}})
    assert scene.initial.direction == pytest.approx((0.0, 0.6, 0.8))
