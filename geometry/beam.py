"""The OCC model of a straight beam: its section extruded along x from 0 to ``length``."""
from __future__ import annotations

import gmsh

from geometry import faces, groups
from geometry.solid import Solid
from geometry.occ_shapes import add_face, extrude_along_x, to_section_plane
from geometry.extent import largest_extent
from geometry.params import BeamParams


def add_beam(p: BeamParams) -> Solid:
    """Build the beam in the current Gmsh model; its end faces are ``end_x0`` and ``end_xL``."""
    profile = p.profile()
    section = [(2, add_face(profile.outer, profile.hole))]
    to_section_plane(section, 0.0)
    (volume,) = extrude_along_x(section, p.length)
    gmsh.model.occ.synchronize()
    boundary = faces.boundary_faces(volume)
    tol = faces.tolerance(largest_extent(p))
    return Solid(volume, {groups.END_X0: faces.plane_x(boundary, 0.0, tol),
                         groups.END_XL: faces.plane_x(boundary, p.length, tol)})
