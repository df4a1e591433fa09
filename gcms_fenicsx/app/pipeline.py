"""The stages of a study as plain functions on plain data (docs/design.md §1).

    mesh_stage ─► body_mesh ─► assembly_stage ─► modes_stage ─► basis_stage
               ─► reduction_stage [─► svk_stage] [─► stress_stage]
               then the scene: dynamics.run.study_run

Each stage takes the tables and products it uses and returns a frozen product; none reads
the whole study, writes a file of a command's or prints anything but progress. ``commands``
composes them for the ``gcms`` verbs, and the workflows and tests build their bodies with
the same functions. The finite-element stages import dolfinx, PETSc and Gmsh when they run,
so this module itself is light: ``gcms simulate`` on a cached model imports none of them.
Collective stages take an MPI communicator (None: the world); small products are the same
on every rank, distributed ones hold each rank's rows.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
from geometry.element_order import element_order_warning
from geometry.estimate import estimate_mesh
from geometry.params import Geometry, MeshParams

from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.modes import ModesConfig
from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.files.outputs import on_rank0
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.files.stress_nodes import StressNodes
from gcms_fenicsx.files.svk_data import SVKCoefficients
from gcms_fenicsx.runtime.progress import Progress, quiet

from geometry.info import MeshInfo

if TYPE_CHECKING:
    from gcms_fenicsx.fe.assembly import FEModel
    from gcms_fenicsx.fe.mesh import BodyMesh, MassProperties
    from gcms_fenicsx.fe.modes import Modes
    from gcms_fenicsx.files.modal_basis import ModalBasis


def _world(comm: Any) -> Any:
    if comm is not None:
        return comm
    from mpi4py import MPI
    return MPI.COMM_WORLD


@dataclass(frozen=True)
class MeshProduct:
    """The meshed body: the ``.msh`` file, what Gmsh reported, warnings, and its build time."""

    msh_path: Path
    info: MeshInfo
    wall_time_s: float
    warnings: tuple[str, ...] = ()


def mesh_stage(geometry: Geometry, mesh: MeshParams, folder: Path, progress: Progress = quiet,
               comm: Any = None) -> MeshProduct:
    """Build the geometry and mesh it on rank 0 (a child process) into ``folder/mesh.msh``;
    every rank gets the product. Refused before meshing when its estimated memory exceeds
    the machine's (``fe.memory``); a P1 mesh predicted to lock is warned."""
    from gcms_fenicsx.fe.memory import check_meshing
    from gcms_fenicsx.fe.meshing import mesh_in_process

    comm = _world(comm)
    path = Path(folder) / "mesh.msh"
    t0 = time.perf_counter()
    estimate = estimate_mesh(geometry, mesh)
    check_meshing(estimate.cells, mesh.size)
    progress(f"geometry and mesh: {type(geometry).__name__}, size {mesh.size:g} m, "
             f"order {mesh.order} (about {estimate.nodes:.2g} nodes)")
    warning = element_order_warning(geometry, mesh)
    if warning:
        progress(f"warning: {warning}")
    info = on_rank0(comm, mesh_in_process, geometry, mesh, path, progress)
    progress(f"mesh: {info.nodes} nodes, {info.cells} cells")
    return MeshProduct(msh_path=path, info=info, wall_time_s=time.perf_counter() - t0,
                       warnings=(warning,) if warning else ())


def body_mesh(product: MeshProduct, comm: Any = None) -> BodyMesh:
    """The meshed body as a distributed dolfinx mesh with its surface groups."""
    from gcms_fenicsx.fe.mesh import read_mesh
    return read_mesh(product.msh_path, product.info.groups, _world(comm))


@dataclass(frozen=True)
class Assembly:
    """K, M and Ms of the body, and the mass properties the mesh integrates (unit density)."""

    model: FEModel
    mass_properties: MassProperties
    wall_time_s: float
    mass_time_s: float


def assembly_stage(mesh: Any, material: Material, degree: int | None = None,
                   progress: Progress = quiet) -> Assembly:
    """Assemble K, M (vector P_k) and Ms (scalar P_k, the same nodes) on a dolfinx mesh
    (``BodyMesh.mesh``); k is the mesh's geometric order unless ``degree`` says otherwise
    (P2 on a straight-edged mesh). Collective."""
    from gcms_fenicsx.fe.assembly import assemble
    from gcms_fenicsx.fe.mass import mass_properties

    progress("assembly: K, M and Ms")
    t0 = time.perf_counter()
    model = assemble(mesh, material, degree)
    t1 = time.perf_counter()
    mass = mass_properties(model.Ms, model.nodes, material.rho)
    progress(f"assembled K, M: {model.ndofs} DOFs")
    return Assembly(model=model, mass_properties=mass, wall_time_s=t1 - t0,
                    mass_time_s=time.perf_counter() - t1)


def modes_stage(model: FEModel, settings: ModesConfig, progress: Progress = quiet,
                memory_check: Callable[[int, int, int], None] | None = None,
                body: BodyMesh | None = None) -> Modes:
    """The six rigid and the requested elastic modes, verified (``fe.eigensolve``), and the
    attachment modes ``settings.attachment`` asks for (at groups of ``body``)."""
    from gcms_fenicsx.fe.eigensolve import solve_free_free
    if not settings.attachment:
        return solve_free_free(model, settings, progress, memory_check)
    from gcms_fenicsx.fe.attachment import load_vectors
    if body is None:
        raise ValueError("attachment modes need the body's node groups: pass body")
    loads = load_vectors(model, body, settings.attachment)
    modes = solve_free_free(model, settings, progress, memory_check, loads)
    return replace(modes, attachment_labels=tuple(a.label for a in settings.attachment))


@dataclass(frozen=True)
class FreeFree:
    """The chain up to the verified free-free modes: mesh, dolfinx mesh, K and M, modes."""

    mesh: MeshProduct
    body: BodyMesh
    assembly: Assembly
    modes: Modes


def free_free(geometry: Geometry, mesh: MeshParams, material: Material, settings: ModesConfig,
              folder: Path, progress: Progress = quiet, comm: Any = None,
              memory_check: Callable[[int, int, int], None] | None = None) -> FreeFree:
    """:func:`mesh_stage`, :func:`body_mesh`, :func:`assembly_stage` and :func:`modes_stage`."""
    product = mesh_stage(geometry, mesh, folder, progress, comm)
    body = body_mesh(product, comm)
    assembly = assembly_stage(body.mesh, material, progress=progress)
    return FreeFree(product, body, assembly,
                    modes_stage(assembly.model, settings, progress, memory_check, body))


def basis_stage(model: FEModel, modes: Modes, body: BodyMesh, progress: Progress = quiet
                ) -> ModalBasis | None:
    """Every GCMS field of the modes with G = Fᵀ Ms F, FᵀF and Kr of all of them and the node
    groups, gathered on rank 0 in the mesh file's node order (None on the other ranks), so
    one and two ranks give the same product (``fe.basis.modal_basis``). Collective."""
    from gcms_fenicsx.fe.basis import modal_basis
    progress("GCMS fields of every mode, their Gram and stiffness matrices")
    return modal_basis(model, modes, body)


def reduction_stage(basis: ModalBasis, settings: SelectionConfig, progress: Progress = quiet
                    ) -> ReducedModel:
    """Selection and the reduced matrices from the modal basis (``reduction.reduce``): NumPy
    on one rank, neither the mesh nor K. Its provenance (input hash, material, mesh
    statistics) is left empty for the caller."""
    from gcms_fenicsx.reduction.reduce import reduce_body
    progress("selection and reduced matrices")
    return reduce_body(basis, settings, progress)


def svk_stage(mesh_file: Path, fields: np.ndarray | None, material: Material,
              progress: Progress = quiet, comm: Any = None
              ) -> tuple[SVKCoefficients | None, dict]:
    """The Saint Venant–Kirchhoff coefficients of the reduced fields F (the mesh file's node
    order, rank 0) on the mesh in ``mesh_file`` (``fe.svk_coefficients``), on rank 0 (None
    on the others), with their report: size, quadrature points, seconds. Collective."""
    from gcms_fenicsx.fe.mesh import read_mesh
    from gcms_fenicsx.fe.svk_coefficients import svk_coefficients
    mesh = read_mesh(mesh_file, {}, _world(comm)).mesh
    return svk_coefficients(mesh, fields, material, progress)


def stress_stage(mesh_file: Path, groups: dict[str, int], stress: StressOutputs,
                 node_count: int, key: str, progress: Progress = quiet, comm: Any = None
                 ) -> StressNodes | None:
    """The stress modes' mesh part for a scene's ``[scene.outputs]`` stresses, on the mesh in
    ``mesh_file`` (its surface groups ``groups``: name → tag): the requested nodes and the
    nodal gradient operator there (``fe.nodal_gradients``), on rank 0 (None on the others).
    Collective."""
    from gcms_fenicsx.fe.mesh import read_mesh
    from gcms_fenicsx.fe.nodal_gradients import stress_nodes
    body = read_mesh(mesh_file, {name: (2, tag) for name, tag in groups.items()},
                     _world(comm))
    return stress_nodes(body, stress, node_count, key, progress)
