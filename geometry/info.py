"""What a build reported: counts, physical groups and the CAD kernel's mass properties.
Pure Python (it crosses from the meshing process as JSON)."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any


@dataclass(frozen=True)
class MeshInfo:
    """What was meshed: counts, physical groups and the CAD's mass properties.

    ``mass_properties`` come from the OCC kernel at unit density: ``volume_m3``,
    ``center_of_mass_m`` [x, y, z], ``inertia_m5`` (3×3, about the centre of mass,
    J = ∫ (|r|² I − r rᵀ) dV with r = x − x_c: positive diagonal, off-diagonals
    −∫ r_i r_j dV; OCC's ``MatrixOfInertia`` convention, checked against a box and an
    L-shaped solid), and ``bounding_box_m`` [[x, y, z]min, [x, y, z]max] (OCC's box,
    enlarged by its tolerance, ~1e-7 of the model unit).
    """

    nodes: int
    cells: int
    groups: dict[str, tuple[int, int]]  # name → (dim, physical tag)
    mass_properties: dict[str, Any]

    def to_json(self) -> dict:
        return asdict(self)

    def summary(self) -> str:
        mp = self.mass_properties
        com = ", ".join(f"{c:.4g}" for c in mp["center_of_mass_m"])
        return "\n".join([
            f"mesh: {self.nodes} nodes, {self.cells} tetrahedra",
            f"CAD volume {mp['volume_m3']:.6e} m^3, centre of mass ({com}) m",
            "groups: " + ", ".join(f"{name} ({dim}D, tag {tag})"
                                   for name, (dim, tag) in self.groups.items()),
        ])

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> MeshInfo:
        """Inverse of :meth:`to_json` (JSON lists back to (dim, tag) tuples)."""
        return cls(nodes=data["nodes"], cells=data["cells"],
                   groups={name: tuple(dim_tag) for name, dim_tag in data["groups"].items()},
                   mass_properties=data["mass_properties"])
