"""What each ``gcms`` verb does: the pipeline's stages it composes, the files it writes on rank 0
and the text it prints.

Every verb validates the whole study first, then works in a staging folder that replaces
the files in ``--out`` only when everything succeeded (``files.outputs.staged_output``).
The stages themselves are ``pipeline``'s; this module adds what belongs to files — the
documents (mesh.json, modes.json, selection.json, summary.json), the provenance of
reduced.h5 (input hash, material, mesh statistics) — and the terminal text.

The stage cache (``stage_cache``): ``--out`` keeps each stage's product with the key of the
tables it depends on — mesh.msh (mesh.json), modes.h5, reduced.h5 — and every verb reuses
what matches and computes what does not (``--fresh``: nothing is reused), saying which in
its progress lines and in the ``stages`` block of the JSON reports it writes
(``stage_files``).
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from gcms_fenicsx import pipeline, stage_cache, stage_files
from gcms_fenicsx.config.basis import scene_patterns
from gcms_fenicsx.config.study import StudyConfig, load_config
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.files.names import MESH_FILES, MODES_FILES, REDUCE_FILES, SIMULATION_FILES
from gcms_fenicsx.files.outputs import check_out, on_rank0, staged_output, write_json
from gcms_fenicsx.files.plots import plot_results
from gcms_fenicsx.files.reduced_model import ReducedModel, read_reduced
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.interrupts import Interrupted
from gcms_fenicsx.runtime.progress import Progress, progress_printer, quiet

#: What ``gcms simulate`` and ``gcms run`` own in --out (``staged_output``).
SCENE_OWNS = (*REDUCE_FILES, *SIMULATION_FILES)


class SimulationIncomplete(ComputationFailed):
    """The simulation stopped before end_time; its results up to there are written."""


class PicturesInterrupted(Interrupted):
    """SIGINT or SIGTERM while the pictures were drawn: the run's results were published
    before, so ``--out`` holds them; a picture not finished is not there."""


def _world() -> Any:
    from mpi4py import MPI
    return MPI.COMM_WORLD


def _verb(config: Path | None, out: Path, fresh: bool, upto: str, owns: tuple[str, ...],
          scene: str = "none") -> tuple[list[str], dict | None]:
    """Validate, plan the reuse, stage, build up to ``upto`` and simulate the scene
    (``scene``: "none", "optional" or "required")."""
    cfg = load_config(config)
    if scene == "required" and cfg.scene is None:
        raise ConfigError.missing("[scene]", "required by gcms simulate: the joints, loads, "
                                  "initial motion and time span to simulate")
    comm = _world()
    progress = progress_printer(comm.rank)
    on_rank0(comm, check_out, out)
    plan = comm.bcast(stage_cache.plan(cfg, out, upto, fresh, progress) if comm.rank == 0
                      else None, root=0)
    owned = (*stage_cache.owned_files(plan, owns), stage_cache.MANIFEST)
    summary = None
    with staged_output(out, comm, owned) as folder:
        built = stage_files.build(cfg, folder, progress, comm, plan, upto)
        if comm.rank == 0:
            stage_cache.write_manifest(out, folder, owned, plan)
        if scene != "none" and cfg.scene is not None:
            summary = on_rank0(comm, scene_files, cfg, built.model, folder, progress,
                               built.stages)
    if summary is not None and comm.rank == 0:
        summary = pictures(out, summary, progress)
    return built.texts, summary


# -- the verbs ----------------------------------------------------------------------------

def mesh(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms mesh``: mesh.msh and mesh.json."""
    texts, _ = _verb(config, out, fresh, "mesh", MESH_FILES)
    return "\n".join(texts)


def modes(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms modes``: the mesh files, modes.h5, modes.json and (``[outputs] mode_shapes``)
    the mode shapes."""
    texts, _ = _verb(config, out, fresh, "modes", MODES_FILES)
    return "\n".join(texts)


def reduce(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms reduce``: everything of ``gcms modes``, then reduced.h5 and selection.json."""
    texts, _ = _verb(config, out, fresh, "reduced", REDUCE_FILES)
    return "\n".join(texts)


# -- gcms simulate ------------------------------------------------------------------------

def scene_files(cfg: StudyConfig, model: ReducedModel, folder: Path, progress: Progress,
                stages: dict | None = None) -> dict:
    """The simulation stage into folder/results.h5, then summary.json (with the ``stages``
    block; ``plots`` empty until :func:`pictures` draws them); the summary."""
    if cfg.scene is None:
        raise ConfigError.missing("[scene]", "required to simulate: the joints, loads, "
                                  "initial motion and time span")
    results = folder / "results.h5"
    if cfg.basis.shapes == "static" and not cfg.modes.attachment:
        progress('note: [basis] shapes = "static" without attachment modes ([basis] attachment '
                 f'= "{cfg.basis.attachment}"): the static shapes are solved in the span of the '
                 "eigenmodes, not exactly")
    t0 = time.perf_counter()
    summary = pipeline.simulation_stage(model, cfg.scene, results, progress, cfg.basis.kind,
                                        cfg.modes.attachment or (),
                                        scene_patterns(cfg.basis, cfg.scene))
    summary["plots"] = []
    if stages is not None:
        stage_files.record_stage(stages, "simulation", "computed", time.perf_counter() - t0)
        summary["stages"] = stages
    write_json(folder / "summary.json", summary)
    return summary


def pictures(out: Path, summary: dict, progress: Progress) -> dict:
    """The pictures of ``out``/results.h5, drawn into ``out`` after the run's results and
    summary.json were published there, and summary.json with their names in ``plots``; a
    picture that cannot be drawn is a warning line (``files.plots``), an interrupt meanwhile
    :class:`PicturesInterrupted`."""
    try:
        drawn = plot_results(out / "results.h5", out, progress)
        summary = dict(summary, plots=drawn)
        write_json(out / "summary.json", summary)
    except Interrupted as exc:
        raise PicturesInterrupted(exc.signum) from exc
    return summary


def simulation_summary(summary: dict) -> str:
    """A few lines on the simulation, for the terminal."""
    state = "complete" if summary["complete"] else f"INCOMPLETE: {summary['message']}"
    return "\n".join([
        f"simulation: {summary['steps']} steps to t = {summary['time_reached_s']:.6g} s, "
        f"{state}",
        f"  {summary['reduced_dofs']} coordinates ({summary['basis']} basis, "
        f"{summary['elasticity']} elasticity), "
        f"{summary['constraint_rows']} constraint rows, "
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


def simulate(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms simulate``: the reduced model (reused from --out, or built), then the scene."""
    texts, summary = _verb(config, out, fresh, "reduced", SCENE_OWNS, scene="required")
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
    other = other_study_note(cfg, model)
    if other:
        progress(f"note: {reduced} {other}; it is simulated as it is")
    with staged_output(out, owns=SIMULATION_FILES) as folder:
        summary = scene_files(cfg, model, folder, progress)
    return finished([], summary)


def other_study_note(cfg: StudyConfig, model: ReducedModel) -> str | None:
    """How a reduced model differs from the one ``gcms reduce`` makes of the study (its input
    hash is another's; the standalone integrator runs it all the same), or None: in
    particular when the study asks for attachment modes (``[basis] attachment``, "auto" with
    a scene) that the model does not hold."""
    if not model.input_hash or cfg.served_by(model.input_hash):
        return None
    text = ("was made from other inputs than this study's (its input hash differs: "
            "[geometry], [mesh], [material], [modes], [selection] or [basis] attachment)")
    if cfg.modes.attachment and not any(n.startswith("att") for n in model.field_names):
        text += (f"; it holds no attachment modes, which [basis] attachment = "
                 f"{cfg.basis.attachment!r} asks for at the scene's joints and loads (without "
                 "them a held body's response can be far from its full model: README, "
                 "Attachment modes)")
    return text


# -- gcms run -----------------------------------------------------------------------------

def run(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms run``: every stage — geometry, mesh, modes, selection, reduced model and, when
    the study has a [scene], the simulation with its plots — each reused from --out when its
    inputs are unchanged (``--fresh``: none)."""
    texts, summary = _verb(config, out, fresh, "reduced", SCENE_OWNS, scene="optional")
    if summary is None:
        return "\n".join([*texts, "no [scene] table: the simulation stage was skipped"])
    return finished(texts, summary)
