"""What the rows say: a paragraph per probe class for docs/stability.md, every number taken
from the rows (a class whose rows lack what its paragraph needs says so)."""
from __future__ import annotations

import math
from itertools import pairwise

import numpy as np

from stress.measures import pair_split, rel
from stress.studies import DRIVE_FACTORS, E_REFERENCE, SQUARE_MODES
from stress.tables import f, good, smallest_margin

EPS = float(np.finfo(float).eps)


def g(v, spec: str = ".1e") -> str:
    """A number in the text ("n/a" for None)."""
    return "n/a" if v is None else format(v, spec)


def every(rows: list[dict], key: str) -> str:
    """"yes" when every row (and at least one) has ``key`` true, else "NO"."""
    return "yes" if rows and all(r.get(key) for r in rows) else "NO"


def changes(rows: list[dict], key: str, x: str = "epsilon") -> list[tuple[float, float, float]]:
    """(x_a, x_b, |v_b / v_a − 1|) for consecutive rows that both have ``key``."""
    pts = [(r[x], r[key]) for r in rows if r.get(key) is not None]
    return [(a, b, rel(vb, va)) for (a, va), (b, vb) in pairwise(pts)]


def verdict(rows: list[dict], key: str, label: str) -> str:
    """Whether ``key`` is continuous in ε. Every ε is meshed afresh, so each step carries the
    mesh-to-mesh variation (a few %); a step is a jump when it changes the value by more than
    max(10 %, 10 Δε) relative (10 % above that variation, a slope of 10 allowed)."""
    steps = changes(rows, key)
    if not steps:
        return f"{label}: not measured"
    vals = [r[key] for r in rows if r.get(key) is not None]
    jumps = [(a, b, c) for a, b, c in steps if c > max(0.1, 10 * (b - a))]
    rest = [c for a, b, c in steps if (a, b, c) not in jumps]
    span = f"{g(min(vals))} … {g(max(vals))}"
    small = f"steps of at most {max(rest):.1%}" if rest else ""
    if not jumps:
        return f"{label} is continuous ({span}; {small})"
    where = "; ".join(f"by {c:.0%} between ε = {a:g} and {b:g}" for a, b, c in jumps)
    return f"{label} jumps {where} ({span}{'; otherwise ' + small if small else ''})"


def span_text(values: list[float], spec: str = ".3g") -> str:
    """The range of ``values`` ("x at every Nm" when they agree to 1e-6)."""
    lo, hi = min(values), max(values)
    return f"{lo:{spec}} at every Nm" if lo == hi or abs(hi / lo - 1) < 1e-6 else \
        f"{lo:{spec}}–{hi:{spec}}"


def selection_text(eps: list[dict]) -> str:
    """How many fields the selection keeps over ε and whether which are dropped changes."""
    counts = [(r["epsilon"], r["fields_kept_count"]) for r in eps]
    count_jumps = [(a, b) for (a, na), (b, nb) in pairwise(counts) if na != nb]
    kept = (f"The number of fields kept is {counts[0][1]} at every ε" if not count_jumps else
            "The number of fields kept changes " + ", ".join(
                f"between ε = {a:g} and {b:g}" for a, b in count_jumps) +
            f" ({', '.join(f'{n} at {e:g}' for e, n in counts)})")
    names = [(r["epsilon"], ", ".join(d["field"] for d in r["fields_dropped"]) or "none",
              ", ".join(g(d.get("relative_residual"), ".0e") for d in r["fields_dropped"]))
             for r in eps]
    name_jumps = [(a[0], b[0]) for a, b in pairwise(names) if a[1] != b[1]]
    groups: list[list] = []
    for e, n, res in names:
        if groups and groups[-1][0] == n:
            groups[-1][2].append(res)
        else:
            groups.append([n, e, [res]])
    which = ("; which fields are dropped does not change" if not name_jumps else
             "; but *which* field is dropped jumps (" + "; ".join(
                 f"{n} from ε = {e:g}, relative residual {' … '.join(dict.fromkeys(rs))}"
                 for n, e, rs in groups) +
             "): the rank comes from the singular values, the choice from a pivoted Cholesky "
             "that breaks the tie of a near-repeated pair either way")
    return f"{kept}{which}."


def mesh_text(eps: list[dict]) -> str:
    """The nodes of each width's mesh and, when they differ, the frequency changes they make."""
    nodes = [(r["epsilon"], r["nodes"]) for r in eps]
    mesh_jumps = [b for (a, na), (b, nb) in pairwise(nodes) if na != nb]
    return ("Gmsh meshes every width afresh: " + ", ".join(f"{n} nodes at ε = {e:g}"
                                                          for e, n in nodes) +
            (f", so from ε = {mesh_jumps[0]:g} the elastic frequencies differ from ε = 0 by "
             "the mesh's own change (largest " + ", ".join(
                 f"{g(r.get('frequency_difference'))} in mode "
                 f"{r.get('frequency_difference_mode')} at ε = {r['epsilon']:g}"
                 for r in eps[1:]) + "), not by ε; the first bending pair moves by " +
             ", ".join(f"{g(r['frequency_differences'][0])} and "
                       f"{g(r['frequency_differences'][1])} at ε = {r['epsilon']:g}"
                       for r in eps[1:] if "frequency_differences" in r) +
             "." if mesh_jumps else "."))


def cut_pair_text(rows: list[dict], eps: list[dict]) -> str | None:
    """The swing with a mode count cutting the third bending pair (None when not measured)."""
    cut = {r["epsilon"]: r for r in good(rows) if r["case"].startswith("Nm")}
    if 1e-6 not in cut or cut[1e-6].get("tip_difference_over_L") is None:
        return None
    ref = next((r.get("tip_difference_over_L") for r in eps if r["epsilon"] == 1e-6), None)
    return (f"A mode count that cuts a near-repeated pair is discontinuous: with Nm = "
            f"{cut[1e-6]['modes']} (the third bending pair's members are modes 6 and 7, "
            f"split {g(pair_split(eps[0]['frequencies_hz'], 5) if eps else None)}"
            f" at ε = 0) the reduced model holds one member, bending in a direction of the y–z "
            f"plane that the mesh's asymmetry picks, and "
            f"the tip trajectory at ε = 1e-6 differs by {g(cut[1e-6]['tip_difference_over_L'])}"
            f" L instead of {g(ref)} L with Nm = {SQUARE_MODES}.")


def text_symmetry(rows: list[dict]) -> str:
    """Class 1: selection, conditioning and pruning over ε, the pair split, the meshes, the
    swing, the cut pair and the square section."""
    eps = sorted((r for r in good(rows) if r["case"].startswith("ε")), key=lambda r: r["epsilon"])
    if not eps:
        return "No result."
    first_pair = [(r["epsilon"], r["pair_split"]) for r in eps]
    sym = next((r for r in good(rows) if r["case"] == "square section"), None)
    tip = [(r["epsilon"], r.get("tip_difference_over_L")) for r in eps[1:]]
    parts = [
        selection_text(eps),
        verdict(eps, "sigma_min", "The smallest singular value") + "; " +
        verdict(eps, "cond_mr_after", "cond(Mr) after selection") +
        "; " + verdict(eps, "pruning_error", "the pruning error") + ".",
        "The first bending pair splits by " + ", ".join(f"{s:.1e} at ε = {e:g}"
                                                         for e, s in first_pair) +
        " (the split of a widened square is ε itself in beam theory; at ε = 0 it is the "
        "unstructured mesh's asymmetry).",
        mesh_text(eps),
        "The pendulum's tip trajectory (0.2 s) differs from ε = 0 by " +
        ", ".join(f"{g(v)} L at ε = {e:g}" for e, v in tip) +
        (": continuous (the swing is about y, which widening along y does not stiffen)."
         if tip and all(v is not None and v < max(e, 1e-8) for e, v in tip) else "."),
    ]
    cut = cut_pair_text(rows, eps)
    if cut is not None:
        parts.append(cut)
    if sym is not None:
        parts.append(f"The `square` section gives the rectangle of equal sides exactly "
                     f"(frequencies {g(sym.get('frequency_difference'))}, "
                     f"same mesh: {f(sym.get('same_mesh_size'))}).")
    return " ".join(parts)


def text_units(rows: list[dict]) -> str:
    """Class 2: every variant against SI, and the mm-t-s swing."""
    rs = [r for r in good(rows) if r["case"] != "SI"]
    ref = next((r for r in good(rows) if r["case"] == "SI"), None)
    if not rs or ref is None:
        return "No result."
    cond = max((r.get(f"{k}_change") or 0) for r in rs for k in ("cond_mr_before",))
    after = max((r.get(f"{k}_change") or 0) for r in rs for k in ("cond_mr_after",
                                                                 "cond_phi_after"))
    sv = max((r.get("singular_values_difference") or 0) for r in rs)
    smin = ref["sigma_smallest"][0] if ref.get("sigma_smallest") else None
    mm = next((r for r in rs if r["case"] == "mm-t-s"), None)
    text = (f"Against SI, every variant has the same mesh ({every(rs, 'same_mesh_size')}) "
            f"and the same fields kept ({every(rs, 'same_fields_kept')}); "
            "frequencies (times the size factor) agree to " +
            ", ".join(f"{g(r.get('frequency_difference'))} ({r['case']})" for r in rs) + ". "
            f"cond(Mr) before selection ({g(ref['cond_mr_before'])}) agrees to {g(cond)}, the "
            f"round-off of a Gram matrix of that condition (ε·cond = "
            f"{g(EPS * ref['cond_mr_before'])}); after selection (and cond(Φ) after) to "
            f"{g(after)}. The singular values agree to {g(sv)}: the smallest, {g(smin)}, is "
            f"the root of a Gram eigenvalue known to ε, so to ε/(2σ²) = "
            f"{g(EPS / (2 * smin ** 2) if smin else None)} relative.")
    if mm is not None:
        text += (f" The mm-t-s pendulum's tip trajectory is the SI one ×1e3 to "
                 f"{g(mm.get('tip_difference_over_L'))} L with "
                 f"{g(mm.get('newton_iterations_mean'), '.2f')} Newton iterations per step "
                 f"(SI {g(ref.get('newton_iterations_mean'), '.2f')}), energy drift "
                 f"{g(mm.get('energy_drift_rel'))} against {g(ref.get('energy_drift_rel'))}; "
                 f"its peak von Mises stresses at the surface nodes (MPa) are the SI ones (Pa) "
                 f"×1e-6 to {g(mm.get('stress_difference'))} of the largest.")
    return text


def loglog_slope(x, y) -> float | None:
    """The exponent p of y ∝ x^p fitted to the positive pairs (None for fewer than two)."""
    pts = [(a, b) for a, b in zip(x, y) if a and b and a > 0 and b > 0]
    if len(pts) < 2:
        return None
    a, b = np.log(np.array(pts).T)
    return float(np.polyfit(a, b, 1)[0])


def power(x, y) -> str:
    """" (∝ Nm^p)" of y against x ("" when not fitted)."""
    p = loglog_slope(x, y)
    return "" if p is None else f" (∝ Nm^{p:.1f})"


def text_slenderness(rows: list[dict]) -> str:
    """Class 3: margins, residuals, frequencies against beam theory and cost over L/h."""
    rs = sorted(good(rows), key=lambda r: r["slenderness"])
    failed = [r for r in rows if r["outcome"] != "ok"]
    if not rs:
        return "No result." + (f" {failed[0]['case']}: {failed[0]['last_stderr']}"
                               if failed else "")
    lh = [r["slenderness"] for r in rs]
    res = [r["max_relative_residual"] for r in rs]
    margin = min((v for r in rs for k, v in r["margins"].items() if v is not None
                  and k != "sylvester"), default=None)
    text = (f"The verified solve passes at every L/h from {lh[0]} to {lh[-1]}"
            + (f" except {', '.join(r['case'] for r in failed)} ("
               + "; ".join(f"exit {r['exit_status']}: {r['last_stderr']}" for r in failed) + ")"
               if failed else "") +
            f"; its smallest margin (limit/measured) is {g(margin)}. The backward error stays "
            f"at {g(min(r['max_backward_error'] for r in rs), '.0e')}–"
            f"{g(max(r['max_backward_error'] for r in rs), '.0e')} while ‖Kφ−λMφ‖/‖Kφ‖ grows "
            f"from {g(res[0])} to {g(res[-1])} (∝ (L/h)^{g(loglog_slope(lh, res), '.1f')}). "
            "The first bending frequency is within " +
            ", ".join(f"{r['error_timoshenko']:+.1e}" for r in rs) +
            " of Timoshenko and " + ", ".join(f"{r['error_euler_bernoulli']:+.1e}" for r in rs) +
            " of Euler–Bernoulli (the shear and rotary-inertia correction fades as (h/L)²). "
            "The eigen-solve takes " + ", ".join(f"{g(r['eigensolve_s'], '.1f')} s" for r in rs) +
            " (" + ", ".join(f"{r['ndofs']:,}" for r in rs) + " DOFs).")
    return text


def text_modes(rows: list[dict]) -> str:
    """Class 4: selection, conditioning, cost and the short scene over Nm, per body."""
    parts = []
    for body in ("beam", "crankshaft"):
        rs = sorted((r for r in good(rows) if r["body"] == body), key=lambda r: r["modes"])
        bad = [r for r in rows if r["body"] == body and r not in rs]
        if not rs:
            if bad:
                parts.append(f"{body}: {bad[0]['case']} ended {bad[0]['outcome']}: "
                             f"{bad[0]['last_stderr']}.")
            continue
        nm = [r["modes"] for r in rs]
        sel = [r["selection_reduction_s"] for r in rs]
        sps = [r["steps_per_second"] for r in rs]
        parts.append(
            f"{body} ({rs[0]['ndofs']:,} DOFs), Nm = {', '.join(map(str, nm))}: columns "
            + ", ".join(f"{r['columns_before']} → {r['columns_after']}" for r in rs) +
            f"; cond(Mr) after {span_text([r['cond_mr_after'] for r in rs])} (before "
            f"{span_text([r['cond_mr_before'] for r in rs], '.1e')}); "
            f"pruning error at most {g(max(r['pruning_error'] for r in rs))}; selection + "
            f"reduction {', '.join(f'{s:.2f}' for s in sel)} s{power(nm, sel)}, "
            + ", ".join(f"{r['selection_over_eigensolve']:.1%}" for r in rs) +
            " of the eigen-solve; Newton " + ", ".join(f"{r['newton_iterations_mean']:.2f}"
                                                      for r in rs) +
            " iterations per step and " + ", ".join(f"{s:,.0f}" for s in sps) +
            f" steps/s{power(nm, sps)}; energy_drift_rel of the short scene "
            + ", ".join(g(r["energy_drift_rel"]) for r in rs)
            + (f"; {', '.join(r['case'] for r in bad)} ended otherwise" if bad else "") + ".")
    return " ".join(parts) or "No result."


def text_long(rows: list[dict]) -> str:
    """Class 5: the energy balance error over each long run, and the finer step's gain."""
    parts = []
    for r in rows:
        if r["case"].endswith("reduce"):
            continue
        if r["outcome"] != "ok" or "read_error" in r:
            parts.append(f"{r['case']}: exit {r['exit_status']} ({r['outcome']}): "
                         f"{r.get('read_error') or r['last_stderr']}.")
            continue
        share, peaks = r.get("drift_share"), r.get("window_maxima") or [0, 0]
        shape = ("stays flat" if share is not None and share < 0.1 else
                 "was not fitted" if share is None else
                 "drifts steadily away from zero" if peaks[-1] > peaks[min(1, len(peaks) - 1)]
                 else "drifts steadily back towards zero")
        parts.append(
            f"{r['case']} ({r['steps']:,} steps to {g(r.get('end_time_s'), 'g')} s): after the "
            f"first tenth the balance error {shape} ({g(r.get('drift_per_s'), '+.1e')} per s, "
            f"{g(share, '.0%')} of its largest value over the run; window maxima "
            f"{g(r['max_first_tenth'])} in the first tenth, {g(r['max_last_tenth'])} in the "
            f"last, ∝ t^{g(r.get('growth_exponent'), '.2f')}); energy_drift_rel "
            f"{g(r['energy_drift_rel'])}; Newton {g(r['newton_iterations_mean'], '.2f')} per "
            f"step (at most {r['newton_iterations_max']}); "
            f"{g(r['steps_per_second'], ',.0f')} steps/s.")
    ok = {r["case"]: r for r in good(rows)}
    coarse = ok.get(f"crankshaft, drive ×{DRIVE_FACTORS[-1]}")
    fine = ok.get(f"crankshaft, drive ×{DRIVE_FACTORS[-1]}, step / 4")
    if coarse and fine and coarse.get("drift_per_s") and fine.get("drift_per_s"):
        parts.append(
            f"A quarter of the step at ×{DRIVE_FACTORS[-1]} (the shaft turning "
            f"{fine['rotation_per_step_rad']:.3f} instead of {coarse['rotation_per_step_rad']:.3f}"
            f" rad per step) cuts energy_drift_rel by "
            f"{coarse['energy_drift_rel'] / fine['energy_drift_rel']:.0f}×"
            f" and the drift rate by {abs(coarse['drift_per_s'] / fine['drift_per_s']):.0f}× "
            f"(16× for a second-order method in its asymptotic range): the error is the "
            f"step's, not an instability.")
    return " ".join(parts) or "No result."


def text_material(rows: list[dict]) -> str:
    """Class 6: bending frequencies towards incompressibility, and scaling over E."""
    nus = sorted((r for r in good(rows) if r["case"].startswith("ν")), key=lambda r: r["nu"])
    es = sorted((r for r in good(rows) if r["case"].startswith("E")), key=lambda r: r["E"])
    bad = [r for r in rows if r["outcome"] != "ok"]
    parts = []
    if nus:
        parts.append(
            "Poisson's ratio " + ", ".join(f"{r['nu']:g}" for r in nus) +
            ": the first (weak-axis) bending frequency is " +
            ", ".join(f"{r['error_weak']:+.1e}" for r in nus) + " and the strong-axis one " +
            ", ".join(f"{r['error_strong']:+.1e}" for r in nus) + " from Timoshenko (Cowper κ(ν)): "
            f"towards incompressibility the error grows by "
            f"{g(nus[-1]['error_weak'] - nus[0]['error_weak'], '+.1e')} (ν = {nus[-1]['nu']:g} "
            f"against {nus[0]['nu']:g}), the volumetric locking of the P2 tetrahedra in bending "
            f"at this mesh. "
            "Smallest verification margins " +
            ", ".join(smallest_margin(r) for r in nus) + "; pruning error " +
            ", ".join(g(r["pruning_error"]) for r in nus) + ".")
    if es:
        cmp = [r for r in es if r.get("frequency_difference") is not None and r["E"] != E_REFERENCE]
        parts.append(
            f"E from {es[0]['E']:.0e} to {es[-1]['E']:.0e} Pa: f·√(E₀/E) equals f(E₀ = "
            f"{E_REFERENCE:.0e}) to "
            f"{g(max((r['frequency_difference'] for r in cmp), default=None))}"
            f" on the same mesh file ({every(cmp, 'same_mesh_file')}), "
            f"with the same fields kept ({every(cmp, 'same_fields_kept')}) "
            f"and cond(Mr) after within "
            f"{g(max((r.get('cond_mr_after_change') or 0) for r in cmp))}; the pruning error "
            f"moves between {g(min(r['pruning_error'] for r in es))} and "
            f"{g(max(r['pruning_error'] for r in es))} (round-off).")
    if bad:
        parts.append("Ended otherwise: " + "; ".join(f"{r['case']} exit {r['exit_status']}: "
                                                     f"{r['last_stderr']}" for r in bad) + ".")
    return " ".join(parts) or "No result."


def text_mpi(rows: list[dict]) -> str:
    """Class 7: two ranks against one, entry by entry."""
    two = next((r for r in good(rows) if r.get("ranks") == 2), None)
    if two is None or "kr_difference" not in two:
        bad = [r for r in rows if r["outcome"] != "ok"]
        return "No comparison." + (f" {bad[0]['case']}: exit {bad[0]['exit_status']}: "
                                   f"{bad[0]['last_stderr']}" if bad else "")
    return (f"`gcms reduce` on 2 ranks against 1 ({two['ndofs']:,} DOFs): frequencies agree to "
            f"{g(two['frequency_difference'])}, the fields kept are the same "
            f"({f(two['same_fields_kept'])}); after matching the nodes by position (to "
            f"{g(two['node_match_over_size'])} of the body) and the signs of the "
            f"{two['sign_flips']} fields that came out flipped, F agrees to "
            f"{g(two['fields_difference'])}, Mr to {g(two['mr_difference'])} and Kr to "
            f"{g(two['kr_difference'])} of their largest entries. The preconditioned basis "
            f"undoes a near-dependency of cond(Mr) = {g(two['cond_mr_before'])} before "
            f"selection, which amplifies round-off by up to its square root, "
            f"{g(math.sqrt(two['cond_mr_before']))}.")


def ended(r: dict) -> str:
    """How a run that gave no result ended: its exit status, outcome and last line."""
    return f"exit {r['exit_status']} ({r['outcome']}): {r.get('read_error') or r['last_stderr']}"


def text_assembly(rows: list[dict]) -> str:
    """Class 8: the crank train's balance, damping, speed, step and basis, and the mistakes."""
    ok = {r["case"]: r for r in good(rows)}
    base = ok.get("as written")
    if base is None:
        return "The coarse train gave no result: " + ended(rows[0]) + "."
    runs = [r for r in good(rows) if r.get("energy_drift_rel") is not None]
    drift = [r["energy_drift_rel"] for r in runs]
    newton = [r["newton_iterations_mean"] for r in runs]
    parts = [f"Every finished run balances its energy to {g(min(drift))}–{g(max(drift))} of "
             f"its largest energy or work, with {g(min(newton), '.2f')}–"
             f"{g(max(newton), '.2f')} Newton iterations a "
             f"step; the train as written ({base['coordinates']:,} coordinates) "
             f"{g(base['steps_per_second'], ',.0f')} steps/s."]
    torques = [(c, ok[c]["drive_torque_peak_nm"]) for c in ("undamped", "as written",
                                                            "damping ×5") if c in ok]
    others = [c for c, _ in torques if c != "as written"]
    parts.append("The drive torque peaks at " + ", ".join(
        f"{t:,.0f} N·m {c}" for c, t in torques) + " (the crankshaft's 500 Hz torsional mode "
        "that the firing's tenth order meets at 3000 rpm); the big-end peak moves by "
        + ", ".join(f"{rel(ok[c]['big_end_peak_n'], base['big_end_peak_n']):.1e}"
                    for c in others) + f" ({', '.join(others)}).")
    half, double = ok.get("half the step"), ok.get("double the step")
    if half and "torque_difference_rel" in half:
        text = (f"Half the step moves the drive torque by {g(half['torque_difference_rel'])} of "
                f"its peak and big-end 1's force by {g(half['big_end_difference_rel'])}")
        if double and "torque_difference_rel" in double:
            ratio = double["torque_difference_rel"] / half["torque_difference_rel"]
            text += (f"; double the step is {g(double['torque_difference_rel'])} and "
                     f"{g(double['big_end_difference_rel'])} from half (h² convergence makes the "
                     f"ratio of the two torque differences 5, measured {ratio:.1f})")
        parts.append(text + ".")
    if "crankshaft in the rotor basis" in ok:
        r = ok["crankshaft in the rotor basis"]
        parts.append(f"The crankshaft in the rotor basis ({r['coordinates']:,} coordinates) "
                     f"differs from the full basis by {g(r.get('torque_difference_rel'))} of the "
                     f"drive torque's peak and {g(r.get('big_end_difference_rel'))} of big-end "
                     f"1's.")
    if "four cycles" in ok:
        r = ok["four cycles"]
        parts.append(f"Over four cycles the balance error's largest value is "
                     f"{g(r['max_first_tenth'])} in the first tenth of the run (within the "
                     f"spin-up) and {g(r['max_last_tenth'])} in the last; the maxima of the tenths "
                     f"after the first grow ∝ t^{g(r.get('growth_exponent'), '.2f')}.")
    speeds = [c for c in ("2700 rpm", "3600 rpm") if c in ok]
    if speeds:
        parts.append("At " + " and ".join(speeds) + " the drive torque peaks at " + " and ".join(
            f"{ok[c]['drive_torque_peak_nm']:,.0f} N·m" for c in speeds) + ".")
    mistakes = [r for r in rows if r["case"] in ("missing body", "light piston", "rubber conrod",
                                                   "1 ms step")]
    parts += [f"{r['case'].capitalize()}: " + (
        f"finished, drift {g(r.get('energy_drift_rel'))}, {r.get('dropped_rows')} rows dropped"
        if r in good(rows) else
        f"stopped at t = {r['stopped_at_s']:.4g} s after {r['steps']} steps, saying: "
        f"{r['message']} (exit 1, its rows kept, marked incomplete)" if "message" in r
        else ended(r)) + "." for r in mistakes]
    return " ".join(parts)


TEXTS = {"symmetry": text_symmetry, "units": text_units, "slenderness": text_slenderness,
         "modes": text_modes, "long": text_long, "material": text_material, "mpi": text_mpi,
         "assembly": text_assembly}
