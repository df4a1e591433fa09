"""The OCC model of a crankshaft: round parts and extruded webs fused into one solid.

Placement comes from ``geometry.crank_layout``; here every part becomes an OCC solid
(cylinders for the nose, journals, pins and flange; each web's outline fused in 2D and
extruded by its thickness), all are fused, and the named surfaces are found again on the
fused solid by their geometry (``geometry.faces``).
"""
from __future__ import annotations

import gmsh

from geometry import faces, groups
from geometry.errors import KernelFailure
from geometry.solid import Solid
from geometry.crank_layout import CrankLayout, Web, crank_layout
from geometry.occ_shapes import DimTags, add_face, extrude_along_x, to_section_plane
from geometry.params import CrankshaftParams


def add_crankshaft(p: CrankshaftParams) -> Solid:
    """Build the crankshaft in the current Gmsh model, with groups ``journal_i``
    (cylindrical main journal surfaces), ``pin_i`` (crank pin surfaces), ``end_x0``, ``end_xL``."""
    occ = gmsh.model.occ
    layout = crank_layout(p)
    solids: DimTags = [(3, occ.addCylinder(part.x0, *part.centre, part.length, 0.0, 0.0,
                                           part.radius)) for part in layout.parts]
    for web in layout.webs:
        solids += [(3, tag) for tag in _add_web(web)]
    fused, _ = occ.fuse(solids[:1], solids[1:])
    occ.synchronize()
    if len(fused) != 1:
        raise KernelFailure(f"crankshaft: fusion gave {len(fused)} solids instead of one")
    volume = fused[0][1]
    return Solid(volume, _surfaces(layout, volume))


def _add_web(web: Web) -> list[int]:
    """The web plate: its outline shapes fused into one face, extruded along x."""
    occ = gmsh.model.occ
    pieces = [(2, add_face(shape)) for shape in web.shapes]
    outline, _ = occ.fuse(pieces[:1], pieces[1:])
    to_section_plane(outline, web.x0)
    return extrude_along_x(outline, web.thickness)


def _surfaces(layout: CrankLayout, volume: int) -> dict[str, list[int]]:
    boundary = faces.boundary_faces(volume)
    tol = faces.tolerance(layout.largest_extent)
    found = {groups.END_X0: faces.plane_x(boundary, 0.0, tol),
             groups.END_XL: faces.plane_x(boundary, layout.length, tol)}
    for part in layout.parts:
        if part.name.startswith(("journal_", "pin_")):
            found[part.name] = faces.cylinder_x(boundary, part.centre, part.radius,
                                                part.x0, part.x1, tol)
    return found
