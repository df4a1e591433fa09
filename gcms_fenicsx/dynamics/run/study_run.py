"""A study's scene run on a reduced model: the simulation stage of ``gcms simulate`` and
``gcms run`` (``app.commands``), and the whole of ``python -m gcms_fenicsx.dynamics``, which
runs it on an exported reduced.h5 with NumPy and h5py only.

It takes the scene's piece of the study's plan (``config.plan.ScenePlan``): the scene, the
basis kind, the static shapes' patterns and the attachment loads, decided when the study
was read. The run writes results.h5 (streamed, ``simulate.simulate_to_file``); its summary
goes to summary.json.
"""
from __future__ import annotations

from pathlib import Path

from gcms_fenicsx.config.plan import BodyPlan, ScenePlan
from gcms_fenicsx.config.study import load_config
from gcms_fenicsx.config.scene import SceneError
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.dynamics.run.simulate import simulate_to_file
from gcms_fenicsx.files.modal_basis import holds_attachment_modes
from gcms_fenicsx.files.names import SIMULATION_FILES
from gcms_fenicsx.files.outputs import staged_output, write_json
from gcms_fenicsx.files.reduced_model import ReducedModel, read_reduced
from gcms_fenicsx.files.stress_nodes import StressNodes, read_stress_nodes
from gcms_fenicsx.runtime.errors import ComputationFailed
from gcms_fenicsx.runtime.progress import Progress, quiet


class SimulationIncomplete(ComputationFailed):
    """The simulation stopped before end_time; its results up to there are written."""


def run_scene(plan: ScenePlan, model: ReducedModel, folder: Path,
              progress: Progress = quiet, stress: StressNodes | None = None) -> dict:
    """The scene of ``plan`` on ``model``, its results streamed into folder/results.h5 (and
    stress.xdmf for whole-body stresses, with the stress modes ``stress``); the summary
    (``plots`` empty: pictures are drawn, where they are, after publication)."""
    if plan.shapes is not None and not plan.attachment:
        progress('note: [basis] shapes = "static" without attachment modes ([basis] attachment '
                 f'= "{plan.attachment_setting}"): the static shapes are solved in the span of '
                 "the eigenmodes, not exactly")
    summary = simulate_to_file(model, plan.scene, folder / "results.h5", progress, plan.basis,
                               plan.attachment, plan.shapes, stress)
    return dict(summary, plots=[])


def simulation_text(summary: dict) -> str:
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


def stress_text(summary: dict) -> list[str]:
    """The hot spot's line, when the run recovered stresses."""
    s = summary.get("stress")
    if not s or s.get("peak_von_mises_pa") is None:
        return []
    x, y, z = s["peak_position_m"]
    return [f"  peak von Mises stress {s['peak_von_mises_pa'] / 1e6:.4g} MPa at node "
            f"{s['peak_node']} ({s['peak_group']}, at ({x:.4g}, {y:.4g}, {z:.4g}) m), "
            f"t = {s['peak_time_s']:.4g} s ({s['nodes']} nodes recovered, "
            f"{s['recovery_per_recorded_step_ms']:.3g} ms per recorded step)"]


def _number(value: float | None, spec: str) -> str:
    return "n/a" if value is None else format(value, spec)


def finished(texts: list[str], summary: dict) -> str:
    """The command's text with the simulation's summary; SimulationIncomplete carrying it when
    the run stopped early (its files are written by then)."""
    text = "\n".join([*texts, simulation_text(summary), *stress_text(summary)])
    if not summary["complete"]:
        raise SimulationIncomplete(text)
    return text


def other_study_note(body: BodyPlan, scene: ScenePlan, model: ReducedModel) -> str | None:
    """How a reduced model differs from the one ``gcms reduce`` makes of the study (its input
    hash is another's; the standalone integrator runs it all the same), or None: in
    particular when the study asks for attachment modes (``[basis] attachment``, "auto" with
    a scene) that the model does not hold."""
    if not model.input_hash or body.served_by(model.input_hash):
        return None
    text = ("was made from other inputs than this study's (its input hash differs: "
            "[geometry], [mesh], [material], [modes], [selection] or [basis] attachment)")
    if scene.attachment and not holds_attachment_modes(model.field_names):
        text += (f"; it holds no attachment modes, which [basis] attachment = "
                 f"{scene.attachment_setting!r} asks for at the scene's joints and loads "
                 "(without them a held body's response can be far from its full model: "
                 "docs/attachment-modes.md)")
    return text


def simulate_model(reduced: Path, config: Path, out: Path, progress: Progress = quiet) -> str:
    """``python -m gcms_fenicsx.dynamics``: the study's scene on an exported reduced model,
    serial, NumPy and h5py only (no pictures: Matplotlib may be missing as well)."""
    plan = load_config(config).plan
    if plan.scene is None:
        raise ConfigError.missing("[scene]", f"required in {config}")
    model = read_reduced(reduced)
    stress = None
    if plan.scene.scene.outputs.stress is not None:
        beside = Path(reduced).parent / "stress_modes.h5"
        if not beside.is_file():
            raise SceneError(f"[scene.outputs] stress_groups: the stresses need the stress "
                             f"modes, {beside} (gcms reduce of this study writes them beside "
                             "reduced.h5)")
        stress = read_stress_nodes(beside)
    if not model.checksummed:
        progress(f"note: {reduced} was written before content checksums (schema "
                 f"{model.schema_version}); its contents cannot be verified")
    other = other_study_note(plan.body, plan.scene, model)
    if other:
        progress(f"note: {reduced} {other}; it is simulated as it is")
    with staged_output(out, owns=SIMULATION_FILES) as folder:
        summary = run_scene(plan.scene, model, folder, progress, stress)
        write_json(folder / "summary.json", summary)
    return finished([], summary)
