"""The stages of a ``gcms`` command, each reused from ``--out`` or computed, and the files they
write into the command's staging folder (docs/design.md §1).

``build`` runs the stages up to the one a verb needs, as ``stage_cache.plan`` decided: the
mesh (mesh.msh, mesh.json), the modes with their modal basis (modes.h5, modes.json and, if
``[outputs]`` asks, mode_shapes/), and the reduced model (reduced.h5, selection.json). A
reused stage writes nothing but the modes.json of the modes it serves; every JSON report
written carries the ``stages`` block: per stage "reused" or "computed" and its seconds.
The finite-element stack is imported only when a finite-element stage runs.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

from geometry.params import surface_groups

from gcms_fenicsx.app import pipeline, stage_cache
from gcms_fenicsx.config.plan import BodyPlan, ScenePlan, StudyPlan
from gcms_fenicsx.files.checksums import file_sha256, sealed_document
from gcms_fenicsx.files.modes_file import StoredModes, write_modes
from gcms_fenicsx.files.outputs import on_rank0, write_json
from gcms_fenicsx.files.reduced_model import ReducedModel, write_reduced
from gcms_fenicsx.files.stress_nodes import StressNodes, write_stress_nodes
from gcms_fenicsx.files.modal_basis import ModalBasis
from gcms_fenicsx.runtime.progress import Progress


@dataclass(frozen=True)
class Built:
    """What a verb's stages produced: the terminal text, the ``stages`` block, the modal basis
    and the reduced model (rank 0; None where not built or on other ranks)."""

    texts: list[str]
    stages: dict[str, dict]
    basis: ModalBasis | None = None
    model: ReducedModel | None = None
    stress: StressNodes | None = None


#: The order of the ``stages`` block.
STAGES = ("mesh", "modes", "mode_shapes", "reduction", "stress_modes", "simulation")


def record_stage(stages: dict[str, dict], name: str, status: str, seconds: float,
           **details: Any) -> None:
    """Record that stage ``name`` was "reused" or "computed" in ``seconds``, in STAGES order."""
    stages[name] = {"status": status, "seconds": round(seconds, 3), **details}
    ordered = sorted(stages.items(), key=lambda item: STAGES.index(item[0]))
    stages.clear()
    stages.update(ordered)


def mesh_document(body: BodyPlan, product: pipeline.MeshProduct, mass: dict,
                  mass_time_s: float) -> dict:
    """The ``mesh.json`` document: counts, groups, and the mesh's mass properties (``mass``,
    unit density) beside the CAD's; ``input_digest`` is the mesh cache's key and
    ``mesh_sha256`` the SHA-256 of mesh.msh's bytes (``stage_cache``)."""
    info = product.info.to_json()
    return {
        "nodes": product.info.nodes,
        "cells": product.info.cells,
        "order": body.mesh.order,
        "size_m": body.mesh.size,
        "volume_m3": mass["volume_m3"],
        "mesh_mass_properties": mass,
        "mass_properties": info["mass_properties"],
        "physical_groups": sorted(product.info.groups),
        "geometry": info,
        "input_digest": body.keys.mesh,
        stage_cache.MESH_CHECKSUM: file_sha256(product.msh_path),
        "warnings": list(product.warnings),
        "timings_s": {"geometry_and_mesh": product.wall_time_s, "mesh_integrals": mass_time_s},
    }


def write_mesh_json(folder: Path, document: dict, stages: dict) -> None:
    """``folder``/mesh.json: ``document`` with the ``stages`` block, sealed with its own
    checksum (``files.checksums``) so that it is verifiable without cache.json."""
    write_json(folder / "mesh.json", sealed_document(dict(document, stages=stages)))


def mesh_summary(document: dict) -> str:
    cad = document["mass_properties"]
    return "\n".join([
        f"mesh: {document['nodes']} nodes, {document['cells']} cells (order "
        f"{document['order']}, size {document['size_m']:g} m)",
        f"  volume {document['volume_m3']:.6e} m^3 (CAD {cad['volume_m3']:.6e} m^3)",
        f"  groups: {', '.join(document['physical_groups'])}",
    ])


def _mesh(body: BodyPlan, folder: Path, progress: Progress, comm: Any,
          reuse: stage_cache.Reuse, stages: dict) -> tuple[pipeline.MeshProduct, dict | None]:
    """The mesh product, reused (with its mesh.json document) or built into ``folder``
    (document None: :func:`mesh_document` needs the mesh's mass, which the caller has or
    computes)."""
    if reuse.mesh is not None:
        record_stage(stages, "mesh", "reused", 0.0)
        cached = reuse.mesh
        return (pipeline.MeshProduct(msh_path=cached.msh_path, info=cached.info, wall_time_s=0.0,
                                     warnings=tuple(cached.document.get("warnings", ()))),
                cached.document)
    t0 = time.perf_counter()
    product = pipeline.mesh_stage(body.geometry, body.mesh, folder, progress, comm)
    record_stage(stages, "mesh", "computed", time.perf_counter() - t0)
    return product, None


def _mesh_alone(body: BodyPlan, folder: Path, progress: Progress, comm: Any,
                reuse: stage_cache.Reuse, stages: dict) -> dict:
    """``gcms mesh``: the mesh, and its document with the mass the mesh integrates (unit
    density: the scalar mass matrix of the read mesh)."""
    product, document = _mesh(body, folder, progress, comm, reuse, stages)
    if document is not None:
        return document
    from gcms_fenicsx.fe.assembly import assemble_scalar_mass
    from gcms_fenicsx.fe.mass import mass_properties

    meshed = pipeline.body_mesh(product, comm)
    t0 = time.perf_counter()
    Ms, nodes = assemble_scalar_mass(meshed.mesh)
    mass = mass_properties(Ms, nodes, 1.0).to_json()
    return _document(body, product, mass, time.perf_counter() - t0, comm)


def _document(body: BodyPlan, product: pipeline.MeshProduct, mass: dict, seconds: float,
              comm: Any) -> dict:
    """mesh.json of a mesh built in this command, on every rank."""
    return comm.bcast(mesh_document(body, product, mass, seconds) if comm.rank == 0 else None,
                      root=0)


def _check_memory(body: BodyPlan, dofs: int, nodes: int, wanted: int) -> None:
    """Refuse (ConfigError) a solve and reduction of ``wanted`` modes on ``dofs`` degrees of
    freedom that would need more memory than this machine has (``fe.memory``)."""
    from gcms_fenicsx.fe import memory
    memory.check_memory(memory.memory_estimate(dofs, wanted, nodes),
                        ("[mesh] size", body.mesh.size), body.modes.named())


def _modes(body: BodyPlan, folder: Path, progress: Progress, comm: Any,
           reuse: stage_cache.Reuse, stages: dict, texts: list[str]) -> ModalBasis | None:
    """The modal basis (rank 0): reused from ``--out``/modes.h5 or solved (mesh reused or built),
    with modes.json written either way and the mode shapes when the study asks."""
    if reuse.modes is not None:
        if reuse.mesh is None:
            record_stage(stages, "mesh", "reused", 0.0)
        record_stage(stages, "modes", "reused", 0.0, count=reuse.modes.basis.mode_count)
        stored = reuse.modes
        if body.outputs.mode_shapes:
            _mode_shapes_from_cache(body, folder, progress, comm, reuse, stored, stages)
        if comm.rank == 0:
            document = _with_band(stored.document, body)
            texts.append(_modes_text(document))
            write_json(folder / "modes.json", dict(document, stages=stages))
        return stored.basis
    from geometry.estimate import estimate_mesh

    from gcms_fenicsx.fe.mode_shapes import MODE_SHAPES_FILE, modes_report, write_mode_shapes

    estimate = estimate_mesh(body.geometry, body.mesh)
    _check_memory(body, estimate.dofs, estimate.nodes, body.modes.count or 1)
    if body.svk and body.modes.count is not None:   # the most fields the modes can give
        from gcms_fenicsx.fe.svk_coefficients import check_memory
        from gcms_fenicsx.files.modal_basis import field_names
        check_memory(len(field_names(body.modes.count, len(body.modes.attachment or ()))),
                     comm=comm)
    product, mesh_doc = _mesh(body, folder, progress, comm, reuse, stages)
    t0 = time.perf_counter()
    meshed = pipeline.body_mesh(product, comm)
    assembly = pipeline.assembly_stage(meshed.mesh, body.material, progress=progress)
    if mesh_doc is None:  # with the mass the assembly integrated (per unit density)
        mesh_doc = _document(body, product, assembly.mass_properties.to_json(),
                             assembly.mass_time_s, comm)
    modes = pipeline.modes_stage(assembly.model, body.modes, progress,
                                 memory_check=partial(_check_memory, body), body=meshed)
    t1 = time.perf_counter()
    basis = pipeline.basis_stage(assembly.model, modes, meshed, progress)
    fields_s = time.perf_counter() - t1
    model = assembly.model
    timings = {"geometry_and_mesh": product.wall_time_s, "assembly": assembly.wall_time_s,
               "fields_and_matrices": fields_s}
    record_stage(stages, "modes", "computed", time.perf_counter() - t0,
                 count=modes.elastic_eigenvalues.size)
    if body.outputs.mode_shapes:
        t1 = time.perf_counter()
        progress(f"mode shapes: writing {MODE_SHAPES_FILE}")
        write_mode_shapes(meshed.mesh, comm.bcast(basis.mode_fields() if comm.rank == 0 else None,
                                                root=0), folder / MODE_SHAPES_FILE)
        record_stage(stages, "mode_shapes", "computed", time.perf_counter() - t1)
    report = _with_band(modes_report(model, modes, timings), body)
    report["attachment_modes"] = list(modes.attachment_labels)
    if comm.rank == 0:
        if reuse.mesh is None:
            write_mesh_json(folder, mesh_doc, stages)
        texts.append(mesh_summary(mesh_doc))
        report["mesh"] = {key: mesh_doc[key] for key in ("nodes", "cells", "order", "volume_m3")}
        write_modes(folder / "modes.h5", StoredModes(basis=basis, document=report,
                                                     key=body.keys.modes))
        texts.append(_modes_text(report))
        write_json(folder / "modes.json", dict(report, stages=stages))
    return basis


def _mode_shapes_from_cache(body: BodyPlan, folder: Path, progress: Progress,
                            comm: Any, reuse: stage_cache.Reuse, stored: StoredModes,
                            stages: dict) -> None:
    """Mode shapes of cached modes: the cached mesh read again (collective), nothing solved."""
    from gcms_fenicsx.fe.mode_shapes import MODE_SHAPES_FILE, write_mode_shapes

    product, _ = _mesh(body, folder, progress, comm, reuse, stages)
    t0 = time.perf_counter()
    progress(f"mode shapes: writing {MODE_SHAPES_FILE} from the cached modes")
    meshed = pipeline.body_mesh(product, comm)
    write_mode_shapes(meshed.mesh, stored.basis.mode_fields(), folder / MODE_SHAPES_FILE)
    record_stage(stages, "mode_shapes", "computed", time.perf_counter() - t0)


def _with_band(document: dict, body: BodyPlan) -> dict:
    """modes.json with the band of ``count = "auto"`` (what set it, the modes it holds), or
    without one."""
    document = {key: value for key, value in document.items() if key != "band"}
    if body.modes.band is not None:
        document["band"] = dict(body.modes.band.to_json(),
                                modes=document["elastic_mode_count"])
    return document


def _modes_text(report: dict) -> str:
    band = report.get("band")
    return "\n".join([
        *([f"modes: count = \"auto\": the band up to {band['max_frequency_hz']:.1f} Hz, set by "
           f"the {band['set_by']}, holds {band['modes']}"] if band else []),
        f"modes: {report['ndofs']} DOFs, {report['rigid_mode_count']} rigid + "
        f"{report['elastic_mode_count']} elastic, max backward error "
        f"{report['max_backward_error']:.1e}, missed {report['missed_eigenvalues']}",
        frequency_table(report["elastic_frequencies_hz"]),
    ])


def frequency_table(frequencies_hz: list[float]) -> str:
    """A few lines listing the elastic frequencies, for the terminal."""
    rows = [f"  {i + 1:3d}  {fi:12.4f} Hz" for i, fi in enumerate(frequencies_hz)]
    return "\n".join(["  mode    frequency", *rows]) if rows else "  (no elastic modes)"


def with_provenance(model: ReducedModel, body: BodyPlan, mesh: dict,
                    ndofs: int) -> ReducedModel:
    """The model as reduced.h5 records it: the input hash of its tables (the cache key),
    the material and the mesh statistics."""
    material = {"E": body.material.E, "nu": body.material.nu, "rho": body.material.rho}
    return replace(model, input_hash=body.keys.reduced, material=material,
                   mesh=dict(mesh, ndofs=ndofs))


def selection_summary(report: dict) -> str:
    """A few lines on what the selection kept and what it did to conditioning and frequencies."""
    return "\n".join([
        f"selection: {report['columns_before']} -> {report['columns_after']} GCMS columns "
        f"({len(report['fields_dropped'])} fields dropped)",
        f"  cond(Phi) {report['cond_phi_before']:.2e} -> {report['cond_phi_after']:.2e}, "
        f"cond(Mr) {report['cond_mr_before']:.2e} -> {report['cond_mr_after']:.2e}",
        f"  max relative frequency error (pruning) {report['max_rel_frequency_error']:.2e}; "
        f"selection + reduction {report['timings_s']['selection_and_reduction']:.2f} s",
        *([f"  Saint Venant-Kirchhoff coefficients of {svk['fields']} fields: "
           f"{svk['bytes'] / 1e6:.1f} MB, {svk['quadrature_points']} quadrature points, "
           f"{svk['seconds']:.1f} s"] if (svk := report.get("svk_coefficients")) else []),
    ])


def build(study: StudyPlan, folder: Path, progress: Progress, comm: Any,
          reuse: stage_cache.Reuse, upto: str) -> Built:
    """Run or reuse the stages of the study's body up to ``upto`` ("mesh", "modes" or
    "reduced") into ``folder``, with the stress modes when the scene asks for stresses; the
    scene's groups are checked against its geometry first."""
    built = _build(study, folder, progress, comm, reuse, upto)
    body = study.body
    if upto != "reduced" or body.stress is None:
        return built
    return replace(built, stress=_stress(body, folder, progress, comm, reuse, built))


def _stress(body: BodyPlan, folder: Path, progress: Progress, comm: Any,
            reuse: stage_cache.Reuse, built: Built) -> StressNodes | None:
    """The stress modes' mesh part (rank 0): reused from ``--out``/stress_modes.h5 or formed
    on the mesh the model was made on and written to ``folder``."""
    if reuse.stress is not None:
        record_stage(built.stages, "stress_modes", "reused", 0.0)
        return reuse.stress
    t0 = time.perf_counter()
    mesh_file = reuse.mesh.msh_path if reuse.mesh is not None else folder / "mesh.msh"
    nodes = comm.bcast(built.model.fields.shape[0] if comm.rank == 0 else None, root=0)
    assert body.stress is not None
    stress = pipeline.stress_stage(mesh_file, surface_groups(body.geometry), body.stress,
                                   nodes, body.keys.stress, progress, comm)
    if comm.rank == 0:
        write_stress_nodes(folder / "stress_modes.h5", stress)
        size = (folder / "stress_modes.h5").stat().st_size
        record_stage(built.stages, "stress_modes", "computed", time.perf_counter() - t0,
                     nodes=len(stress.requested), bytes=size)
        built.texts.append(f"stress modes: {len(stress.requested)} nodes, "
                           f"{size / 1e6:.3g} MB, {time.perf_counter() - t0:.1f} s")
    return stress


def _build(study: StudyPlan, folder: Path, progress: Progress, comm: Any,
           reuse: stage_cache.Reuse, upto: str) -> Built:
    """:func:`build` without the stress modes."""
    stages: dict[str, dict] = {}
    texts: list[str] = []
    body = study.body
    check_groups(body, study.scene)
    if upto == "mesh":
        document = _mesh_alone(body, folder, progress, comm, reuse, stages)
        if comm.rank == 0:
            if reuse.mesh is None:
                write_mesh_json(folder, document, stages)
            texts.append(mesh_summary(document))
        return Built(texts, stages)
    if upto == "reduced" and reuse.reduced is not None and not body.outputs.mode_shapes:
        record_stage(stages, "reduction", "reused", 0.0)   # the stages above it were not needed
        texts.append(f"reduced model: reused ({reuse.reduced.dofs} coordinates)")
        return Built(texts, stages, model=reuse.reduced)
    basis = _modes(body, folder, progress, comm, reuse, stages, texts)
    if upto == "modes":
        return Built(texts, stages, basis=basis)
    if reuse.reduced is not None:
        record_stage(stages, "reduction", "reused", 0.0)
        texts.append(f"reduced model: reused ({reuse.reduced.dofs} coordinates)")
        return Built(texts, stages, basis, reuse.reduced)
    t0 = time.perf_counter()
    model = on_rank0(comm, pipeline.reduction_stage, basis, body.selection, progress)
    report = {}
    if body.svk:
        mesh_file = reuse.mesh.msh_path if reuse.mesh is not None else folder / "mesh.msh"
        if "mesh" not in stages:                  # the cached mesh, read for the coefficients
            record_stage(stages, "mesh", "reused", 0.0)
        model, report = _with_svk(body, model, mesh_file, progress, comm)
    record_stage(stages, "reduction", "computed", time.perf_counter() - t0)
    model = on_rank0(comm, _write_reduced, body, folder, model, report, stages, texts)
    return Built(texts, stages, basis, model if comm.rank == 0 else None)


def _with_svk(body: BodyPlan, model: ReducedModel, mesh_file: Path, progress: Progress,
              comm: Any) -> tuple[ReducedModel, dict]:
    """The model with the Saint Venant–Kirchhoff coefficients of its fields, integrated on
    the mesh its modes were solved on (collective), and their report."""
    svk, report = pipeline.svk_stage(mesh_file, model.fields if comm.rank == 0 else None,
                                     body.material, progress, comm)
    return replace(model, svk=svk), report


def _write_reduced(body: BodyPlan, folder: Path, model: ReducedModel, svk_report: dict,
                   stages: dict, texts: list[str]) -> ReducedModel:
    """reduced.h5 and selection.json (with the SVK coefficients' size and time, if any)."""
    modes_doc = json.loads((folder / "modes.json").read_text())
    report = dict(model.selection, eigensolve_s=modes_doc["timings_s"].get("eigensolve"),
                  stages=stages)
    if svk_report:
        report["svk_coefficients"] = svk_report
    model = with_provenance(replace(model, selection=report), body, modes_doc["mesh"],
                            modes_doc["ndofs"])
    write_reduced(folder / "reduced.h5", model)
    write_json(folder / "selection.json", report)
    texts.append(selection_summary(report))
    return model


def check_groups(body: BodyPlan, scene: ScenePlan | None) -> None:
    """SceneError, before anything is meshed, for a scene naming a surface group the body's
    geometry does not have."""
    if scene is not None:
        scene.scene.check_groups(surface_groups(body.geometry))
