"""How many cells and nodes Gmsh will make, estimated from ``[geometry]`` and ``[mesh]`` alone.

A tetrahedral mesh of element size h has about a·V/h³ cells in a volume V, plus about
b·S/h² more along a surface S (smaller cells where the surface mesh is graded into the
volume; all of them where the body is thinner than h). So the body is cut into regions,
each meshed at one size: a beam is one region, a crankshaft one per journal, pin, web,
nose and flange, a connecting rod one per eye and its shank. A region's size is ``[mesh] size`` or, on a round surface, the curvature
size 2πr/ELEMENTS_PER_CIRCLE if smaller, as Gmsh's ``MeshSizeFromCurvature`` makes it;
a beam's volume takes the size of its largest round outline (the interior is
interpolated from the boundary). Then

    cells ≈ a·T_V + b·T_S,   vertices ≈ p·T_V + q·T_S,   boundary triangles ≈ r·T_S,

with T_V = Σ V/h³ and T_S = Σ S/h². Order 2 adds a node per edge, and Euler's relation
for a tetrahedral mesh of a solid (vertices − edges + faces − cells = χ, faces = 2·cells
+ boundary triangles/2) gives edges = vertices + cells + boundary triangles/2 − χ. A
refined surface group of area A at size h_r, growing linearly to h over a distance 2h
(``meshing.set_mesh_sizes``), adds A·((h + h_r)/(h_r² h) − 2/h²) to T_V (∫ dd/s(d)³ over
the layer, less what h alone gives it) and A·(1/h_r² − 1/h²) to T_S.

The constants are fitted to Gmsh 4.8's counts over every section and crankshafts of 1 to
4 throws across sizes (docs/geometry_checks.md; ``tests/test_geometry_estimate.py``
checks them). Pure Python: no Gmsh.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from geometry import conrod_layout, groups
from geometry.crank_layout import RoundPart, crank_layout, web_area_and_perimeter
from geometry.params import ELEMENTS_PER_CIRCLE, BeamParams, ConrodParams, CrankshaftParams, \
    Geometry, MeshParams
from geometry.shapes import Circle, Polygon

#: Fitted constants of the module docstring's model (cells, vertices, boundary triangles).
CELLS_PER_VOLUME, CELLS_PER_SURFACE = 3.22, 2.51
VERTICES_PER_VOLUME, VERTICES_PER_SURFACE = 0.437, 1.21
TRIANGLES_PER_SURFACE = 2.62
#: Gmsh meshes no coarser than this fraction of the bounding box's diagonal, whatever
#: ``[mesh] size`` says (measured: a 0.1 m beam's edges get 9 to 10 segments at any size).
GMSH_SIZE_CAP = 0.1


@dataclass(frozen=True)
class MeshEstimate:
    """Estimated counts of a mesh at its order: cells, nodes (vertices, plus edge midpoints
    at order 2) and displacement degrees of freedom."""

    cells: int
    nodes: int

    @property
    def dofs(self) -> int:
        return 3 * self.nodes


@dataclass(frozen=True)
class Terms:
    """T_V = Σ V/h³ and T_S = Σ S/h² of the module docstring."""

    volume: float = 0.0
    surface: float = 0.0

    def __add__(self, other: Terms) -> Terms:
        return Terms(self.volume + other.volume, self.surface + other.surface)


def curvature_size(radius: float, size: float) -> float:
    """The element size on a round surface of ``radius``: at most ``size``."""
    return min(size, 2.0 * math.pi * radius / ELEMENTS_PER_CIRCLE)


def bounding_box_diagonal(geom: Geometry) -> float:
    """The diagonal of the body's bounding box (a crankshaft's from its widest reach)."""
    if isinstance(geom, BeamParams):
        width, height = geom.profile().outer.extent
        return math.hypot(geom.length, width, height)
    if isinstance(geom, ConrodParams):
        return math.hypot(*conrod_layout.bounding_box(geom))
    layout = crank_layout(geom)
    return math.hypot(layout.length, layout.width, layout.width)


def effective_size(geom: Geometry, size: float) -> float:
    """``[mesh] size``, or GMSH_SIZE_CAP of the bounding-box diagonal if that is smaller."""
    return min(size, GMSH_SIZE_CAP * bounding_box_diagonal(geom))


def mesh_terms(geom: Geometry, mesh: MeshParams) -> Terms:
    """T_V and T_S of ``geom`` meshed as ``mesh``, refinement included."""
    size = effective_size(geom, mesh.size)
    terms = body_terms(geom, size)
    for name, fine in mesh.refine.items():
        area, local = group_area_and_size(geom, name, size)
        terms += refinement_terms(area, fine, local)
    return terms


def estimate_mesh(geom: Geometry, mesh: MeshParams) -> MeshEstimate:
    """The cells and nodes Gmsh will make for ``geom`` meshed as ``mesh`` (module docstring)."""
    terms = mesh_terms(geom, mesh)
    cells = CELLS_PER_VOLUME * terms.volume + CELLS_PER_SURFACE * terms.surface
    vertices = VERTICES_PER_VOLUME * terms.volume + VERTICES_PER_SURFACE * terms.surface
    nodes = vertices
    if mesh.order == 2:
        nodes += vertices + cells + TRIANGLES_PER_SURFACE * terms.surface / 2.0
    return MeshEstimate(cells=round(cells), nodes=round(nodes))


def body_terms(geom: Geometry, size: float) -> Terms:
    """T_V and T_S of the whole body at ``[mesh] size`` (without refinement)."""
    if isinstance(geom, BeamParams):
        return _beam_terms(geom, size)
    if isinstance(geom, ConrodParams):
        return _conrod_terms(geom, size)
    return _crankshaft_terms(geom, size)


def _outline_size(shape: Circle | Polygon, size: float) -> float:
    """The element size along a section's outline: the curvature size of a circle."""
    return curvature_size(shape.radius, size) if isinstance(shape, Circle) else size


def beam_volume_size(p: BeamParams, size: float) -> float:
    """The size a beam's volume and end faces are meshed at: that of its largest outline."""
    return _outline_size(p.profile().outer, size)


def _beam_terms(p: BeamParams, size: float) -> Terms:
    profile = p.profile()
    inner = beam_volume_size(p, size)
    terms = Terms(profile.area * p.length / inner**3, 2.0 * profile.area / inner**2)
    for shape in (profile.outer, profile.hole):
        if shape is not None:
            terms += Terms(0.0, shape.perimeter * p.length / _outline_size(shape, size) ** 2)
    return terms


def _round_terms(part: RoundPart, size: float) -> Terms:
    h = curvature_size(part.radius, size)
    return Terms(math.pi * part.radius**2 * part.length / h**3,
                 2.0 * math.pi * part.radius * part.length / h**2)


def _crankshaft_terms(p: CrankshaftParams, size: float) -> Terms:
    """Round parts; webs (the outline's faces less the journal and pin discs they carry,
    and the rim); the end faces and the shoulders where two round parts meet."""
    layout = crank_layout(p)
    terms = Terms()
    for part in layout.parts:
        terms += _round_terms(part, size)
    area, perimeter = web_area_and_perimeter(p)
    h = curvature_size(p.web_width / 2.0, size)
    covered = math.pi * (p.journal_diameter**2 + p.pin_diameter**2) / 4.0
    terms += Terms(len(layout.webs) * area * p.web_thickness / h**3,
                   len(layout.webs) * (2.0 * area - covered + perimeter * p.web_thickness) / h**2)
    first, last = layout.parts[0], layout.parts[-1]
    faces = [(first.radius**2, first), (last.radius**2, last)]
    faces += [(abs(a.radius**2 - b.radius**2), max(a, b, key=lambda q: q.radius))
              for a, b in zip(layout.parts, layout.parts[1:]) if a.x1 == b.x0]
    for radius_squared, part in faces:  # plane faces, meshed at the larger part's size
        terms += Terms(0.0, math.pi * radius_squared / curvature_size(part.radius, size) ** 2)
    return terms


def _conrod_terms(p: ConrodParams, size: float) -> Terms:
    """Each eye an annulus meshed at its outer surface's size (outer and bore surfaces,
    two faces), the shank a prism between the eyes at ``[mesh] size`` (its sides)."""
    terms = Terms()
    for eye in conrod_layout.eyes(p):
        h = curvature_size(eye.radius, size)
        ring = math.pi * (eye.radius**2 - eye.bore**2)
        terms += Terms(ring * eye.width / h**3, 2.0 * (ring + math.pi * eye.radius * eye.width)
                       / h**2 + 2.0 * math.pi * eye.bore * eye.width
                       / curvature_size(eye.bore, size) ** 2)
    shank, length = conrod_layout.shank_profile(p), conrod_layout.shank_length(p)
    return terms + Terms(shank.area * length / size**3, shank.perimeter * length / size**2)


def group_area_and_size(geom: Geometry, name: str, size: float) -> tuple[float, float]:
    """A surface group's area and the element size around it without refinement."""
    if isinstance(geom, BeamParams):
        return geom.profile().area, beam_volume_size(geom, size)
    if isinstance(geom, ConrodParams):
        eye = next(e for e in conrod_layout.eyes(geom) if e.name == name)
        return 2.0 * math.pi * eye.bore * eye.width, curvature_size(eye.bore, size)
    parts = crank_layout(geom).parts
    if name in (groups.END_X0, groups.END_XL):
        part = parts[0] if name == groups.END_X0 else parts[-1]
        return math.pi * part.radius**2, curvature_size(part.radius, size)
    part = next(q for q in parts if q.name == name)
    return 2.0 * math.pi * part.radius * part.length, curvature_size(part.radius, size)


def refinement_terms(area: float, fine: float, size: float) -> Terms:
    """What a group of ``area`` refined to ``fine`` adds where the mesh is ``size`` (module
    docstring); nothing when ``fine`` >= ``size``."""
    if fine >= size:
        return Terms()
    return Terms(area * ((size + fine) / (fine**2 * size) - 2.0 / size**2),
                 area * (1.0 / fine**2 - 1.0 / size**2))
