"""The simulate stage of a study: a reduced model and a scene in, results and pictures out.

``gcms simulate`` reuses ``OUT/reduced.h5`` when its input hash matches the study's
geometry, mesh, material, modes and selection tables — then nothing of the finite-element
stack is imported — and otherwise builds it first (``commands``). The scene runs on rank 0
(the reduced matrices live there).

The simulation streams its results into ``results.h5`` as it runs (memory does not grow
with the number of steps; a run whose results would not fit on the disk is refused before it
starts), and the pictures read from that file what they show. A simulation that stops early
(Newton fails, the state blows up) still writes what it computed, marked incomplete, and the
command then ends with exit status 1.
"""
from __future__ import annotations

from pathlib import Path

from gcms_fenicsx.config import REDUCED_MODEL_TABLES, StudyConfig, load_config
from gcms_fenicsx.errors import ComputationFailed
from gcms_fenicsx.files import REDUCE_FILES, SIMULATION_FILES
from gcms_fenicsx.dynamics.simulate import simulate_to_file
from gcms_fenicsx.outputs import on_rank0, staged_output, write_json
from gcms_fenicsx.plots import plot_results
from gcms_fenicsx.progress import Progress, progress_printer
from gcms_fenicsx.reduced_model import ReducedModel, ReducedModelError, read_reduced
from gcms_fenicsx.validation import ConfigError


class SimulationIncomplete(ComputationFailed):
    """The simulation stopped before end_time; its results up to there are written."""


def cached_model(cfg: StudyConfig, out: Path, progress: Progress) -> ReducedModel | None:
    """``out/reduced.h5`` if it was made from this study's upstream tables, else None."""
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


def run_scene(cfg: StudyConfig, model: ReducedModel, folder: Path,
              progress: Progress, plots: bool = True) -> dict:
    """Simulate ``cfg.scene`` streaming results.h5, then write summary.json and (``plots``) the
    pictures, drawn from results.h5."""
    assert cfg.scene is not None
    results = folder / "results.h5"
    summary = simulate_to_file(model, cfg.scene, results, progress)
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


def simulate_command(config: Path | None, out: Path) -> str:
    """``gcms simulate``: the reduced model (cached or built), then the scene."""
    cfg = load_config(config)
    if cfg.scene is None:
        raise ConfigError.missing("[scene]", "required by gcms simulate: the joints, loads, "
                                  "initial motion and time span to simulate")
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    progress = progress_printer(comm.rank)
    model = cached_model(cfg, out, progress) if comm.rank == 0 else None
    texts = []
    cached = comm.bcast(model is not None, root=0)
    owns = SIMULATION_FILES if cached else (*REDUCE_FILES, *SIMULATION_FILES)
    with staged_output(out, comm, owns) as folder:
        if not cached:
            from gcms_fenicsx.commands import reduced_model_files
            text, model = reduced_model_files(cfg, folder, progress, comm, mode_shapes=False)
            texts.append(text)
        summary = on_rank0(comm, run_scene, cfg, model, folder, progress)
    return finished(texts, summary)


def finished(texts: list[str], summary: dict) -> str:
    """The command's text with the simulation's summary; SimulationIncomplete carrying it when
    the run stopped early (its files are written by then)."""
    text = "\n".join([*texts, simulation_summary(summary)])
    if not summary["complete"]:
        raise SimulationIncomplete(text)
    return text


def _number(value: float | None, spec: str) -> str:
    return "n/a" if value is None else format(value, spec)
