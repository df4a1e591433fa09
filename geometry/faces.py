"""Finding named surfaces of a (fused) OCC solid by their geometry.

Boolean operations renumber and may split faces, so groups are not tracked through them;
instead each boundary face is sampled at a grid of parametric points and kept when its
CAD type matches and every sample lies on the expected plane or cylinder. Needs a
synchronized Gmsh model.
"""
from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np

SAMPLES_PER_DIRECTION = 4


@dataclass(frozen=True)
class Face:
    tag: int
    kind: str  # Gmsh's CAD type: "Plane", "Cylinder", ...
    points: np.ndarray  # (n, 3) samples on the face


def boundary_faces(volume: int) -> list[Face]:
    """The faces bounding ``volume``, each with its type and sample points."""
    faces = []
    for _, tag in gmsh.model.getBoundary([(3, volume)], oriented=False):
        (u0, v0), (u1, v1) = gmsh.model.getParametrizationBounds(2, tag)  # (min, max)
        s = (np.arange(SAMPLES_PER_DIRECTION) + 0.5) / SAMPLES_PER_DIRECTION
        uv = np.array([(u0 + a * (u1 - u0), v0 + b * (v1 - v0)) for a in s for b in s])
        points = np.reshape(gmsh.model.getValue(2, tag, uv.ravel()), (-1, 3))
        faces.append(Face(tag, gmsh.model.getType(2, tag), points))
    return faces


def plane_x(faces: list[Face], x: float, tol: float) -> list[int]:
    """Tags of the plane faces lying in the plane at ``x``."""
    return [f.tag for f in faces
            if f.kind == "Plane" and np.all(np.abs(f.points[:, 0] - x) <= tol)]


def cylinder_x(faces: list[Face], centre: tuple[float, float], radius: float,
               x0: float, x1: float, tol: float) -> list[int]:
    """Tags of the cylindrical faces on the cylinder of ``radius`` about the line parallel
    to x through (y, z) = ``centre``, between x0 and x1."""
    return _cylinder(faces, 0, centre, radius, (x0, x1), tol)


def cylinder_z(faces: list[Face], centre: tuple[float, float], radius: float,
               z0: float, z1: float, tol: float) -> list[int]:
    """Tags of the cylindrical faces on the cylinder of ``radius`` about the line parallel
    to z through (x, y) = ``centre``, between z0 and z1."""
    return _cylinder(faces, 2, centre, radius, (z0, z1), tol)


def _cylinder(faces: list[Face], axis: int, centre: tuple[float, float], radius: float,
              span: tuple[float, float], tol: float) -> list[int]:
    """Tags of the cylindrical faces about the line parallel to coordinate ``axis`` through
    ``centre`` (the other two coordinates, in order), within ``span`` along it."""
    across = [i for i in range(3) if i != axis]
    found = []
    for f in faces:
        if f.kind != "Cylinder":
            continue
        r = np.hypot(f.points[:, across[0]] - centre[0], f.points[:, across[1]] - centre[1])
        along = f.points[:, axis]
        if np.all(np.abs(r - radius) <= tol) and np.all(
                (along >= span[0] - tol) & (along <= span[1] + tol)):
            found.append(f.tag)
    return found


def tolerance(extent: float) -> float:
    """Matching tolerance for a body of the given size: samples are evaluated on the exact
    CAD surfaces, so this only needs to absorb round-off and OCC's 1e-7 m vertex fuzz."""
    return 1e-6 * extent
