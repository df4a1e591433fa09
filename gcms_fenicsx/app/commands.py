"""What each ``gcms`` verb does: the pipeline's stages it composes, the files it writes on rank 0
and the text it prints.

Every verb reads the study into its plan first (``config.plan``: every choice made once,
refused there if it does not fit), then works in a staging folder that replaces the files
in ``--out`` only when everything succeeded (``files.outputs.staged_output``); each stage
takes its piece of the plan. The stages themselves are ``pipeline``'s, their files
``stage_files``'s, the scene run ``dynamics.run.study_run``'s; this module composes them
and draws the pictures after the results are published.

The stage cache (``stage_cache``): ``--out`` keeps each stage's product with the key of the
tables it depends on — mesh.msh (mesh.json), modes.h5, reduced.h5 — and every verb reuses
what matches and computes what does not (``--fresh``: nothing is reused), saying which in
its progress lines and in the ``stages`` block of the JSON reports it writes
(``stage_files``).
"""
from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

from gcms_fenicsx.app import stage_cache, stage_files, system_plots, system_run
from gcms_fenicsx.app.plots import plot_results
from gcms_fenicsx.config.plan import ScenePlan, StudyPlan
from gcms_fenicsx.config.study import load_config
from gcms_fenicsx.config.system import SystemConfig, built_in_system
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.dynamics.run.study_run import SimulationIncomplete, finished, run_scene
from gcms_fenicsx.files.names import MESH_FILES, MODES_FILES, REDUCE_FILES, SIMULATION_FILES
from gcms_fenicsx.files.outputs import check_out, on_rank0, staged_output, write_json
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.files.stress_nodes import StressNodes
from gcms_fenicsx.runtime.interrupts import Interrupted
from gcms_fenicsx.runtime.progress import Progress, progress_printer

#: What ``gcms simulate`` and ``gcms run`` own in --out (``staged_output``).
SCENE_OWNS = (*REDUCE_FILES, *SIMULATION_FILES)


class PicturesInterrupted(Interrupted):
    """SIGINT or SIGTERM while the pictures were drawn: the run's results (``files``) were
    published before, so ``--out`` holds them; a picture not finished is not there."""

    def __init__(self, signum: int, files: str = "results.h5, summary.json") -> None:
        super().__init__(signum)
        self.files = files


def _world() -> Any:
    from mpi4py import MPI
    return MPI.COMM_WORLD


@contextmanager
def built_stages(plan: StudyPlan, out: Path, fresh: bool, upto: str, owns: tuple[str, ...],
                 comm: Any, progress: Progress) -> Iterator[tuple[Path, stage_files.Built]]:
    """Plan the reuse, stage, build one body's stages up to ``upto`` into the staging folder
    and write the cache manifest; (the folder, what was built), published into ``out`` when
    the ``with`` block ends without an error."""
    on_rank0(comm, check_out, out)
    reuse = comm.bcast(stage_cache.reuse(plan.body, out, upto, fresh, progress)
                       if comm.rank == 0 else None, root=0)
    owned = (*stage_cache.owned_files(reuse, owns), stage_cache.MANIFEST)
    with staged_output(out, comm, owned) as folder:
        built = stage_files.build(plan, folder, progress, comm, reuse, upto)
        if comm.rank == 0:
            stage_cache.write_manifest(out, folder, owned, reuse)
        yield folder, built


def _verb(config: Path | None, out: Path, fresh: bool, upto: str, owns: tuple[str, ...],
          scene: str = "none") -> tuple[list[str], dict | None]:
    """Validate, build up to ``upto`` (:func:`built_stages`) and simulate the scene
    (``scene``: "none", "optional" or "required")."""
    plan = load_config(config).plan
    if scene == "required" and plan.scene is None:
        raise ConfigError.missing("[scene]", "required by gcms simulate: the joints, loads, "
                                  "initial motion and time span to simulate")
    comm = _world()
    progress = progress_printer(comm.rank)
    summary = None
    with built_stages(plan, out, fresh, upto, owns, comm, progress) as (folder, built):
        if scene != "none" and plan.scene is not None:
            summary = on_rank0(comm, scene_files, plan.scene, built.model, folder, progress,
                               built.stages, built.stress)
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

def scene_files(plan: ScenePlan, model: ReducedModel, folder: Path, progress: Progress,
                stages: dict, stress: StressNodes | None = None) -> dict:
    """The simulation stage into folder/results.h5 (``dynamics.run.study_run``; the stresses
    with the stress modes ``stress``), then summary.json with the ``stages`` block; the
    summary."""
    t0 = time.perf_counter()
    summary = run_scene(plan, model, folder, progress, stress)
    stage_files.record_stage(stages, "simulation", "computed", time.perf_counter() - t0)
    summary["stages"] = stages
    write_json(folder / "summary.json", summary)
    return summary


def pictures(out: Path, summary: dict, progress: Progress) -> dict:
    """The pictures of ``out``/results.h5, drawn into ``out`` after the run's results and
    summary.json were published there, and summary.json with their names in ``plots``; a
    picture that cannot be drawn is a warning line (``app.plots``), an interrupt meanwhile
    :class:`PicturesInterrupted`."""
    try:
        drawn = plot_results(out / "results.h5", out, progress)
        summary = dict(summary, plots=drawn)
        write_json(out / "summary.json", summary)
    except Interrupted as exc:
        raise PicturesInterrupted(exc.signum) from exc
    return summary


def simulate(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms simulate``: the reduced model (reused from --out, or built), then the scene."""
    texts, summary = _verb(config, out, fresh, "reduced", SCENE_OWNS, scene="required")
    return finished(texts, summary)


# -- gcms run -----------------------------------------------------------------------------

def run(config: Path | None, out: Path, fresh: bool = False) -> str:
    """``gcms run``: every stage — geometry, mesh, modes, selection, reduced model and, when
    the study has a [scene], the simulation with its plots — each reused from --out when its
    inputs are unchanged (``--fresh``: none). A system study (``[system]``) runs every body's
    stages and then the assembly (:func:`run_system`); without a study, the built-in default,
    the inline-4 crank train (``config.system.built_in_system``)."""
    if config is None:
        return run_system(built_in_system(), out, fresh)
    raw = system_run.system_file(config)
    if raw is not None:
        return run_system(system_run.load_system(config, raw), out, fresh)
    texts, summary = _verb(config, out, fresh, "reduced", SCENE_OWNS, scene="optional")
    if summary is None:
        return "\n".join([*texts, "no [scene] table: the simulation stage was skipped"])
    return finished(texts, summary)


@contextmanager
def system_models(cfg: SystemConfig, out: Path, fresh: bool, comm: Any, progress: Progress
                  ) -> Iterator[tuple[dict[str, ReducedModel], dict[str, dict], list[str]]]:
    """Each flexible body's stages, staged for ``out``/bodies/NAME (its own cache): (the
    reduced model of each flexible body, its stages for summary.json, the stages' lines),
    published when the ``with`` block ends without an error — so a study refused by its
    joints, or a run that fails, leaves ``--out`` as it was. Bodies of the same study and
    joints share the first one's model (``model_of``)."""
    models, stages, texts, first = {}, {}, [], {}
    with ExitStack() as staged:
        for body in cfg.flexible:
            if body.model_key in first:          # the same study and joints: one reduced model
                models[body.name] = models[first[body.model_key]]
                stages[body.name] = {"model_of": first[body.model_key]}
                progress(f"body {body.name}: the model of {first[body.model_key]} (the same "
                         "study and joints)")
                continue
            first[body.model_key] = body.name
            progress(f"body {body.name}: {body.source}")
            folder = out / system_run.BODIES_FOLDER / body.name
            _, built = staged.enter_context(built_stages(body.study.plan, folder, fresh,
                                                         "reduced", REDUCE_FILES, comm,
                                                         progress))
            models[body.name], stages[body.name] = built.model, built.stages
            texts += [f"{body.name}: {line}" for line in built.texts]
        yield models, stages, texts


def run_system(cfg: SystemConfig, out: Path, fresh: bool = False) -> str:
    """A system study: each flexible body's stages (:func:`system_models`), then the assembly
    stepped on rank 0, its files (``system_run.SYSTEM_FILES``) and the bodies' stages
    published into ``out`` together — also when a step failed: its rows up to there, marked
    incomplete, and SimulationIncomplete (exit status 1), as a one-body simulation's."""
    comm = _world()
    progress = progress_printer(comm.rank)
    on_rank0(comm, check_out, out)
    with system_models(cfg, out, fresh, comm, progress) as (models, stages, texts), \
            staged_output(out, comm, system_run.SYSTEM_FILES) as folder:
        summary = on_rank0(comm, system_run.simulate_system, cfg, models, folder, progress)
        if comm.rank == 0:
            summary["stages"] = stages
            write_json(folder / "summary.json", summary)
    if comm.rank == 0:
        try:
            summary = dict(summary, plots=system_plots.draw(out, progress))
            write_json(out / "summary.json", summary)
        except Interrupted as exc:
            raise PicturesInterrupted(exc.signum, "system.h5, summary.json") from exc
    text = "\n".join([*texts, system_run.system_text(summary) if comm.rank == 0 else ""])
    if not summary["complete"]:                  # every rank has it (on_rank0): no collective
        raise SimulationIncomplete(text)         # its rows up to the failed step are written
    return text
