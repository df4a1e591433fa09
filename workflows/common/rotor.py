"""The rotor basis against the full one on a reduced model (``bench_rotor``, ``rotor_fewest``):
both bases on the scene, alternating, the best of a number of runs each, both again at half
the step, and the floor of a step (the least a generalized-α Newton step of the same
coordinates and constraint rows computes; ``bench_rotor``'s docstring); and their tables."""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

from common import table_head, table_row
from common.crankshaft import BASES, errors, outputs, percents


def run(model, scene, basis: str, attachment: tuple, static=None) -> tuple[dict, dict]:
    """(outputs and their times, summary) of one run of ``scene`` in ``basis`` (on the static
    shapes of the scene's ``static`` patterns, if given)."""
    from gcms_fenicsx.dynamics.run.simulate import simulate

    traj, summary = simulate(model, scene, basis=basis, attachment=attachment, static=static)
    if not summary["complete"]:
        raise SystemExit(f"{basis} basis: {summary['message']}")
    return dict(outputs(traj), time=traj.time), summary


def case(model, scene, repeat: int, attachment: tuple, static=None) -> tuple[dict, dict]:
    """Both bases on ``scene``, alternating, the fastest of ``repeat`` runs each kept; and
    both once at half the step: (row, the fastest runs' outputs and summaries).
    ``attachment``: the loads of the model's attachment modes (the rotor basis makes its own
    from them); ``static``: the scene's patterns of the static shapes, if the bases are on
    them (``config.basis.ScenePatterns``)."""
    half = replace(scene, time_step_s=scene.time_step_s / 2)
    out, summaries = {}, {}
    for _ in range(repeat):
        for basis in BASES:
            o, s = run(model, scene, basis, attachment, static)
            if basis not in summaries or s["wall_time_s"] < summaries[basis]["wall_time_s"]:
                out[basis], summaries[basis] = o, s
    halves = {basis: run(model, half, basis, attachment, static)[0]
              for basis in BASES}
    thinned = {b: {k: v[::2] for k, v in o.items()} for b, o in halves.items()}
    full, rotor = summaries["full"], summaries["rotor"]
    return {
        "coordinates": {"full": full["reduced_dofs"], "rotor": rotor["reduced_dofs"]},
        "steps_per_second": {"full": full["steps_per_second"],
                             "rotor": rotor["steps_per_second"]},
        "speedup": rotor["steps_per_second"] / full["steps_per_second"],
        "floor": floor(summaries),
        "rotor_vs_full": errors(out["rotor"], out["full"]),
        "full_vs_half_step": errors(out["full"], thinned["full"]),
        "rotor_vs_half_step": errors(out["rotor"], thinned["rotor"]),
    }, {"outputs": out, "summaries": summaries}


def skeleton(n: int, m: int, iterations: int) -> Callable[[int], float]:
    """The floor (module docstring) for n coordinates, m rows and ``iterations`` Newton
    iterations per step, on random dense matrices: a function of a step count that runs them
    and returns the µs per step."""
    import time

    import numpy as np

    rng = np.random.default_rng(0)
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    K, C = M.copy(), rng.standard_normal((m, n))
    inverse = np.linalg.inv(np.block([[M + K, C.T], [C, np.zeros((m, m))]]))
    predictor, update = 0.9 * np.eye(4), np.array([[1.0], [0.5], [0.2], [0.1]])
    f, rhs = rng.standard_normal(n), np.zeros(n + m)

    def run(steps: int) -> float:
        Z, lam = np.zeros((4, n)), np.zeros(m)
        t0 = time.perf_counter()
        for _ in range(steps):
            Z = predictor.dot(Z)
            q, acc = Z[0], Z[2]
            for _ in range(iterations):
                rhs[:n] = M.dot(acc)
                rhs[:n] += K.dot(q)
                rhs[:n] -= f
                rhs[:n] += C.T.dot(lam)
                rhs[n:] = C.dot(q)
                d = inverse.dot(rhs)
                Z -= update * d[:n]
                lam -= d[n:]
                math.sqrt(d[:n].dot(d[:n]))
        return (time.perf_counter() - t0) / steps * 1e6
    return run


def floor(summaries: dict, repeat: int = 15, steps: int = 2000) -> dict:
    """The measured µs per step of both bases, their floors (best of ``repeat`` runs of
    ``steps``, the two bases alternating), and the rotor step a speedup of 2 would need
    (module docstring)."""
    bases = BASES
    step = {b: 1e6 / summaries[b]["steps_per_second"] for b in bases}
    runs = {b: skeleton(summaries[b]["reduced_dofs"], summaries[b]["constraint_rows"],
                        max(1, round(summaries[b]["newton_iterations_mean"]))) for b in bases}
    best = dict.fromkeys(bases, math.inf)
    for _ in range(repeat):
        for b in bases:
            best[b] = min(best[b], runs[b](steps))
    return {"step_us": step, "skeleton_us": best,
            "skeleton_ratio": best["full"] / best["rotor"],
            "rotor_step_for_2x_us": step["full"] - step["rotor"]}


def table(rows: list[dict]) -> str:
    """The speed and differences of each row, its floor, and the static shapes' rows against
    the full basis on the modes."""
    def first(r: dict) -> tuple:
        c = r["coordinates"]
        return r["modes"], r["attachment"], r["shapes"], f"{c['full']} → {c['rotor']}"

    lines = table_head("Nm", "attachment", "shapes", "coordinates full → rotor", "steps/s full",
                       "steps/s rotor", "speedup", "rotor vs full (whirl, forces, torque)",
                       "full: h vs h/2", "rotor: h vs h/2")
    for r in rows:
        s = r["steps_per_second"]
        lines.append(table_row(*first(r), f"{s['full']:,.0f}", f"{s['rotor']:,.0f}",
                               f"{r['speedup']:.2f}×", percents(r["rotor_vs_full"]),
                               percents(r["full_vs_half_step"]),
                               percents(r["rotor_vs_half_step"])))
    lines += ["", *table_head("Nm", "attachment", "shapes", "coordinates full → rotor",
                              "µs/step full, rotor", "floor full, rotor", "floor ratio",
                              "rotor step a 2× speedup needs")]
    for r in rows:
        f = r["floor"]
        lines.append(table_row(
            *first(r), f"{f['step_us']['full']:.0f}, {f['step_us']['rotor']:.0f}",
            f"{f['skeleton_us']['full']:.0f}, {f['skeleton_us']['rotor']:.0f}",
            f"{f['skeleton_ratio']:.2f}×", f"{f['rotor_step_for_2x_us']:.0f} µs"))
    static = [r for r in rows if "against_modes" in r]
    if static:
        lines += ["", *table_head("Nm", "static shapes in", "coordinates", "steps/s against "
                                  "the full basis on the modes", "difference from it")]
    for r in static:
        for b in BASES:
            a = r["against_modes"][b]
            lines.append(f"| {r['modes']} | {b} | {r['coordinates'][b]} | "
                         f"{a['speedup']:.2f}× | {percents(a['difference'])} |")
    return "\n".join(lines)

