"""The OCC model of a connecting rod: two eyes and an I-section shank fused, the bores cut.

Placement comes from ``geometry.conrod_layout``: each eye is a full cylinder along z, the
shank its I-section extruded along x from one bore centre to the other; the three are
fused, the two bores cut through, and the bores' cylindrical faces found again on the
result by their geometry (``geometry.faces``).
"""
from __future__ import annotations

import gmsh

from geometry import faces
from geometry.conrod_layout import eyes, largest_extent, shank_profile
from geometry.errors import KernelFailure
from geometry.occ_shapes import add_face, extrude_along_x, to_section_plane
from geometry.params import ConrodParams
from geometry.solid import Solid


def add_conrod(p: ConrodParams) -> Solid:
    """Build the connecting rod in the current Gmsh model, with groups ``big_end`` and
    ``small_end`` (the cylindrical faces of its two bores)."""
    occ = gmsh.model.occ
    parts = eyes(p)
    discs = [(3, occ.addCylinder(e.x, 0.0, -e.width / 2, 0.0, 0.0, e.width, e.radius))
             for e in parts]
    section = [(2, add_face(shank_profile(p).outer))]
    to_section_plane(section, 0.0)
    shank = [(3, tag) for tag in extrude_along_x(section, p.length)]
    rod, _ = occ.fuse(discs[:1], discs[1:] + shank)
    bores = [(3, occ.addCylinder(e.x, 0.0, -e.width, 0.0, 0.0, 2.0 * e.width, e.bore))
             for e in parts]
    cut, _ = occ.cut(rod, bores)
    occ.synchronize()
    if len(cut) != 1:
        raise KernelFailure(f"conrod: fusion and bores gave {len(cut)} solids instead of one")
    volume = cut[0][1]
    boundary = faces.boundary_faces(volume)
    tol = faces.tolerance(largest_extent(p))
    return Solid(volume, {e.name: faces.cylinder_z(boundary, (e.x, 0.0), e.bore, -e.width / 2,
                                                   e.width / 2, tol) for e in parts})
