"""The time loop of a run: step, record, report progress — with the NumPy step, or with the
compiled one in stretches (``stepping.kernel``), which hands the steps it does not take to
the NumPy step. A failed step ends the loop; the run is then incomplete, with the message."""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

from gcms_fenicsx.config.scene import SceneError
from gcms_fenicsx.dynamics.run.capacity import format_duration
from gcms_fenicsx.dynamics.run.recorder import Recorder
from gcms_fenicsx.dynamics.stepping.errors import IntegrationError
from gcms_fenicsx.dynamics.stepping.integrator import GeneralizedAlpha
from gcms_fenicsx.dynamics.stepping.kernel import (STRETCH_STEPS, CompiledStepper, KernelChoice,
                                                   requested)
from gcms_fenicsx.dynamics.stepping.state import State, StepInfo
from gcms_fenicsx.runtime.progress import Progress

PROGRESS_INTERVAL_S = 2.0


@dataclass(frozen=True)
class Start:
    """What the loop starts from: the stepper, the initial state and its step's info, the
    number of steps, the steps with field snapshots, and the scene's end time."""

    integrator: GeneralizedAlpha
    state: State
    info: StepInfo
    steps: int
    snapshot_steps: frozenset[int]
    end_time_s: float


@dataclass(frozen=True)
class Stepped:
    """How the time loop ended: the last converged state and what its step left."""

    complete: bool
    message: str
    steps: int
    newton_iterations: int
    wall_s: float
    state: State
    info: StepInfo


def warm_up(choice: KernelChoice, stepper: CompiledStepper | None, recorder: Recorder,
            state: State, progress: Progress, setting: str
            ) -> tuple[KernelChoice, CompiledStepper | None]:
    """The kernel compiled (the first run on a machine) or loaded from its cache, said in one
    line; the choice with its time, and the stepper (None: NumPy steps). A kernel that does
    not compile leaves the run to NumPy, saying why, unless the scene insists on Numba."""
    if stepper is None:
        if choice.reason != "asked for":
            progress(f"simulate: stepping in NumPy ({choice.reason})")
        return choice, None
    progress("simulate: compiling the step kernel with Numba, or loading it from its cache")
    try:
        seconds, cached = stepper.warm_up(recorder, state)
    except Exception as exc:   # Numba's errors have no common base class but Exception
        why = f"the kernel did not compile: {type(exc).__name__}: {str(exc).splitlines()[0]}"
        if requested(setting) == "numba":
            raise SceneError(f'[scene.solver] kernel = "numba": {why}') from exc
        progress(f"warning: simulate: stepping in NumPy ({why})")
        return KernelChoice("numpy", why), None
    if cached is None:
        return replace(choice, compile_s=0.0), stepper
    progress(f"simulate: step kernel {'loaded from its cache' if cached else 'compiled'} in "
             f"{seconds:.1f} s" + ("" if cached else " (cached for the next runs)"))
    return replace(choice, compile_s=seconds, cached=cached), stepper


def march(start: Start, recorder: Recorder, progress: Progress,
          stepper: CompiledStepper | None = None) -> Stepped:
    """Steps 1 … ``start.steps``, each accounted for and recorded as due; with ``stepper``,
    stretches of compiled steps up to the next field snapshot, a full block of recorded rows
    or ``STRETCH_STEPS``, a step the kernel hands over taken by the NumPy step (which also
    says why a step fails)."""
    state, info, steps = start.state, start.info, start.steps
    complete, message, index, iterations = True, "", 0, 0
    snapshots = sorted(start.snapshot_steps)
    begin = last_report = time.perf_counter()
    while index < steps:
        if stepper is not None:
            stop = min(steps, index + STRETCH_STEPS,
                       next((k for k in snapshots if k > index), steps))
            status, taken, reached, reached_info, its = stepper.stretch(state, index, stop,
                                                                        recorder)
            if taken:
                state, info = reached, reached_info
                index += taken
                iterations += its
                recorder.snapshot(index, state)
            if status == stepper.block_full:
                recorder.flush()
            numpy_step = status == stepper.handed_over
        if stepper is None or numpy_step:
            try:
                state, info = start.integrator.step(state)
            except IntegrationError as exc:
                complete, message = False, str(exc)
                break
            index += 1
            iterations += info.iterations
            recorder.step(index, state, info, last=index == steps)
        now = time.perf_counter()
        if now - last_report > PROGRESS_INTERVAL_S:
            last_report = now
            progress(progress_line(state.t, start.end_time_s, index, steps, now - begin))
    return Stepped(complete=complete, message=message, steps=index,
                   newton_iterations=iterations, wall_s=time.perf_counter() - begin,
                   state=state, info=info)


def progress_line(t: float, end_time: float, index: int, steps: int, elapsed: float) -> str:
    """Where a run is, how fast it goes and when it ends (the rate so far)."""
    rate = index / elapsed if elapsed > 0 else float("inf")
    return (f"simulate: t = {t:.4g} / {end_time:g} s ({index} of {steps} steps, {rate:.0f} "
            f"steps/s, ETA {format_duration((steps - index) / rate)})")
