"""What each finite-element ``gcms`` subcommand does: the stages it chains and the files it writes.

Every command validates the whole config first, then works in a staging folder that
replaces the files in ``--out`` only when everything succeeded (``outputs.staged_output``).
``gcms simulate`` lives in ``simulation`` (it needs this module only when the reduced
model is not cached).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from geometry import estimate_mesh

from gcms_fenicsx import budget, eigen, fe
from gcms_fenicsx.config import StudyConfig, load_config
from gcms_fenicsx.files import MESH_FILES, MODES_FILES, REDUCE_FILES, SIMULATION_FILES
from gcms_fenicsx.mesh import BodyMesh
from gcms_fenicsx.modes_io import frequency_table, modes_report, write_mode_shapes
from gcms_fenicsx.outputs import on_rank0, staged_output, write_json
from gcms_fenicsx.pipeline import MeshStage, mesh_report, meshed_body
from gcms_fenicsx.progress import Progress, progress_printer
from gcms_fenicsx.reduce import reduce_body
from gcms_fenicsx.reduced_model import ReducedModel, write_reduced
from gcms_fenicsx.simulation import finished, run_scene


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
    with staged_output(out, comm, MESH_FILES) as folder:
        stage, body = meshed_body(cfg, folder, progress_printer(comm.rank), comm)
        Ms, nodes = fe.assemble_scalar_mass(body.mesh)
        report = _write_mesh_json(cfg, folder, stage, Ms, nodes, 1.0, comm)
    return _mesh_summary(report)


def _check_memory(cfg: StudyConfig, dofs: int, nodes: int, wanted: int) -> None:
    """Refuse (ConfigError) a solve and reduction of ``wanted`` modes on ``dofs`` degrees of
    freedom that would need more memory than this machine has (``budget``)."""
    modes_key = ("[modes] count", cfg.modes.count) if cfg.modes.count is not None else \
        ("[modes] max_frequency_hz", cfg.modes.max_frequency_hz)
    budget.check_memory(budget.memory_estimate(dofs, wanted, nodes),
                        ("[mesh] size", cfg.mesh.size), modes_key)


@dataclass(frozen=True)
class _ModesResult:
    body: BodyMesh
    model: fe.FEModel
    modes: eigen.Modes
    mesh_json: dict
    summary: str


def _modes_files(cfg: StudyConfig, folder: Path, progress: Progress, comm: MPI.Comm,
                 mode_shapes: bool = True) -> _ModesResult:
    """Mesh, assembly and the verified eigen-solve; writes the mesh files, modes.json and, if
    asked, mode_shapes/ (ParaView). The memory of the whole run is estimated before meshing."""
    estimate = estimate_mesh(cfg.geometry, cfg.mesh)
    _check_memory(cfg, estimate.dofs, estimate.nodes, cfg.modes.count or 1)
    stage, body = meshed_body(cfg, folder, progress, comm)
    progress(f"assembly: K, M and Ms on {stage.info.nodes} nodes")
    t0 = time.perf_counter()
    model = fe.assemble(body.mesh, cfg.material)
    timings = {"geometry_and_mesh": stage.wall_time_s, "assembly": time.perf_counter() - t0}
    progress(f"assembled K, M: {model.ndofs} DOFs")
    mesh_json = _write_mesh_json(cfg, folder, stage, model.Ms, model.nodes, cfg.material.rho,
                                 comm)
    result = eigen.solve_free_free(
        model, cfg.modes, progress,
        memory_check=lambda wanted: _check_memory(cfg, model.ndofs, model.num_nodes, wanted))
    if mode_shapes:
        progress("mode shapes: writing mode_shapes/modes.pvd")
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
    with staged_output(out, comm, MODES_FILES) as folder:
        result = _modes_files(cfg, folder, progress_printer(comm.rank), comm)
    return result.summary


def reduced_model_files(cfg: StudyConfig, folder: Path, progress: Progress, comm: MPI.Comm,
                        mode_shapes: bool = True) -> tuple[str, ReducedModel | None]:
    """Every stage up to the reduced model: the files of ``gcms modes``, then reduced.h5 and
    selection.json. Returns the summary text and the model (on rank 0; None elsewhere)."""
    result = _modes_files(cfg, folder, progress, comm, mode_shapes)
    progress("GCMS fields, selection and reduced matrices")
    stats = {key: result.mesh_json[key] for key in ("nodes", "cells", "order", "volume_m3")}
    stats["ndofs"] = result.model.ndofs
    reduced, report = reduce_body(result.model, result.modes, result.body, cfg, stats)
    report["eigensolve_s"] = result.modes.timings_s["eigensolve"]
    if comm.rank == 0:
        write_reduced(folder / "reduced.h5", reduced)
        write_json(folder / "selection.json", report)
    return "\n".join([result.summary, selection_summary(report)]), reduced


def reduce(config: Path | None, out: Path) -> str:
    """``gcms reduce``: everything of ``gcms modes``, then reduced.h5 and selection.json."""
    cfg = load_config(config)
    comm = MPI.COMM_WORLD
    with staged_output(out, comm, REDUCE_FILES) as folder:
        text, _ = reduced_model_files(cfg, folder, progress_printer(comm.rank), comm)
    return text


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
    """``gcms run``: every stage — geometry, mesh, modes, selection, reduced model and, when
    the study has a [scene], the simulation with its plots."""
    cfg = load_config(config)
    comm = MPI.COMM_WORLD
    progress = progress_printer(comm.rank)
    summary = None
    with staged_output(out, comm, (*REDUCE_FILES, *SIMULATION_FILES)) as folder:
        text, model = reduced_model_files(cfg, folder, progress, comm)
        if cfg.scene is not None:
            summary = on_rank0(comm, run_scene, cfg, model, folder, progress)
    if summary is None:
        return text + "\nno [scene] table: the simulation stage was skipped"
    return finished([text], summary)
