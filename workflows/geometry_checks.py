"""What geometry.features refuses before Gmsh, and geometry.estimate's counts against Gmsh's.

Three tables, each body built in a child process (Gmsh's failures and slow meshes stay
there; a mesh that takes longer than ``--timeout`` seconds is recorded as such):

1. Features against the geometry kernel: a feature set to a fraction (1e-8 … 1e-5) of the
   body's largest extent, built with the OCC kernel and its named surfaces found
   (``meshing.add_body`` and the physical groups), no mesh: "builds" or the kernel's error.
2. Features against the mesh size: beams 0.05 m long at [mesh] size h = 5 mm and a
   one-throw crankshaft at h = 10 mm, the feature set to feature/h from 1 to 0.001, meshed
   at order 1 and 2: the worst cell's shape measure γ = 6√2 V / l_rms³ when every cell's
   Jacobian is positive at every Gauss point, else the folded cells or Gmsh's error.
3. ``estimate.estimate_mesh`` against Gmsh: every section at L = 0.1 and 0.5 m and sizes of
   2, 1, 1/2 and 1/4 times its default 2A/P, crankshafts of 1 to 4 throws, refinements.

The bodies are built from their parameters directly (``geometry.params``), not through
``parse_geometry``, whose checks would refuse the small features being measured.

    python workflows/geometry_checks.py [--out docs/geometry_checks] [--quick]

writes OUT.md (the page, its tables generated) and OUT.json (every build's result).
The full run takes about 10 min on 2 cores (most of it the estimate table's largest
meshes, 100k–235k cells); ``--quick`` builds two rows of each table at a few ratios (a
smoke run, under 20 s).
"""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import time

from common import REPO, log, parser, record_header, table_head, table_row, worker_options
from common import write_markdown, write_record

sys.path.insert(0, str(REPO))

FLANGED = {"width": 0.04, "height": 0.05, "flange_thickness": 0.006, "web_thickness": 0.004}
KERNEL_FRACTIONS = (1e-8, 1e-7, 3e-7, 1e-6, 1e-5)
RATIOS = (1, 0.5, 0.3, 0.2, 0.1, 0.05, 0.03, 0.02, 0.01, 0.003, 0.001)
BEAM_SIZE, CRANK_SIZE = 0.005, 0.010


# --- the bodies ----------------------------------------------------------------------------

def beam(section: str, length: float, **dims) -> dict:
    return {"kind": "beam", "section": section, "length": length, "dimensions": dims}


def crank(**keys) -> dict:
    return {"kind": "crankshaft", **keys}


def spike(width: float) -> list[list[float]]:
    """A 40 × 20 mm rectangle with a 20 mm spike of ``width`` on top."""
    return [[0, 0], [0.04, 0], [0.04, 0.02], [0.02 + width, 0.02], [0.02 + width, 0.04],
            [0.02, 0.04], [0.02, 0.02], [0, 0.02]]


def notch(width: float) -> list[list[float]]:
    """A 40 mm square with a 20 mm deep notch of ``width`` cut into its top."""
    return [[0, 0], [0.04, 0], [0.04, 0.04], [0.02 + width, 0.04], [0.02 + width, 0.02],
            [0.02, 0.02], [0.02, 0.04], [0, 0.04]]


def sliver(width: float) -> list[list[float]]:
    """A 40 mm long quadrilateral ``width`` thick (2A/P about ``width``)."""
    return [[0, 0], [0.04, 0], [0.04, width], [0, width * 1.01]]


def rim_width(value: float) -> float:
    d = CRANK_DEFAULTS()
    return max(d["journal_diameter"], d["pin_diameter"]) + 2 * value


def CRANK_DEFAULTS() -> dict:  # noqa: N802 - read lazily (imports the package)
    from geometry.params import CRANKSHAFT_DEFAULTS
    return dict(CRANKSHAFT_DEFAULTS)


#: Table 1: (row, extent of the body the fraction is of, body with the feature = value).
KERNEL_ROWS = {
    "tube wall": (0.1, lambda v: beam("tube", 0.1, radius=0.02, thickness=v)),
    "box wall": (0.1, lambda v: beam("box", 0.1, width=0.04, height=0.03, thickness=v)),
    "I web": (0.1, lambda v: beam("I", 0.1, **{**FLANGED, "web_thickness": v})),
    "polygon spike": (0.1, lambda v: beam("polygon", 0.1, vertices=spike(v))),
    "beam length": (0.02, lambda v: beam("square", v, side=0.02)),
    "crank web_thickness": (None, lambda v: crank(throws=1, web_thickness=v)),
    "crank journal_length": (None, lambda v: crank(throws=1, journal_length=v)),
    "crank web rim": (None, lambda v: crank(throws=1, web_width=rim_width(v))),
}

#: Table 2: (row, orders, body with the feature = value at h; None below a ratio: not built).
MESH_ROWS = {
    "tube wall (r = 20 mm)": ((1, 2), lambda v: beam("tube", 0.05, radius=0.02, thickness=v)),
    "tube hole diameter": ((1,), lambda v: beam("tube", 0.05, radius=0.02,
                                                thickness=0.02 - v / 2) if v >= 0.05 * BEAM_SIZE
                           else None),
    "box wall": ((1,), lambda v: beam("box", 0.05, width=0.04, height=0.03, thickness=v)),
    "I web": ((1,), lambda v: beam("I", 0.05, **{**FLANGED, "web_thickness": v})),
    "I flange": ((1,), lambda v: beam("I", 0.05, **{**FLANGED, "flange_thickness": v})),
    "T flange overhang": ((1,), lambda v: beam("T", 0.05, **{**FLANGED,
                                                            "web_thickness": 0.04 - 2 * v})),
    "L leg": ((1,), lambda v: beam("L", 0.05, width=0.04, height=0.05, thickness=v)),
    "polygon sliver (2A/P)": ((1,), lambda v: beam("polygon", 0.05, vertices=sliver(v))),
    "polygon spike": ((1,), lambda v: beam("polygon", 0.05, vertices=spike(v))),
    "polygon notch": ((1,), lambda v: beam("polygon", 0.05, vertices=notch(v))),
    "beam length": ((1,), lambda v: beam("square", v, side=0.02)),
    "crank web_thickness": ((1,), lambda v: crank(throws=1, web_thickness=v)),
    "crank journal_length": ((1,), lambda v: crank(throws=1, journal_length=v)),
    "crank pin_length": ((1,), lambda v: crank(throws=1, pin_length=v)),
    "crank web rim": ((1, 2), lambda v: crank(throws=1, web_width=rim_width(v))),
}
ROUND_ROWS = ("tube wall (r = 20 mm)", "crank web rim")   # straight ones: the same mesh at order 2

SECTION_BODIES = {
    "square": ({"side": 0.02}, 4), "rectangle": ({"width": 0.03, "height": 0.02}, 4),
    "circle": ({"radius": 0.01}, 4),
    "tube": ({"radius": 0.02, "thickness": 0.004}, 3),
    "box": ({"width": 0.04, "height": 0.03, "thickness": 0.004}, 3),
    "I": (FLANGED, 3), "T": (FLANGED, 3), "C": (FLANGED, 3),
    "L": ({"width": 0.04, "height": 0.05, "thickness": 0.006}, 3),
    "polygon": ({"vertices": [[0, 0], [0.03, 0], [0.03, 0.01], [0, 0.02]]}, 4),
}   # (dimensions, how many of the four sizes at L = 0.5)


def estimate_cases() -> list[tuple[str, dict, dict]]:
    """(label, body, mesh) of table 3."""
    from geometry.params import BeamParams

    cases = []
    for section, (dims, at_half) in SECTION_BODIES.items():
        dims = {k: [tuple(p) for p in v] if k == "vertices" else v for k, v in dims.items()}
        default = BeamParams(section=section, dimensions=dims).profile().feature_size
        for length, count in ((0.1, 4), (0.5, at_half)):
            for factor in (2, 1, 0.5, 0.25)[:count]:
                size = round(factor * default, 6)
                cases.append((f"{section} L = {length:g}", beam(section, length, **dims),
                              {"size": size}))
    for throws in (1, 2, 4):
        for size in (0.040, 0.020, 0.0108, 0.007, 0.005):
            cases.append((f"crankshaft {throws} throws", crank(throws=throws), {"size": size}))
    for keys, sizes in (({"counterweights": False}, (0.020, 0.008)),
                        ({"web_thickness": 0.008, "nose": False}, (0.020, 0.008)),
                        ({"throws": 3, "flange": False, "stroke": 0.12}, (0.020, 0.008))):
        throws = keys.get("throws", 4)
        label = ", ".join(f"{k} = {v}" for k, v in keys.items() if k != "throws")
        for size in sizes:
            cases.append((f"crankshaft {throws} throws ({label})",
                          crank(**{"throws": throws, **keys}), {"size": size}))
    cases += [
        ("square L = 0.1", beam("square", 0.1, side=0.02),
         {"size": 0.010, "refine": {"end_x0": 0.002}}),
        ("rectangle L = 1", beam("rectangle", 1.0, width=0.03, height=0.02),
         {"size": 0.010, "refine": {"end_x0": 0.003, "end_xL": 0.005}}),
        ("crankshaft 4 throws", crank(throws=4),
         {"size": 0.0108, "refine": {"journal_0": 0.004, "pin_1": 0.005}}),
        ("crankshaft 1 throws", crank(throws=1), {"size": 0.020, "refine": {"end_x0": 0.003}}),
        ("circle L = 1", beam("circle", 1.0, radius=0.01), {"size": 0.020}),
        ("square L = 1", beam("square", 1.0, side=0.02), {"size": 0.0025}),
    ]
    return cases


def params(body: dict):
    """geometry.params of a body dict, unchecked."""
    from geometry.params import BeamParams, CrankshaftParams, default_crank_angles

    if body["kind"] == "beam":
        dims = {k: tuple(tuple(p) for p in v) if k == "vertices" else v
                for k, v in body["dimensions"].items()}
        return BeamParams(section=body["section"], dimensions=dims, length=body["length"])
    keys = {k: v for k, v in body.items() if k != "kind"}
    if "throws" in keys:
        keys["crank_angles_deg"] = default_crank_angles(keys["throws"])
    return CrankshaftParams(**keys)


# --- the child's builds --------------------------------------------------------------------

def kernel_build(body: dict) -> dict:
    """Build with the kernel alone: "builds" or the kernel's message."""
    import gmsh  # noqa: F401  (the session below)

    from geometry import meshing
    from geometry.extent import largest_extent
    from geometry.params import model_unit

    geom = params(body)
    unit = model_unit(largest_extent(geom))
    try:
        with meshing.gmsh_session():
            solid = meshing.add_body(geom.in_units(unit))
            meshing._add_physical_groups(geom, solid)
    except Exception as exc:  # the kernel's bare Exception or KernelFailure
        return {"result": " ".join(str(exc).split())[:80]}
    return {"result": "builds"}


def shape_measures(order: int) -> dict:
    """The worst γ over the mesh's tetrahedra and, at order 2, the folded cells."""
    import gmsh
    import numpy as np

    from geometry.meshing import TETRAHEDRON

    kind = TETRAHEDRON[order]
    tags, nodes = gmsh.model.mesh.getElementsByType(kind)
    node_tags, coords, _ = gmsh.model.mesh.getNodes()
    index = np.zeros(int(node_tags.max()) + 1, dtype=np.int64)
    index[node_tags.astype(np.int64)] = np.arange(len(node_tags))
    xyz = coords.reshape(-1, 3)
    corners = xyz[index[nodes.astype(np.int64).reshape(len(tags), -1)[:, :4]]]
    a, b, c, d = (corners[:, k] for k in range(4))
    volume = np.abs(np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))) / 6
    edges = [b - a, c - a, d - a, c - b, d - b, d - c]
    l_rms = np.sqrt(sum(np.einsum("ij,ij->i", e, e) for e in edges) / 6)
    out = {"cells": int(len(tags)), "gamma": float((6 * math.sqrt(2) * volume / l_rms**3).min())}
    points, _ = gmsh.model.mesh.getIntegrationPoints(kind, "Gauss4")
    _, det, _ = gmsh.model.mesh.getJacobians(kind, points)
    out["folded"] = int(np.sum(det.reshape(-1, len(points) // 3).min(axis=1) <= 0.0))
    return out


def mesh_build(body: dict, mesh: dict, orders: tuple[int, ...], measure: bool = True) -> dict:
    """Mesh at order 1 (and 2): cells and nodes, and (``measure``) γ and folded cells; or
    Gmsh's error."""
    import gmsh

    from geometry import meshing
    from geometry.extent import largest_extent
    from geometry.params import MeshParams, model_unit

    geom = params(body)
    unit = model_unit(largest_extent(geom))
    mp = MeshParams(size=mesh["size"], order=1, refine=mesh.get("refine", {}))
    out: dict = {}
    try:
        with meshing.gmsh_session() as set_option:
            solid = meshing.add_body(geom.in_units(unit))
            meshing._add_physical_groups(geom, solid)
            meshing.set_mesh_sizes(set_option, solid, mp.in_units(unit))
            gmsh.model.mesh.generate(3)
            out["nodes_1"] = len(gmsh.model.mesh.getNodes()[0])
            for order in orders:
                if order == 2:
                    gmsh.model.mesh.setOrder(2)
                    out["nodes_2"] = len(gmsh.model.mesh.getNodes()[0])
                out[f"order_{order}"] = shape_measures(order) if measure else {
                    "cells": len(gmsh.model.mesh.getElementsByType(
                        meshing.TETRAHEDRON[order])[0])}
    except Exception as exc:
        out["error"] = " ".join(str(exc).split())[:80]
    return out


def worker(task: dict) -> dict:
    if task["what"] == "kernel":
        return kernel_build(task["body"])
    return mesh_build(task["body"], task["mesh"], tuple(task["orders"]),
                      task.get("measure", True))


def run(task: dict, timeout: float) -> dict:
    """``task`` in a child process: its result, or a timeout or crash noted as such."""
    t0 = time.perf_counter()
    try:
        child = subprocess.run([sys.executable, __file__, "--worker", json.dumps(task)],
                               capture_output=True, text=True, timeout=timeout, cwd=REPO)
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout:g} s", "wall_s": timeout}
    lines = child.stdout.strip().splitlines()
    if child.returncode or not lines:
        tail = (child.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": f"child exit {child.returncode}: {tail[:60]}",
                "wall_s": round(time.perf_counter() - t0, 2)}
    return {**json.loads(lines[-1]), "wall_s": round(time.perf_counter() - t0, 2)}


# --- the tables ----------------------------------------------------------------------------

def kernel_table(quick: bool, timeout: float) -> tuple[list[dict], list[str]]:
    from geometry.extent import largest_extent

    rows = []
    lines = table_head("feature", *(heading(f) for f in KERNEL_FRACTIONS[:-2]), "1e-6 and up")
    for name, (extent, make) in KERNEL_ROWS.items():
        if quick and name not in ("I web", "crank web_thickness"):
            continue
        extent = extent or largest_extent(params(crank(throws=1)))
        results = []
        for fraction in KERNEL_FRACTIONS:
            got = run({"what": "kernel", "body": make(fraction * extent)}, timeout)
            results.append(got.get("result", got.get("error")))
        rows.append({"feature": name, "extent_m": extent, "results": results})
        lines.append(table_row(name, *kernel_cells(results)))
        log(lines[-1])
    return rows, lines


def short(message: str) -> str:
    """A kernel message as the table shows it: its recognisable phrase."""
    for phrase in ("Line Loop is not closed", "BRepSweep_Translation",
                   "Fuse operation cannot be performed", "PLC Error", "overlapping facets",
                   "matched no face"):
        if phrase in message:
            return phrase
    fusion = re.search(r"fusion gave \d+ solids", message)
    return fusion.group(0) if fusion else message[:50]


def kernel_cells(results: list[str]) -> list[str]:
    """The table's cells: one a fraction below 1e-6, then "1e-6 and up" (1e-6 and 1e-5)."""
    cells = [short(r) for r in results]
    last = cells[-2] if cells[-2] == cells[-1] else f"{cells[-2]} (1e-5: {cells[-1]})"
    return [*cells[:-2], last]


def cell(result: dict, order: int) -> str:
    if "error" in result:
        return short(result["error"])
    measured = result[f"order_{order}"]
    if measured["folded"]:
        return f"**{measured['folded']} folded**"
    return f"{measured['gamma']:.2g}"


def heading(x: float) -> str:
    """A column heading for a fraction: 0.1, 1e-8 (not 1e-08)."""
    return f"{x:g}".replace("e-0", "e-")


def mesh_table(quick: bool, timeout: float) -> tuple[list[dict], list[str]]:
    ratios = (1, 0.1, 0.01) if quick else RATIOS
    rows, lines = [], table_head("feature", "order", *(heading(r) for r in ratios))
    for name, (orders, make) in MESH_ROWS.items():
        if quick and name not in ("box wall", "crank web rim"):
            continue
        size = CRANK_SIZE if name.startswith("crank") else BEAM_SIZE
        results = []
        for ratio in ratios:
            body = make(ratio * size)
            results.append({"result": "–"} if body is None else
                           run({"what": "mesh", "body": body, "mesh": {"size": size},
                                "orders": list(orders)}, timeout))
        rows.append({"feature": name, "size_m": size, "ratios": list(ratios),
                     "results": results})
        shown = orders if name in ROUND_ROWS else (1,)
        for order in shown:
            label = str(order) if name in ROUND_ROWS else ", ".join(map(str, orders))
            lines.append(table_row(name, label, *(
                r["result"] if "result" in r else cell(r, order) for r in results)))
            log(lines[-1])
    return rows, lines


def failed(result: dict, order: int) -> bool:
    """Gmsh's error (not a timeout) or folded cells at ``order``."""
    if "error" in result:
        return not result["error"].startswith("over ")
    return f"order_{order}" in result and result[f"order_{order}"]["folded"] > 0


def mesh_limits(rows: list[dict]) -> dict[int, tuple[float, str] | None]:
    """By order: the largest feature/h that failed (Gmsh's error or folded cells) and where."""
    from geometry.features import MIN_FEATURE_PER_SIZE

    out: dict[int, tuple[float, str] | None] = {}
    for order in MIN_FEATURE_PER_SIZE:
        worst = [(ratio, row["feature"]) for row in rows
                 for ratio, r in zip(row["ratios"], row["results"])
                 if failed(r, order if order in MESH_ROWS[row["feature"]][0] else 1)]
        out[order] = max(worst, default=None)
    return out


def limits_text(limits: dict[int, tuple[float, str] | None]) -> str:
    from geometry.features import MIN_FEATURE_PER_SIZE

    parts = []
    for order, worst in limits.items():
        minimum = MIN_FEATURE_PER_SIZE[order]
        if worst is None:
            parts.append(f"order {order}: nothing failed ({minimum:g} in use)")
        else:
            ratio, where = worst
            verdict = "at least twice it" if minimum >= 2 * ratio - 1e-12 else \
                "**less than twice it**"
            parts.append(f"order {order}: {ratio:g} h ({where}); {minimum:g} in use, {verdict}")
    return "Largest feature/h measured to fail (Gmsh's error or folded cells) — " + \
        "; ".join(parts) + "."


def kernel_limit(rows: list[dict]) -> str:
    from geometry.features import KERNEL_RESOLUTION

    worst = max((f for row in rows for f, r in zip(KERNEL_FRACTIONS, row["results"])
                 if r != "builds"), default=None)
    if worst is None:
        return "Every fraction built."
    return (f"The largest fraction that failed is {worst:g} of the extent; "
            f"`KERNEL_RESOLUTION` = {KERNEL_RESOLUTION:g} is {KERNEL_RESOLUTION / worst:.0f} "
            "times it.")


def estimate_table(quick: bool, timeout: float) -> tuple[list[dict], list[str]]:
    from gcms_fenicsx.config.geometry import parse_mesh
    from geometry.estimate import estimate_mesh

    cases = estimate_cases()
    if quick:
        cases = [cases[0], cases[1], cases[-3]]
    rows = []
    lines = table_head("body", "[mesh] size", "refine", "cells (Gmsh)", "estimate / cells",
                       "nodes P1", "est./P1", "nodes P2", "est./P2")
    for label, body, mesh in cases:
        geom = params(body)
        got = run({"what": "mesh", "body": body, "mesh": mesh, "orders": [1, 2],
                   "measure": False}, timeout)
        if "error" in got:
            log(f"{label} {mesh}: {got['error']}")
            rows.append({"body": label, "mesh": mesh, "error": got["error"]})
            continue
        est = {order: estimate_mesh(geom, parse_mesh({**mesh, "order": order}, geom))
               for order in (1, 2)}
        row = {"body": label, "mesh": mesh, "cells": got["order_1"]["cells"],
               "nodes_1": got["nodes_1"], "nodes_2": got["nodes_2"],
               "estimate_cells": est[1].cells, "estimate_nodes_1": est[1].nodes,
               "estimate_nodes_2": est[2].nodes, "wall_s": got["wall_s"]}
        rows.append(row)
        refine = ", ".join(f"{k} {v:g}" for k, v in mesh.get("refine", {}).items())
        lines.append(table_row(label, f"{mesh['size'] * 1e3:.3g} mm", refine,
                               f"{row['cells']:,}", f"{row['estimate_cells'] / row['cells']:.2f}",
                               f"{row['nodes_1']:,}",
                               f"{row['estimate_nodes_1'] / row['nodes_1']:.2f}",
                               f"{row['nodes_2']:,}",
                               f"{row['estimate_nodes_2'] / row['nodes_2']:.2f}"))
        log(lines[-1])
    return rows, lines


def ranges(rows: list[dict]) -> str:
    done = [r for r in rows if "cells" in r]

    def span(key: str, actual: str) -> str:
        q = [r[key] / r[actual] for r in done]
        return f"{min(q):.2f}–{max(q):.2f}"

    return (f"{len(done)} meshes: estimate/actual cells {span('estimate_cells', 'cells')}, "
            f"P1 nodes {span('estimate_nodes_1', 'nodes_1')}, P2 nodes "
            f"{span('estimate_nodes_2', 'nodes_2')}.")


def page(kernel: list[str], mesh: list[str], estimate: list[str], notes: dict[str, str],
         quick: bool) -> str:
    import gmsh

    return "\n".join([
        "# Geometry checks and mesh estimates", "",
        "What `geometry.features` refuses before Gmsh runs, and how `geometry.estimate` "
        "counts cells",
        "and nodes, with the measurements behind their constants, made by "
        f"`workflows/geometry_checks.py` with Gmsh {gmsh.__version__} (OpenCASCADE kernel), "
        "models built in units of",
        "the power of ten nearest the body's largest extent (`params.model_unit`)."
        + (" **Quick run: a few rows of each table only.**" if quick else ""), "",
        "## Features against the geometry kernel", "",
        "A feature is a wall, flange, web, leg, a polygon's shortest edge, narrowest spike or "
        "notch",
        "(a vertex's distance to an edge not ending at it) and 2A/P, a crankshaft's journals, "
        "pins,",
        "web rim, stroke/2 and the nose and flange shoulders, a beam's length",
        "(`features.features`). Built with the kernel alone (no mesh; beams 0.1 m, a "
        "one-throw crankshaft), a feature of the given fraction of the largest extent:", "",
        *kernel, "",
        "The named surfaces are then found to 1e-6 of the extent (`faces.tolerance`), so a "
        "feature",
        "must be at least `KERNEL_RESOLUTION` = 1e-5 of the body's largest extent: ten times "
        "the",
        "face tolerance. " + notes["kernel"], "",
        "## Features against the mesh size", "",
        "Beams at [mesh] size h = 5 mm (0.05 m long; tube r = 20 mm, box 40 × 30, I/T 40 × 50, "
        "L 40 × 50, polygons in a 20–40 mm square), a one-throw crankshaft at h = 10 mm, the",
        "feature set to the ratio feature/h of the column. Each entry is the worst cell's "
        "shape",
        "measure γ = 6√2 V / l_rms³ (1 for a regular tetrahedron) when every cell's Jacobian "
        "is",
        "positive at every Gauss point, else the folded cells or Gmsh's error. Straight-edged",
        "bodies get the same mesh at order 2; only the round ones are shown twice.", "",
        *mesh, "",
        notes["mesh"], "",
        "`MIN_FEATURE_PER_SIZE` (0.1 at order 1, 0.2 at order 2) is meant to be at least "
        "twice the largest ratio measured to fail. A refused feature's message names its key, the feature, the size it "
        "was compared with and the largest size that would do.", "",
        "## Counting cells and nodes before meshing", "",
        "`estimate.estimate_mesh` (model in its docstring): cells ≈ a·ΣV/h³ + b·ΣS/h², "
        "vertices",
        "≈ p·ΣV/h³ + q·ΣS/h², boundary triangles ≈ r·ΣS/h², order-2 nodes from Euler's "
        "relation.",
        "h is [mesh] size, at most the curvature size 2πr/16 of a round surface, and",
        "at most 0.1 of the bounding box's diagonal (Gmsh meshes no coarser than that "
        "whatever",
        "MeshSizeMax says). The constants a = 3.22, b = 2.51, p = 0.437, q = 1.21, r = 2.62 "
        "were fitted to these meshes.", "",
        *estimate, "",
        notes["estimate"], "",
        "The worst cases are the coarsest (a few hundred cells, a section spanned by one or two",
        "elements) and the refinements (the Threshold layer is modelled as a slab of twice the "
        "mesh",
        "size, not clipped by the body): `tests/test_geometry_estimate.py` asserts a factor "
        "of 2.", ""])


def main() -> None:
    p = parser(__doc__, out="docs/geometry_checks", out_help="OUT.md and OUT.json are written",
               quick="two rows of each table")
    p.add_argument("--timeout", type=float, default=60.0,
                   help="seconds a child build may take (default 60)")
    worker_options(p, "--worker")
    args = p.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(args.worker))))
        return
    start = time.perf_counter()
    kernel_rows, kernel = kernel_table(args.quick, args.timeout)
    mesh_rows, mesh = mesh_table(args.quick, args.timeout)
    estimate_rows, estimate = estimate_table(args.quick, args.timeout)
    notes = {"kernel": kernel_limit(kernel_rows), "mesh": limits_text(mesh_limits(mesh_rows)),
             "estimate": ranges(estimate_rows)}
    text = page(kernel, mesh, estimate, notes, args.quick)
    print(text)
    record = record_header()
    write_record(args.out.with_suffix(".json"),
                 {"quick": args.quick, "notes": notes, "kernel": kernel_rows, "mesh_size": mesh_rows,
                  "estimate": estimate_rows, "wall_s": round(time.perf_counter() - start, 1)},
                 newline=True)
    write_markdown(args.out.with_suffix(".md"), text, record)


if __name__ == "__main__":
    main()
