"""The picture of a system run (``system.h5``, ``app.system_run``): each joint's force
magnitude over time and, below, its moment's — the bearing, pin and guide forces a person
looks at first. Drawn after the run's files are published; one that cannot be drawn is a
warning, never the run's loss (as ``app.plots``). Matplotlib (Agg) is imported here only."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from gcms_fenicsx.app.plots import PLOT_ROWS, pyplot, save_figure
from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.runtime.progress import Progress, quiet

PICTURE = "system_joints.png"


def plot_joints(system: Path, path: Path) -> None:
    """|force| (N) and |moment| (N·m) of every joint over time, every k-th recorded row (at
    most ``PLOT_ROWS``)."""
    with h5py.File(system, "r") as f:
        stride = max(1, -(-len(f["time_s"]) // PLOT_ROWS))
        t = f["time_s"][::stride]
        series = {name: {key: np.linalg.norm(f[f"joints/{name}/{key}"][::stride], axis=1)
                         for key in f[f"joints/{name}"]} for name in f.get("joints", {})}
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for name, entry in series.items():
        if "force_n" in entry:
            top.plot(t, entry["force_n"], label=name)
        if "moment_nm" in entry:
            bottom.plot(t, entry["moment_nm"], label=name)
    top.set_ylabel("joint force |F| (N)")
    bottom.set_ylabel("joint moment |M| (N·m)")
    bottom.set_xlabel("time (s)")
    for ax in (top, bottom):
        if ax.lines:
            ax.legend(fontsize=8, loc="upper right")
        ax.grid(alpha=0.3)
    top.set_title("joints: force and moment on each joint's first body"
                  + (f" (every {stride}th recorded step)" if stride > 1 else ""))
    save_figure(plt, fig, path)


def draw(folder: Path, warn: Progress = quiet) -> list[str]:
    """``system_joints.png`` of ``folder``/system.h5 into ``folder``: [its name], or [] and a
    warning line when it cannot be drawn."""
    try:
        with atomic_file(folder / PICTURE) as tmp:
            plot_joints(folder / "system.h5", tmp)
    except Exception as exc:  # a picture is never the run's loss
        warn(f"warning: {PICTURE} could not be drawn ({type(exc).__name__}: {exc}); the "
             "run's results are complete without it")
        return []
    return [PICTURE]
