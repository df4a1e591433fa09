"""The body's dolfinx mesh: reading a Gmsh file on one or more ranks, and the record of its
mass properties.

The geometry kernel's mass properties (``geometry.MeshInfo.mass_properties``) are of the
CAD; :class:`MassProperties` built by ``fe.mass_properties`` are integrated over the mesh
the finite elements actually see, so comparing the two checks the mesh (curved order-2
cells included).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import gmsh  # its import resets SIGINT: done first, and undone, by the fe package
import numpy as np
from dolfinx.io import gmshio
from dolfinx.mesh import Mesh, MeshTagsMetaClass
from mpi4py import MPI

from geometry.meshing import gmsh_session

from gcms_fenicsx.runtime.interrupts import reinstall


@dataclass(frozen=True)
class BodyMesh:
    """A distributed dolfinx mesh with the facet tags of its named surface groups."""

    mesh: Mesh
    facet_tags: MeshTagsMetaClass
    groups: dict[str, int]  # surface group name -> facet tag value

    @property
    def order(self) -> int:
        return self.mesh.geometry.cmap.degree


@dataclass(frozen=True)
class MassProperties:
    """Volume, centre of mass and inertia tensor per unit density.

    ``inertia_m5`` is J = ∫ (|r|² I − r rᵀ) dV with r = x − x_c (about the centre of
    mass); multiply by the density for kg·m².
    """

    volume_m3: float
    center_of_mass_m: np.ndarray
    inertia_m5: np.ndarray

    @classmethod
    def from_moments(cls, moments: np.ndarray) -> "MassProperties":
        """From the 4×4 moments P = ∫ [1, x]ᵀ[1, x] dV (volume, first and second moments).

        With V = P00, c = P[0, 1:]/V and S_c = P[1:, 1:] − V c cᵀ (parallel-axis theorem):
        J = tr(S_c) I − S_c.
        """
        volume = float(moments[0, 0])
        center = moments[0, 1:] / volume
        second_c = moments[1:, 1:] - volume * np.outer(center, center)
        inertia = np.trace(second_c) * np.eye(3) - second_c
        return cls(volume_m3=volume, center_of_mass_m=center, inertia_m5=inertia)

    def to_json(self) -> dict:
        return {"volume_m3": self.volume_m3,
                "center_of_mass_m": self.center_of_mass_m.tolist(),
                "inertia_m5": self.inertia_m5.tolist()}


def read_mesh(path: str | Path, groups: dict[str, tuple[int, int]],
              comm: MPI.Comm = MPI.COMM_WORLD) -> BodyMesh:
    """Read a ``.msh`` file on rank 0 and distribute it over ``comm``.

    ``groups`` maps physical-group names to (dim, tag), as ``geometry.MeshInfo.groups``;
    the surface (dim 2) ones are kept as facet-tag values.
    """
    # dolfinx 0.5.2's gmshio.read_from_msh returns an undefined name on the reading rank,
    # so merge the file here and hand the model to gmshio.model_to_mesh ourselves
    if comm.rank == 0:
        with gmsh_session():
            gmsh.merge(str(path))
            mesh, _, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
        reinstall()  # gmsh.finalize resets SIGINT
    else:
        mesh, _, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    surfaces = {name: tag for name, (dim, tag) in groups.items() if dim == 2}
    return BodyMesh(mesh=mesh, facet_tags=facet_tags, groups=surfaces)
