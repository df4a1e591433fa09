"""What each ``gcms`` subcommand does: the stages it chains and the files it writes.

Every command validates the whole config first, then works in a staging folder that
replaces the files in ``--out`` only when everything succeeded (``outputs.staged_output``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from gcms_fenicsx import eigen, fe
from gcms_fenicsx.config import StudyConfig, load_config
from gcms_fenicsx.mesh import BodyMesh, read_mesh
from gcms_fenicsx.modes_io import frequency_table, modes_report, write_mode_shapes
from gcms_fenicsx.outputs import staged_output, write_json
from gcms_fenicsx.pipeline import MeshStage, Progress, mesh_report, mesh_stage, progress_printer
from gcms_fenicsx.reduce import reduce_body
from gcms_fenicsx.reduced_model import write_reduced


def _write_mesh_json(cfg: StudyConfig, folder: Path, stage: MeshStage, Ms: PETSc.Mat,
                     nodes: np.ndarray, rho: float, comm: MPI.Comm) -> dict:
    """mesh.json, with the mesh's own mass properties from the scalar mass matrix Ms (density rho)."""
    t0 = time.perf_counter()
    mass = fe.mass_properties(Ms, nodes, rho)
    report = mesh_report(cfg, stage, mass.to_json(), time.perf_counter() - t0)
    if comm.rank == 0:
        write_json(folder / "mesh.json", report)
    return report


def _mesh_summary(report: dict) -> str:
    cad = report["mass_properties"]
    return "\n".join([
        f"mesh: {report['nodes']} nodes, {report['cells']} cells (order {report['order']}, "
        f"size {report['size_m']:g} m)",
        f"  volume {report['volume_m3']:.6e} m^3 (CAD {cad['volume_m3']:.6e} m^3)",
        f"  groups: {', '.join(report['physical_groups'])}",
    ])


def mesh(config: Path | None, out: Path) -> str:
    """``gcms mesh``: mesh.msh and mesh.json."""
    cfg = load_config(config)
    comm = MPI.COMM_WORLD
    with staged_output(out, comm) as folder:
        stage = mesh_stage(cfg, folder, progress_printer(comm), comm)
        body = read_mesh(stage.msh_path, stage.info.groups, comm)
        Ms, nodes = fe.assemble_scalar_mass(body.mesh)
        report = _write_mesh_json(cfg, folder, stage, Ms, nodes, 1.0, comm)
    return _mesh_summary(report)


@dataclass(frozen=True)
class _ModesResult:
    body: BodyMesh
    model: fe.FEModel
    modes: eigen.Modes
    mesh_json: dict
    summary: str


def _modes_files(cfg: StudyConfig, folder: Path, progress: Progress,
                 comm: MPI.Comm) -> _ModesResult:
    """Mesh, assembly and the verified eigen-solve; writes the mesh files, modes.json, mode_shapes/."""
    stage = mesh_stage(cfg, folder, progress, comm)
    body = read_mesh(stage.msh_path, stage.info.groups, comm)
    t0 = time.perf_counter()
    model = fe.assemble(body.mesh, cfg.material)
    timings = {"geometry_and_mesh": stage.wall_time_s, "assembly": time.perf_counter() - t0}
    progress(f"assembled K, M: {model.ndofs} DOFs")
    mesh_json = _write_mesh_json(cfg, folder, stage, model.Ms, model.nodes, cfg.material.rho,
                                 comm)
    result = eigen.solve_free_free(model, cfg.modes, progress)
    t0 = time.perf_counter()
    write_mode_shapes(model, result, folder / "mode_shapes" / "modes.pvd")
    timings["mode_shapes_output"] = time.perf_counter() - t0
    report = modes_report(model, result, timings)
    if comm.rank == 0:
        write_json(folder / "modes.json", report)
    summary = "\n".join([
        _mesh_summary(mesh_json),
        f"modes: {report['ndofs']} DOFs, {report['rigid_mode_count']} rigid + "
        f"{report['elastic_mode_count']} elastic, max residual "
        f"{report['max_relative_residual']:.1e}, missed {report['missed_eigenvalues']}",
        frequency_table(result),
    ])
    return _ModesResult(body, model, result, mesh_json, summary)


def modes(config: Path | None, out: Path) -> str:
    """``gcms modes``: the mesh files, modes.json and the mode shapes (mode_shapes/modes.pvd)."""
    cfg = load_config(config)
    comm = MPI.COMM_WORLD
    with staged_output(out, comm) as folder:
        result = _modes_files(cfg, folder, progress_printer(comm), comm)
    return result.summary


def reduce(config: Path | None, out: Path) -> str:
    """``gcms reduce``: everything of ``gcms modes``, then reduced.h5 and selection.json."""
    cfg = load_config(config)
    comm = MPI.COMM_WORLD
    progress = progress_printer(comm)
    with staged_output(out, comm) as folder:
        result = _modes_files(cfg, folder, progress, comm)
        progress("GCMS fields, selection and reduced matrices")
        stats = {key: result.mesh_json[key] for key in ("nodes", "cells", "order", "volume_m3")}
        stats["ndofs"] = result.model.ndofs
        reduced, report = reduce_body(result.model, result.modes, result.body, cfg, stats)
        report["eigensolve_s"] = result.modes.timings_s["eigensolve"]
        if comm.rank == 0:
            write_reduced(folder / "reduced.h5", reduced)
            write_json(folder / "selection.json", report)
    return "\n".join([result.summary, selection_summary(report)])


def selection_summary(report: dict) -> str:
    """A few lines on what the selection kept and what it did to conditioning and frequencies."""
    return "\n".join([
        f"selection: {report['columns_before']} -> {report['columns_after']} GCMS columns "
        f"({len(report['fields_dropped'])} fields dropped)",
        f"  cond(Phi) {report['cond_phi_before']:.2e} -> {report['cond_phi_after']:.2e}, "
        f"cond(Mr) {report['cond_mr_before']:.2e} -> {report['cond_mr_after']:.2e}",
        f"  max relative frequency error (pruning) {report['max_rel_frequency_error']:.2e}; "
        f"selection + reduction {report['timings_s']['selection_and_reduction']:.2f} s",
    ])


def run(config: Path | None, out: Path) -> str:
    """``gcms run``: every stage built so far (geometry, mesh, modes, selection, reduced model)."""
    return reduce(config, out)
