"""The stages of a study, composed: geometry → mesh → K, M → free-free modes.

Each function takes plain inputs (the validated config, a folder) and returns the next
stage's data; the CLI only chains them inside a staged output folder. Rank 0 runs Gmsh
and writes files; every rank takes part in the finite-element stages.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from geometry import MeshInfo, element_order_warning, estimate_mesh

from gcms_fenicsx.budget import check_meshing
from gcms_fenicsx.config import StudyConfig
from gcms_fenicsx.mesh import BodyMesh, read_mesh
from gcms_fenicsx.meshing_process import mesh_in_process
from gcms_fenicsx.outputs import on_rank0
from gcms_fenicsx.progress import Progress, quiet


@dataclass(frozen=True)
class MeshStage:
    """The meshed body: the ``.msh`` file, what Gmsh reported, and its build time."""

    msh_path: Path
    info: MeshInfo
    wall_time_s: float
    warnings: tuple[str, ...] = ()


def mesh_stage(cfg: StudyConfig, folder: Path, progress: Progress,
               comm: MPI.Comm = MPI.COMM_WORLD) -> MeshStage:
    """Build the geometry and mesh it on rank 0 into ``folder/mesh.msh``; every rank gets the info.

    A scene that names a group the mesh does not have fails here, before any solve.
    """
    path = Path(folder) / "mesh.msh"
    t0 = time.perf_counter()
    estimate = estimate_mesh(cfg.geometry, cfg.mesh)
    check_meshing(estimate.cells, cfg.mesh.size)
    progress(f"geometry and mesh: {type(cfg.geometry).__name__}, size {cfg.mesh.size:g} m, "
             f"order {cfg.mesh.order} (about {estimate.nodes:.2g} nodes)")
    warning = element_order_warning(cfg.geometry, cfg.mesh)
    if warning:
        progress(f"warning: {warning}")
    info = on_rank0(comm, mesh_in_process, cfg.geometry, cfg.mesh, path, progress)
    progress(f"mesh: {info.nodes} nodes, {info.cells} cells")
    if cfg.scene is not None:
        cfg.scene.check_groups(name for name, (dim, _) in info.groups.items() if dim == 2)
    return MeshStage(msh_path=path, info=info, wall_time_s=time.perf_counter() - t0,
                     warnings=(warning,) if warning else ())


def meshed_body(cfg: StudyConfig, folder: Path, progress: Progress = quiet,
                comm: MPI.Comm = MPI.COMM_WORLD) -> tuple[MeshStage, BodyMesh]:
    """:func:`mesh_stage`, then the body as a distributed dolfinx mesh with its physical groups."""
    stage = mesh_stage(cfg, folder, progress, comm)
    return stage, read_mesh(stage.msh_path, stage.info.groups, comm)


def mesh_report(cfg: StudyConfig, stage: MeshStage, fe_mass: dict, volume_time_s: float) -> dict:
    """The ``mesh.json`` document: counts, groups, and the mesh's mass properties beside the CAD's."""
    info = stage.info.to_json()
    return {
        "nodes": stage.info.nodes,
        "cells": stage.info.cells,
        "order": cfg.mesh.order,
        "size_m": cfg.mesh.size,
        "volume_m3": fe_mass["volume_m3"],
        "mesh_mass_properties": fe_mass,
        "mass_properties": info["mass_properties"],
        "physical_groups": sorted(stage.info.groups),
        "geometry": info,
        "input_digest": cfg.digest("geometry", "mesh"),
        "warnings": list(stage.warnings),
        "timings_s": {"geometry_and_mesh": stage.wall_time_s, "mesh_integrals": volume_time_s},
    }
