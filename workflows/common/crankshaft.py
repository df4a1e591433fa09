"""The default crankshaft scene's outputs and the study chain of the sweeps, shared by
``auto_modes``, ``bench_rotor``, ``rotor_fewest``, ``pareto`` and ``crankshaft_reference``.

The outputs are the nose's whirl (``end_x0`` position across the shaft, y and z), the bearing
forces (both bearings, three components each) and the drive torque; a run is compared with a
reference as the flexible pendulum compares its tip: max_t |y − y_ref| / max_t |y_ref|.
"""
from __future__ import annotations

import time
import tomllib
from pathlib import Path
from typing import Any

OUTPUTS = ("nose whirl", "bearing forces", "drive torque")
#: The errors are also given from this time on (``crankshaft_reference``): with loads applied
#: at once the first recorded sample holds the multipliers consistent with them (index 3),
#: which a reduced body spreads over its modes and the full model keeps local, not the
#: dynamics. The default scene's loads now rise in from rest, and the two measures agree.
START_S = 1e-3
#: The two bases every reduced model runs in.
BASES = ("full", "rotor")


def outputs(results: Path | Any) -> dict[str, Any]:
    """The scene's outputs of interest from results.h5 (a path, or the file as
    ``read_results`` returned it), per output a (time, components) array."""
    import numpy as np

    from gcms_fenicsx.files.results import joint_force, read_results

    r = read_results(results) if isinstance(results, Path) else results
    torque = [i for i, row in enumerate(r.rows) if row["kind"] == "drive_moment"]
    return {"nose whirl": r.groups["end_x0"]["position"][:, 1:],
            "bearing forces": np.hstack([joint_force(r.rows, r.multipliers, j)
                                         for j in ("front_bearing", "rear_bearing")]),
            "drive torque": -r.multipliers[:, torque]}


def errors(run: dict, reference: dict) -> dict[str, float]:
    """max_t |y − y_ref| / max_t |y_ref| per output, and their maximum."""
    import numpy as np
    out = {name: float(np.abs(run[name] - reference[name]).max() / np.abs(reference[name]).max())
           for name in OUTPUTS}
    return dict(out, maximum=max(out.values()))


def after_start(out: dict, time: Any) -> dict:
    """The outputs from START_S on."""
    late = time >= START_S
    return {k: out[k][late] for k in OUTPUTS}


def on_times(out: dict, t: Any, t_ref: Any) -> dict:
    """Outputs recorded at times ``t`` interpolated to ``t_ref``."""
    import numpy as np

    return {k: np.stack([np.interp(t_ref, t, v[:, j]) for j in range(v.shape[1])], axis=1)
            for k, v in out.items()}


def default_study(**tables: Any) -> dict:
    """The built-in study's tables (``gcms run`` without a file), ``tables`` replacing theirs."""
    from gcms_fenicsx.config.study import default_config_text

    return dict(tomllib.loads(default_config_text()), **tables)


def study(case: str, s: dict[str, Any]) -> dict:
    """The study tables of one run of a sweep: ``case`` "pendulum" (the flexible pendulum) or
    "crankshaft" (the default study), with the settings ``s`` (mesh_size, modes, attachment,
    tolerance, time_step)."""
    from gcms_fenicsx.references import pendulum

    raw = dict(pendulum.STUDY) if case == "pendulum" else default_study()
    mesh = dict(raw.get("mesh", {}))
    if s["mesh_size"] is not None:
        mesh["size"] = s["mesh_size"]
    return dict(raw, mesh=mesh, modes={"count": s["modes"]},
                basis={"attachment": s["attachment"]},
                selection={"svd_tolerance": s["tolerance"], "cosine_tolerance": 1e-12},
                scene=dict(raw["scene"], time_step=s["time_step"]))


def run_chain(raw: dict, folder: Path) -> tuple[Any, Any, float]:
    """Mesh to reduced model through the pipeline's stages: (config, reduced model, seconds)."""
    from gcms_fenicsx.app import pipeline
    from gcms_fenicsx.config.study import parse_config

    cfg = parse_config(raw)
    t0 = time.perf_counter()
    chain = pipeline.free_free(cfg.geometry, cfg.mesh, cfg.material, cfg.plan.body.modes, folder)
    basis = pipeline.basis_stage(chain.assembly.model, chain.modes, chain.body)
    reduced = pipeline.reduction_stage(basis, cfg.selection)
    return cfg, reduced, time.perf_counter() - t0


def shapes_of(cfg) -> dict[str, Any]:
    """The shapes a reduced model runs on: its modes (None), and with attachment modes (which
    make the static shapes exact) the held body's static shapes, by the scene's patterns."""
    from dataclasses import replace

    from gcms_fenicsx.config.basis import scene_patterns

    if not cfg.plan.body.modes.attachment:
        return {"modes": None}
    return {"modes": None,
            "static": scene_patterns(replace(cfg.basis, shapes="static"), cfg.scene)}


def crankshaft_outputs(reduced, cfg, folder: Path, tag: str, basis: str = "full",
                       static=None) -> tuple[dict, float, Any, int]:
    """(outputs, simulation seconds, recorded times, coordinates) of one run in ``basis``
    (on the static shapes of the scene's ``static`` patterns, if given)."""
    from gcms_fenicsx.files.results import read_results
    from gcms_fenicsx.dynamics.run.simulate import simulate_to_file

    path = folder / f"{tag}.h5"
    t0 = time.perf_counter()
    summary = simulate_to_file(reduced, cfg.scene, path, basis=basis,
                               attachment=cfg.plan.body.modes.attachment or (), static=static)
    online = time.perf_counter() - t0
    results = read_results(path)
    return outputs(results), online, results.time, summary["reduced_dofs"]


def percents(e: dict, digits: int = 1) -> str:
    """The three outputs' errors of ``e`` as "a %, b %, c %"."""
    return ", ".join(f"{100 * e[k]:.{digits}f} %" for k in OUTPUTS)
