"""What each ``gcms`` verb does: the pipeline's stages it composes, the files it writes on rank 0
and the text it prints.

Every verb validates the whole study first, then works in a staging folder that replaces
the files in ``--out`` only when everything succeeded (``files.outputs.staged_output``).
The stages themselves are ``pipeline``'s; this module adds what belongs to files — the
documents (mesh.json, modes.json, selection.json, summary.json), the provenance of
reduced.h5 (input hash, material, mesh statistics) — and the terminal text. The
finite-element verbs import the finite-element stack when they run: ``gcms simulate`` on a
cached model, and ``simulate_model`` (the standalone integrator's), never do.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

from geometry.params import surface_groups

from gcms_fenicsx import pipeline
from gcms_fenicsx.config.study import REDUCED_MODEL_TABLES, StudyConfig, load_config
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.files.names import MESH_FILES, MODES_FILES, REDUCE_FILES, SIMULATION_FILES
from gcms_fenicsx.files.outputs import on_rank0, staged_output, write_json
from gcms_fenicsx.files.plots import plot_results
from gcms_fenicsx.files.reduced_model import (ReducedModel, ReducedModelError, read_reduced,
                                              write_reduced)
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.progress import Progress, progress_printer, quiet

class SimulationIncomplete(ComputationFailed):
    """The simulation stopped before end_time; its results up to there are written."""


def _world() -> Any:
    from mpi4py import MPI
    return MPI.COMM_WORLD


# -- gcms mesh ----------------------------------------------------------------------------

def _check_groups(cfg: StudyConfig) -> None:
    """SceneError, before anything is meshed, for a scene naming a surface group the body's
    geometry does not have."""
    if cfg.scene is not None:
        cfg.scene.check_groups(surface_groups(cfg.geometry))


def mesh_document(cfg: StudyConfig, product: pipeline.MeshProduct, mass: dict,
                  mass_time_s: float) -> dict:
    """The ``mesh.json`` document: counts, groups, and the mesh's mass properties (``mass``,
    unit density) beside the CAD's."""
    info = product.info.to_json()
    return {
        "nodes": product.info.nodes,
        "cells": product.info.cells,
        "order": cfg.mesh.order,
        "size_m": cfg.mesh.size,
        "volume_m3": mass["volume_m3"],
        "mesh_mass_properties": mass,
        "mass_properties": info["mass_properties"],
        "physical_groups": sorted(product.info.groups),
        "geometry": info,
        "input_digest": cfg.digest("geometry", "mesh"),
        "warnings": list(product.warnings),
        "timings_s": {"geometry_and_mesh": product.wall_time_s, "mesh_integrals": mass_time_s},
    }


def mesh_summary(document: dict) -> str:
    cad = document["mass_properties"]
    return "\n".join([
        f"mesh: {document['nodes']} nodes, {document['cells']} cells (order "
        f"{document['order']}, size {document['size_m']:g} m)",
        f"  volume {document['volume_m3']:.6e} m^3 (CAD {cad['volume_m3']:.6e} m^3)",
        f"  groups: {', '.join(document['physical_groups'])}",
    ])


def mesh(config: Path | None, out: Path) -> str:
    """``gcms mesh``: mesh.msh and mesh.json."""
    from gcms_fenicsx.fe.assembly import assemble_scalar_mass
    from gcms_fenicsx.fe.mass import mass_properties

    cfg = load_config(config)
    _check_groups(cfg)
    comm = _world()
    with staged_output(out, comm, MESH_FILES) as folder:
        product = pipeline.mesh_stage(cfg.geometry, cfg.mesh, folder,
                                      progress_printer(comm.rank), comm)
        body = pipeline.body_mesh(product, comm)
        t0 = time.perf_counter()
        Ms, nodes = assemble_scalar_mass(body.mesh)
        mass = mass_properties(Ms, nodes, 1.0).to_json()
        document = mesh_document(cfg, product, mass, time.perf_counter() - t0)
        if comm.rank == 0:
            write_json(folder / "mesh.json", document)
    return mesh_summary(document)


# -- gcms modes ---------------------------------------------------------------------------

@dataclass(frozen=True)
class ModesFiles:
    """What the modes verbs leave for the next stage, and their text."""

    chain: pipeline.FreeFree
    mesh_document: dict
    text: str


def _check_memory(cfg: StudyConfig, dofs: int, nodes: int, wanted: int) -> None:
    """Refuse (ConfigError) a solve and reduction of ``wanted`` modes on ``dofs`` degrees of
    freedom that would need more memory than this machine has (``fe.memory``)."""
    from gcms_fenicsx.fe import memory
    modes_key = ("[modes] count", cfg.modes.count) if cfg.modes.count is not None else \
        ("[modes] max_frequency_hz", cfg.modes.max_frequency_hz)
    memory.check_memory(memory.memory_estimate(dofs, wanted, nodes),
                        ("[mesh] size", cfg.mesh.size), modes_key)


def modes_files(cfg: StudyConfig, folder: Path, progress: Progress, comm: Any,
                mode_shapes: bool = True) -> ModesFiles:
    """Mesh, assembly and the verified eigen-solve; writes mesh.msh, mesh.json, modes.json
    and, if asked, mode_shapes/ (ParaView). The memory of the whole run is estimated before
    meshing, and again with the real DOF count before the Krylov basis is allocated."""
    from geometry.estimate import estimate_mesh

    from gcms_fenicsx.fe.mode_shapes import frequency_table, modes_report, write_mode_shapes

    _check_groups(cfg)
    estimate = estimate_mesh(cfg.geometry, cfg.mesh)
    _check_memory(cfg, estimate.dofs, estimate.nodes, cfg.modes.count or 1)
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.modes, folder,
                               progress, comm, memory_check=partial(_check_memory, cfg))
    model = chain.assembly.model
    document = mesh_document(cfg, chain.mesh, chain.assembly.mass_properties.to_json(),
                             chain.assembly.mass_time_s)
    timings = {"geometry_and_mesh": chain.mesh.wall_time_s,
               "assembly": chain.assembly.wall_time_s}
    if mode_shapes:
        progress("mode shapes: writing mode_shapes/modes.pvd")
        t0 = time.perf_counter()
        write_mode_shapes(model, chain.modes, folder / "mode_shapes" / "modes.pvd")
        timings["mode_shapes_output"] = time.perf_counter() - t0
    report = modes_report(model, chain.modes, timings)
    if comm.rank == 0:
        write_json(folder / "mesh.json", document)
        write_json(folder / "modes.json", report)
    text = "\n".join([
        mesh_summary(document),
        f"modes: {report['ndofs']} DOFs, {report['rigid_mode_count']} rigid + "
        f"{report['elastic_mode_count']} elastic, max backward error "
        f"{report['max_backward_error']:.1e}, missed {report['missed_eigenvalues']}",
        frequency_table(chain.modes),
    ])
    return ModesFiles(chain, document, text)


def modes(config: Path | None, out: Path) -> str:
    """``gcms modes``: the mesh files, modes.json and the mode shapes (mode_shapes/modes.pvd)."""
    cfg = load_config(config)
    comm = _world()
    with staged_output(out, comm, MODES_FILES) as folder:
        return modes_files(cfg, folder, progress_printer(comm.rank), comm).text


# -- gcms reduce --------------------------------------------------------------------------

def with_provenance(model: ReducedModel, cfg: StudyConfig, mesh_document: dict,
                    ndofs: int) -> ReducedModel:
    """The model as reduced.h5 records it: the input hash of its tables (the cache key),
    the material and the mesh statistics."""
    stats = {key: mesh_document[key] for key in ("nodes", "cells", "order", "volume_m3")}
    material = {"E": cfg.material.E, "nu": cfg.material.nu, "rho": cfg.material.rho}
    return replace(model, input_hash=cfg.digest(*REDUCED_MODEL_TABLES), material=material,
                   mesh=stats | {"ndofs": ndofs})


def reduced_model_files(cfg: StudyConfig, folder: Path, progress: Progress, comm: Any,
                        mode_shapes: bool = True) -> tuple[str, ReducedModel | None]:
    """Every stage up to the reduced model: the files of ``gcms modes``, then reduced.h5 and
    selection.json. The summary text, and the model on rank 0 (None elsewhere)."""
    result = modes_files(cfg, folder, progress, comm, mode_shapes)
    chain = result.chain
    reduction = pipeline.reduction_stage(chain.assembly.model, chain.modes, chain.body,
                                         cfg.selection, progress)
    report = reduction.selection | {"eigensolve_s": chain.modes.timings_s["eigensolve"]}
    model = pipeline.reduced_model(reduction, comm)
    if comm.rank == 0:
        model = with_provenance(replace(model, selection=report), cfg, result.mesh_document,
                                chain.assembly.model.ndofs)
        write_reduced(folder / "reduced.h5", model)
        write_json(folder / "selection.json", report)
    return "\n".join([result.text, selection_summary(report)]), model


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


def reduce(config: Path | None, out: Path) -> str:
    """``gcms reduce``: everything of ``gcms modes``, then reduced.h5 and selection.json."""
    cfg = load_config(config)
    comm = _world()
    with staged_output(out, comm, REDUCE_FILES) as folder:
        text, _ = reduced_model_files(cfg, folder, progress_printer(comm.rank), comm)
    return text


# -- gcms simulate ------------------------------------------------------------------------

def cached_model(cfg: StudyConfig, out: Path, progress: Progress) -> ReducedModel | None:
    """``out/reduced.h5`` if it was made from this study's upstream tables, intact, else None
    (with a progress line saying why it is rebuilt)."""
    path = Path(out) / "reduced.h5"
    if not path.is_file():
        return None
    try:
        model = read_reduced(path)
    except ReducedModelError as exc:
        progress(f"reduced model: {path} cannot be used ({exc}); rebuilding it")
        return None
    if not model.checksummed:
        progress(f"reduced model: {path} has no content checksums (schema "
                 f"{model.schema_version}, an older gcms-fenicsx); rebuilding it")
        return None
    if model.input_hash != cfg.digest(*REDUCED_MODEL_TABLES):
        progress(f"reduced model: {path} was made from other inputs; rebuilding it")
        return None
    progress(f"reduced model: reusing {path} ({model.dofs} coordinates; inputs unchanged)")
    return model


def scene_files(cfg: StudyConfig, model: ReducedModel, folder: Path, progress: Progress,
                plots: bool = True) -> dict:
    """The simulation stage into folder/results.h5, then summary.json and (``plots``) the
    pictures drawn from results.h5; the summary."""
    if cfg.scene is None:
        raise ConfigError.missing("[scene]", "required to simulate: the joints, loads, "
                                  "initial motion and time span")
    results = folder / "results.h5"
    summary = pipeline.simulation_stage(model, cfg.scene, results, progress)
    if plots:
        summary["plots"] = plot_results(results, folder)
    write_json(folder / "summary.json", summary)
    return summary


def simulation_summary(summary: dict) -> str:
    """A few lines on the simulation, for the terminal."""
    state = "complete" if summary["complete"] else f"INCOMPLETE: {summary['message']}"
    return "\n".join([
        f"simulation: {summary['steps']} steps to t = {summary['time_reached_s']:.6g} s, "
        f"{state}",
        f"  {summary['reduced_dofs']} coordinates, {summary['constraint_rows']} constraint rows, "
        f"{_number(summary['steps_per_second'], '.0f')} steps/s, "
        f"{_number(summary['newton_iterations_mean'], '.2f')} Newton iterations per step",
        f"  relative energy drift {_number(summary['energy_drift_rel'], '.2e')}",
    ])


def _number(value: float | None, spec: str) -> str:
    return "n/a" if value is None else format(value, spec)


def finished(texts: list[str], summary: dict) -> str:
    """The command's text with the simulation's summary; SimulationIncomplete carrying it when
    the run stopped early (its files are written by then)."""
    text = "\n".join([*texts, simulation_summary(summary)])
    if not summary["complete"]:
        raise SimulationIncomplete(text)
    return text


def simulate(config: Path | None, out: Path) -> str:
    """``gcms simulate``: the reduced model (cached in --out, or built), then the scene."""
    cfg = load_config(config)
    if cfg.scene is None:
        raise ConfigError.missing("[scene]", "required by gcms simulate: the joints, loads, "
                                  "initial motion and time span to simulate")
    comm = _world()
    progress = progress_printer(comm.rank)
    model = cached_model(cfg, out, progress) if comm.rank == 0 else None
    cached = comm.bcast(model is not None, root=0)
    texts = []
    owns = SIMULATION_FILES if cached else (*REDUCE_FILES, *SIMULATION_FILES)
    with staged_output(out, comm, owns) as folder:
        if not cached:
            text, model = reduced_model_files(cfg, folder, progress, comm, mode_shapes=False)
            texts.append(text)
        summary = on_rank0(comm, scene_files, cfg, model, folder, progress)
    return finished(texts, summary)


def simulate_model(reduced: Path, config: Path, out: Path, progress: Progress = quiet) -> str:
    """``python -m gcms_fenicsx.dynamics``: the study's scene on an exported reduced model,
    serial, NumPy and h5py only (no plots: Matplotlib may be missing as well)."""
    cfg = load_config(config)
    if cfg.scene is None:
        raise ConfigError.missing("[scene]", f"required in {config}")
    model = read_reduced(reduced)
    if not model.checksummed:
        progress(f"note: {reduced} was written before content checksums (schema "
                 f"{model.schema_version}); its contents cannot be verified")
    with staged_output(out, owns=SIMULATION_FILES) as folder:
        summary = scene_files(cfg, model, folder, progress, plots=False)
    return finished([], summary)


# -- gcms run -----------------------------------------------------------------------------

def run(config: Path | None, out: Path) -> str:
    """``gcms run``: every stage — geometry, mesh, modes, selection, reduced model and, when
    the study has a [scene], the simulation with its plots."""
    cfg = load_config(config)
    comm = _world()
    progress = progress_printer(comm.rank)
    summary = None
    with staged_output(out, comm, (*REDUCE_FILES, *SIMULATION_FILES)) as folder:
        text, model = reduced_model_files(cfg, folder, progress, comm)
        if cfg.scene is not None:
            summary = on_rank0(comm, scene_files, cfg, model, folder, progress)
    if summary is None:
        return text + "\nno [scene] table: the simulation stage was skipped"
    return finished([text], summary)
