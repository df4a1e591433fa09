"""The "Numerical stability" section of docs/stability.md (the README's): the run's verdict,
then per probe class its title, its run, its paragraph and its table."""
from __future__ import annotations

from stress import CLASSES
from stress.paragraphs import TEXTS
from stress.tables import broken, table

TITLES = {
    "symmetry": "Symmetry perturbation: a 30 mm square steel beam (0.5 m, 7.5 mm P2 mesh, "
                "Nm = 10) widened by ε",
    "units": "Units and size: the same beam in SI, in mm-t-s, and scaled by 1e-3 and 1e3",
    "slenderness": "Slenderness: 10 mm square steel beams, mesh h/2 up to L/h = 200, h above",
    "modes": "Many modes: a 50×40 mm × 1 m steel beam and the default crankshaft, 200 steps "
             "of a short scene",
    "long": "Long runs: the flexible pendulum and the default crankshaft scene (drive ×1, ×3, ×10)",
    "material": "Material extremes: a 30×20 mm × 0.5 m steel beam, ν up to 0.499 and E over "
                "ten decades",
    "mpi": "One and two MPI ranks: `gcms reduce` of a 30×20 mm × 0.5 m beam, Nm = 8",
    "assembly": "Assemblies: the crank train on coarse meshes (crankshaft 16 mm, conrods 5 mm), "
                "its spin-up and a cycle at speed",
}


def markdown(document: dict) -> str:
    """The "Numerical stability" section: the run's verdict, then per class its title, run,
    paragraph and table."""
    classes = document["classes"]
    rows = [r for c in classes.values() for r in c["rows"]]
    bad = broken(rows)
    minutes = sum(c.get("wall_s", 0.0) for c in classes.values()) / 60
    modes = sorted({c["mode"] for c in classes.values()})
    lines = ["## Numerical stability", "",
             f"`python workflows/stability.py` ({' and '.join(modes)} run here: "
             f"{minutes:.0f} minutes; `--quick` runs the smallest members, `--only CLASS` one "
             "class) drives the `gcms` command on studies chosen to stress it and writes "
             "`docs/stability.json`, `docs/stability.png` ([picture](docs/stability.png)) "
             "and this section. Every command "
             "must end in a result or in one line with exit status 1 or 2 and `--out` as it "
             "was; " + (f"of {len(rows)} commands, all did." if not bad else
                        f"of {len(rows)} commands, {len(bad)} did not: " +
                        "; ".join(f"{r['class']}/{r['case']} ({r['problem']})" for r in bad) +
                        "."), ""]
    for i, cls in enumerate(CLASSES, 1):
        if cls not in classes:
            continue
        c = classes[cls]
        try:
            text = TEXTS[cls](c["rows"])
        except (KeyError, TypeError, ValueError, IndexError, ZeroDivisionError) as exc:
            text = f"(no summary: the rows lack {type(exc).__name__} {exc}; rerun the class)"
        lines += [f"**{i}. {TITLES[cls]}** ({c['mode']} run, {c['date']}, {c['git']}). "
                  + text, "", table(cls, c["rows"]), ""]
    return "\n".join(lines)
