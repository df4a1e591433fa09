"""A tetrahedral box mesh with the full symmetry of its hexahedral grid.

Each hexahedron is split into 24 tetrahedra (cell centre, face centre, one edge), a
pattern invariant under every symmetry of the cube, so a square-section beam meshed with
ny = nz is mapped onto itself by the swap y ↔ z: its bending pairs are exactly repeated.
(dolfinx's ``create_box`` 6-tet split is not invariant under that swap.)
"""
from __future__ import annotations

import itertools

import numpy as np
import ufl
from dolfinx.mesh import Mesh, create_mesh
from mpi4py import MPI

# the 6 faces of the unit cube as (fixed axis, side) and their 4 edges as corner pairs
_CORNERS = np.array(list(itertools.product([0, 1], repeat=3)))  # index = 4i + 2j + k


def _face_edges(axis: int, side: int) -> list[tuple[int, int]]:
    on_face = [c for c in range(8) if _CORNERS[c][axis] == side]
    return [(a, b) for a, b in itertools.combinations(on_face, 2)
            if np.abs(_CORNERS[a] - _CORNERS[b]).sum() == 1]


def symmetric_box(comm: MPI.Comm, lower, upper, n) -> Mesh:
    """P1 tetrahedral mesh of the box [lower, upper] with n = (nx, ny, nz) hexahedra, 24 tets each."""
    lower, upper, n = np.asarray(lower, float), np.asarray(upper, float), np.asarray(n)
    if comm.rank != 0:
        points, cells = np.zeros((0, 3)), np.zeros((0, 4), dtype=np.int64)
    else:
        grid = [np.linspace(lower[d], upper[d], n[d] + 1) for d in range(3)]
        vertex_id = lambda i, j, k: (i * (n[1] + 1) + j) * (n[2] + 1) + k  # noqa: E731
        points = [np.array([grid[0][i], grid[1][j], grid[2][k]])
                  for i in range(n[0] + 1) for j in range(n[1] + 1) for k in range(n[2] + 1)]
        cells = []
        face_points: dict[tuple[int, ...], int] = {}  # shared by the two hexahedra of a face
        for i, j, k in itertools.product(range(n[0]), range(n[1]), range(n[2])):
            corner_ids = [vertex_id(i + a, j + b, k + c) for a, b, c in _CORNERS]
            corner_xyz = np.array([points[c] for c in corner_ids])
            centre = len(points)
            points.append(corner_xyz.mean(axis=0))
            for axis, side in itertools.product(range(3), [0, 1]):
                on_face = _CORNERS[:, axis] == side
                key = tuple(sorted(np.array(corner_ids)[on_face]))
                if key not in face_points:
                    face_points[key] = len(points)
                    points.append(corner_xyz[on_face].mean(axis=0))
                face = face_points[key]
                for a, b in _face_edges(axis, side):
                    cells.append([corner_ids[a], corner_ids[b], face, centre])
        points, cells = np.array(points), np.array(cells, dtype=np.int64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.tetrahedron, 1))
    return create_mesh(comm, cells, points, domain)
