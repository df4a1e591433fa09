"""Whether a run's results fit the machine, checked before anything is allocated or stepped,
and how long it still takes.

A run that writes a file streams its rows to it, so what must fit is the file: its estimated
size (:attr:`RecordPlan.total_bytes`, uncompressed, so an upper bound) against the free space
where it goes. A run kept in memory must fit in the memory available now. The estimate and the
limit are both in the refusal, which names the key that makes the results large.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from gcms_fenicsx.runtime.machine import available_memory_bytes
from gcms_fenicsx.dynamics.run.recorder import RecordPlan
from gcms_fenicsx.config.scene import Scene, SceneError


@dataclass(frozen=True)
class Capacity:
    """How many bytes the results may take, and what limits them (for messages)."""

    bytes: int
    what: str     # e.g. "free on /data/out" or "of available memory"


def disk_capacity(folder: Path) -> Capacity:
    """The free space of the file system holding ``folder``."""
    return Capacity(shutil.disk_usage(folder).free, f"free on {folder}")


def memory_capacity() -> Capacity:
    """The memory available now (``runtime.machine.available_memory_bytes``)."""
    return Capacity(int(available_memory_bytes()), "of available memory")


#: The most steps a run may take: 30 h of stepping at the fastest rate measured
#: (``FASTEST_STEPS_PER_S``, the crankshaft's rotor basis on its static shapes, README). A
#: run past it (``end_time = 1e12`` at 1 ms with sparse outputs fits any disk, and would
#: report an ETA of millions of days) is refused before it starts.
MAX_STEPS = 10**9
FASTEST_STEPS_PER_S = 9139.0


def check_capacity(plan: RecordPlan, capacity: Capacity, scene: Scene) -> None:
    """SceneError, in one line with the estimate and the limit, if the results of ``plan``
    exceed ``capacity``; it names ``[scene.outputs] field_times`` when the field snapshots are
    most of it, else ``[scene] end_time``. Then :func:`check_steps`."""
    if plan.total_bytes <= capacity.bytes:
        check_steps(plan, scene)
        return
    snapshots = (f" and {len(plan.snapshot_steps)} field snapshots of {plan.nodes} nodes "
                 f"({format_bytes(plan.snapshot_bytes)})" if plan.snapshot_steps else "")
    estimate = (f"{plan.steps:.3g} steps of {scene.time_step_s:g} s record {plan.rows:.3g} rows "
                f"of {plan.row_bytes} B ({format_bytes(plan.series_bytes)}){snapshots}: "
                f"{format_bytes(plan.total_bytes)} of results, more than the "
                f"{format_bytes(capacity.bytes)} {capacity.what}")
    if plan.snapshot_bytes > plan.series_bytes:
        raise SceneError(f"[scene.outputs] field_times = ({len(scene.outputs.field_times)} "
                         f"times): {estimate}; request fewer field times")
    raise SceneError(f"[scene] end_time = {scene.end_time_s:g}: {estimate}; shorten end_time, "
                     f"record fewer rows ([scene.outputs] every = {scene.outputs.every} now) or "
                     "fewer series")


def check_steps(plan: RecordPlan, scene: Scene) -> None:
    """SceneError naming ``[scene] end_time``, in one line, if the run takes more than
    MAX_STEPS steps."""
    if plan.steps <= MAX_STEPS:
        return
    hours = MAX_STEPS / FASTEST_STEPS_PER_S / 3600
    raise SceneError(f"[scene] end_time = {scene.end_time_s:g}: {plan.steps:.3g} steps of "
                     f"{scene.time_step_s:g} s, more than the {MAX_STEPS:.3g} a run may take "
                     f"({hours:.0f} h at {FASTEST_STEPS_PER_S:,.0f} steps/s, the fastest rate "
                     f"measured; this one would take "
                     f"{format_duration(plan.steps / FASTEST_STEPS_PER_S)}): shorten end_time "
                     "or lengthen time_step")


def format_bytes(n: float) -> str:
    """512 B, 1.5 kB, 3.2 GB, … (decimal units)."""
    units = ("B", "kB", "MB", "GB", "TB", "PB", "EB")
    k = 0
    while abs(n) >= 1000 and k < len(units) - 1:
        n, k = n / 1000, k + 1
    return f"{n:.0f} B" if k == 0 else f"{n:.3g} {units[k]}"


def format_duration(seconds: float) -> str:
    """12 s, 4 min 05 s, 3 h 12 min, 4.2 days."""
    if seconds < 60:
        return f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min {int(seconds % 60):02d} s"
    if seconds < 2 * 86400:
        return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"
    return f"{seconds / 86400:.3g} days"
