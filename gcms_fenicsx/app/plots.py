"""Pictures of a simulation for a person to look at: a sensor's trajectory, the energies, the
joints' forces and, when the scene asks for stresses, the body coloured by its peak von Mises
stress with the hot spot marked (``stress.png``) and the hot spot's stress over time.

They are drawn from ``results.h5`` and read only what they show — the time, the first output
group, the energies and the multipliers — and of a long run only every k-th recorded row, at
most ``PLOT_ROWS`` of them (a figure is about a thousand pixels wide; the title says k), so
drawing them takes bounded memory whatever the length of the run.

Each picture is drawn to a temporary name and renamed (``files.outputs.atomic_file``), and one
that cannot be drawn is a warning naming it, never an error: the pictures come after the
run's results are published (``commands``), and a figure must not cost the run.

Matplotlib (Agg) is imported when a picture is drawn, not before.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gcms_fenicsx.files.results import MULTIPLIERS, joint_force, open_results
from gcms_fenicsx.files.outputs import atomic_file
from gcms_fenicsx.runtime.progress import Progress, quiet

#: At most this many rows of each series are read for the pictures.
PLOT_ROWS = 20_000


@dataclass(frozen=True)
class StressPlot:
    """The recorded nodes (undeformed, k × 3), their peak von Mises stresses (Pa) and times,
    the hot spot (the node of the largest) with its group and its stress at the rows shown."""

    nodes: np.ndarray
    peak: np.ndarray
    peak_time: np.ndarray
    hot: int
    group: str
    series: np.ndarray


def _stress_plot(f, stride: int) -> StressPlot | None:
    """The stress pictures' data of an open results file, None without stresses."""
    if "stress" not in f:
        return None
    peak = f["stress/peak_von_mises"][()]
    hot = int(np.argmax(peak))
    groups = f["stress/groups"]
    group = next((g for g in groups if hot in groups[g]["nodes"][()]), "")
    return StressPlot(nodes=f["stress/nodes"][()], peak=peak,
                      peak_time=f["stress/peak_time"][()], hot=hot, group=group,
                      series=f["stress/von_mises"][::stride, hot].astype(float))


@dataclass(frozen=True)
class PlotData:
    """What the pictures show, read from results.h5 (every ``stride``-th recorded row)."""

    time: np.ndarray
    sensor: str | None                 # the first output group
    sensor_position: np.ndarray
    energy: dict[str, np.ndarray]
    multipliers: np.ndarray
    rows: list[dict]
    complete: bool
    stride: int
    stress: StressPlot | None = None

    def joint_force(self, joint: str) -> np.ndarray:
        """The force (N) ``joint`` exerts on the body, at the rows shown."""
        return joint_force(self.rows, self.multipliers, joint)

    @property
    def note(self) -> str:
        """What the title says about the rows shown."""
        return "" if self.stride == 1 else f" (one recorded row in {self.stride} shown)"


def read_plot_data(path: Path, max_rows: int = PLOT_ROWS) -> PlotData:
    """The series the pictures need, every k-th row with k = ⌈rows / max_rows⌉; the file is
    the one this run has just written, so its checksums are not read back."""
    with open_results(path, verify=False) as (f, _):
        stride = max(1, math.ceil(len(f["time"]) / max_rows))
        groups = json.loads(f.attrs["scene"])["outputs"]["groups"]   # HDF5 sorts its groups
        sensor = groups[0] if groups else None
        return PlotData(
            time=f["time"][::stride],
            sensor=sensor,
            sensor_position=(f[f"groups/{sensor}/position"][::stride] if sensor
                             else np.zeros((0, 3))),
            energy={n: f[f"energy/{n}"][::stride] for n in f.get("energy", {})},
            multipliers=f[MULTIPLIERS][::stride], rows=json.loads(f.attrs["rows"]),
            complete=bool(f.attrs["complete"]), stride=stride, stress=_stress_plot(f, stride))


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_figure(plt, fig, path: Path) -> None:
    """Write ``fig`` as PNG to ``path`` (a temporary name: the format is not read from it)."""
    try:
        fig.tight_layout()
        fig.savefig(path, dpi=110, format="png")
    finally:
        plt.close(fig)


def plot_trajectory(traj: PlotData, path: Path) -> None:
    """The sensor group's displacement components against time, and its path in the plane
    of its two largest motions."""
    plt = pyplot()
    t, x, sensor = traj.time, traj.sensor_position, traj.sensor
    d = x - x[0]
    scale, unit = (1e3, "mm") if np.abs(d).max() > 1e-4 else (1e6, "µm")
    fig, (left, right) = plt.subplots(1, 2, figsize=(11.5, 4.3))
    for k, name in enumerate("xyz"):
        left.plot(t, scale * d[:, k], label=f"{name}")
    left.set_xlabel("time [s]")
    left.set_ylabel(f"displacement of {sensor} [{unit}]")
    left.legend(loc="best")
    left.grid(alpha=0.3)
    a, b = np.sort(np.argsort(np.ptp(x, axis=0))[::-1][:2])
    right.plot(scale * d[:, a], scale * d[:, b], lw=0.8)
    right.plot([0.0], [0.0], "o", label="start")
    right.set_xlabel(f"{'xyz'[a]} displacement [{unit}]")
    right.set_ylabel(f"{'xyz'[b]} displacement [{unit}]")
    right.set_aspect("equal", adjustable="datalim")
    right.legend(loc="best")
    right.grid(alpha=0.3)
    right.set_title(f"path of {sensor}")
    status = "" if traj.complete else "  (incomplete)"
    fig.suptitle(f"sensor {sensor}{status}{traj.note}")
    save_figure(plt, fig, path)


def plot_energy(traj: PlotData, path: Path) -> None:
    """Kinetic, elastic and gravity energy, the work terms, and the balance error."""
    plt = pyplot()
    e, t = traj.energy, traj.time
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True,
                                      gridspec_kw={"height_ratios": [2.2, 1]})
    top.plot(t, e["kinetic"], label="kinetic")
    top.plot(t, e["elastic"], label="elastic")
    top.plot(t, e["gravity"] - e["gravity"][0], label="gravity (from start)")
    for name in ("load_work", "constraint_work", "damping_dissipation"):
        if np.any(e[name]):
            top.plot(t, e[name], "--", label=name.replace("_", " "))
    top.set_ylabel("energy [J]")
    top.legend(loc="best", fontsize=8)
    top.grid(alpha=0.3)
    bottom.plot(t, e["balance_error"], color="k")
    bottom.set_ylabel("balance error [J]")
    bottom.set_xlabel("time [s]")
    bottom.grid(alpha=0.3)
    top.set_title(f"energies{traj.note}")
    save_figure(plt, fig, path)


def plot_joints(traj: PlotData, path: Path) -> None:
    """The force on the body (magnitude) of every joint that keeps force rows and, when a
    joint constrains a rotation, its moments, against time: a scene of spherical joints only
    gets no moment panel, and a joint whose force rows all went to an earlier joint on its
    group (a revolute after a fixed one) only its moments."""
    plt = pyplot()
    joints = list(dict.fromkeys(r["joint"] for r in traj.rows if r["kind"] == "force"))
    moments = [(i, r) for i, r in enumerate(traj.rows) if r["unit"] == "N*m"]
    panels = 1 + bool(moments) + (traj.stress is not None)
    fig, axes = plt.subplots(panels, 1, figsize=(9, 3.8 + 2.9 * (panels - 1)), sharex=True,
                             squeeze=False)
    top = axes[0, 0]
    for name in joints:
        top.plot(traj.time, np.linalg.norm(traj.joint_force(name), axis=1), label=name)
    top.set_ylabel("|joint force on body| [N]")
    top.set_title(f"joints{traj.note}")
    top.legend(loc="best", fontsize=8)
    top.grid(alpha=0.3)
    if moments:
        bottom = axes[1, 0]
        for i, r in moments:
            axis = np.round(r["axis"], 2).tolist()
            bottom.plot(traj.time, -traj.multipliers[:, i], lw=0.9,
                        label=f"{r['joint']}: {r['kind'].replace('_', ' ')} about {axis}")
        bottom.set_ylabel("moment on body [N·m]")
        bottom.legend(loc="best", fontsize=7)
        bottom.grid(alpha=0.3)
    if traj.stress is not None:
        _hot_spot_series(axes[-1, 0], traj)
    axes[-1, 0].set_xlabel("time [s]")
    save_figure(plt, fig, path)


def _hot_spot_series(ax, traj: PlotData) -> None:
    """The hot spot's von Mises stress against time on ``ax``."""
    s = traj.stress
    assert s is not None
    x, y, z = s.nodes[s.hot]
    ax.plot(traj.time, s.series / 1e6, color="C3")
    ax.set_ylabel("von Mises at hot spot [MPa]")
    ax.set_title(f"hot spot: {s.group} node at ({x:.4g}, {y:.4g}, {z:.4g}) m", fontsize=9)
    ax.grid(alpha=0.3)


def plot_stress(traj: PlotData, path: Path) -> None:
    """The recorded nodes coloured by their peak von Mises stress over the run, the hot spot
    marked, and its stress against time."""
    plt = pyplot()
    s = traj.stress
    assert s is not None
    fig = plt.figure(figsize=(12, 5))
    body = fig.add_subplot(1, 2, 1, projection="3d")
    shown = body.scatter(*s.nodes.T, c=s.peak / 1e6, s=2, cmap="inferno", depthshade=False)
    x, y, z = s.nodes[s.hot]
    body.plot([x], [y], [z], marker="*", ms=20, mfc="cyan", mec="k", ls="none", zorder=10,
              label=f"hot spot: {s.peak[s.hot] / 1e6:.4g} MPa at t = {s.peak_time[s.hot]:.4g} s")
    body.set_box_aspect(np.maximum(np.ptp(s.nodes, axis=0), 1e-9 * np.ptp(s.nodes).max()))
    from matplotlib.ticker import MaxNLocator
    for axis in (body.xaxis, body.yaxis, body.zaxis):     # a slender body's short sides
        axis.set_major_locator(MaxNLocator(3))
    body.tick_params(labelsize=7)
    body.set_xlabel("x [m]")
    body.set_ylabel("y [m]")
    body.set_zlabel("z [m]")
    body.legend(loc="upper left", fontsize=8)
    fig.colorbar(shown, ax=body, shrink=0.7, pad=0.15, label="peak von Mises over the run [MPa]")
    _hot_spot_series(fig.add_subplot(1, 2, 2), traj)
    fig.axes[-1].set_xlabel("time [s]")
    status = "" if traj.complete else "  (incomplete)"
    fig.suptitle(f"stresses at {len(s.peak)} recorded nodes{status}{traj.note}")
    save_figure(plt, fig, path)


#: The pictures in the order they are drawn: name, drawing function, and whether the run's
#: data have what it shows.
PICTURES = (
    ("trajectory.png", plot_trajectory, lambda d: d.sensor is not None),
    ("energy.png", plot_energy, lambda d: bool(d.energy)),
    ("joints.png", plot_joints, lambda d: bool(d.rows)),
    ("stress.png", plot_stress, lambda d: d.stress is not None),
)


def plot_results(results: Path, folder: Path, warn: Progress = quiet) -> list[str]:
    """trajectory.png (first output group), energy.png, joints.png and stress.png of the
    results file ``results`` into ``folder``, where the data exist; the names of those drawn. A picture
    that cannot be drawn (or results that cannot be read for them) is a ``warn`` line naming
    it and the reason, and is not written."""
    try:
        traj = read_plot_data(results)
    except Exception as exc:  # any failure of a picture is a warning, never the run's loss
        warn(f"warning: no pictures drawn: {results} could not be read for them "
             f"({type(exc).__name__}: {exc})")
        return []
    written = []
    for name, draw, shown in PICTURES:
        if not (shown(traj) and len(traj.time) > 1):
            continue
        try:
            with atomic_file(folder / name) as tmp:
                draw(traj, tmp)
        except Exception as exc:
            warn(f"warning: {name} could not be drawn ({type(exc).__name__}: {exc}); the "
                 "run's results are complete without it")
            continue
        written.append(name)
    return written
