"""The picture of a system run (``system.h5``, ``app.system_run``): the joints' force
magnitudes over time, a panel per family of joints (names that differ only in a trailing
number: main_0 … main_4, big_end_1 … big_end_4), and the drives' torques — the bearing, pin
and guide forces a person looks at first (the moments are in ``system.h5``). Drawn after the
run's files are published; one that cannot be drawn is a warning, never the run's loss (as
``app.plots``). Matplotlib (Agg) is imported here only."""
from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np

from gcms_fenicsx.app.plots import PLOT_ROWS, pyplot, save_figure
from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.runtime.progress import Progress, quiet

PICTURE = "system_joints.png"


def family(joint: str) -> str:
    """The joint's name without a trailing number (and the ``_`` or ``-`` before it)."""
    return re.sub(r"[_-]?\d+$", "", joint) or joint


def plot_joints(system: Path, path: Path) -> None:
    """|force| (N) of every joint over time, a panel per :func:`family`, and each drive's
    torque (N·m), every k-th recorded row (at most ``PLOT_ROWS``)."""
    panels: dict[str, dict[str, np.ndarray]] = {}
    torques: dict[str, np.ndarray] = {}
    with h5py.File(system, "r") as f:
        stride = max(1, -(-len(f["time_s"]) // PLOT_ROWS))
        t = f["time_s"][::stride]
        for name, entry in f.get("joints", {}).items():
            if "force_n" in entry:
                panels.setdefault(family(name), {})[name] = np.linalg.norm(
                    entry["force_n"][::stride], axis=1)
            if "drive_torque_nm" in entry:
                torques[name] = entry["drive_torque_nm"][::stride]
    plt = pyplot()
    count = len(panels) + bool(torques)
    fig, axes = plt.subplots(max(count, 1), 1, figsize=(8, 1.0 + 1.9 * max(count, 1)),
                             sharex=True, squeeze=False)
    axes = axes[:, 0]
    for ax, (stem, series) in zip(axes, panels.items()):
        for name, values in series.items():
            ax.plot(t, values / 1e3, label=name, lw=1)
        ax.set_ylabel(f"{stem}\n|F| (kN)")
    if torques:
        for name, values in torques.items():
            axes[-1].plot(t, values, label=f"{name} drive", lw=1)
        axes[-1].set_ylabel("drive torque\n(N·m)")
    for ax in axes:
        if ax.lines:
            ax.legend(fontsize=7, loc="upper left", ncol=min(len(ax.lines), 5))
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title("joint forces on each joint's first body"
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
