"""OUT.json, OUT.md and OUT.png: the classes just run merged into an existing OUT.json (the
others kept as they were), written as strict JSON, and the report and picture drawn from it."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from common import with_record, write_markdown
from gcms_fenicsx.files.outputs import finite_json
from stress import CLASSES, log
from stress.figure import plot
from stress.report import markdown


def merged(path: Path, runs: dict[str, dict]) -> dict:
    """OUT.json with the classes just run replacing theirs (the others kept as they were)."""
    classes: dict = {}
    if path.exists():
        try:
            classes = json.loads(path.read_text()).get("classes", {})
        except (ValueError, AttributeError):
            classes = {}
    classes.update(runs)
    return {"suite": "workflows/stability.py",
            "classes": {c: classes[c] for c in CLASSES if c in classes}}


def python_scalar(value: np.generic):
    """A NumPy scalar as the Python number or boolean JSON can hold (TypeError otherwise)."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON")


def redraw(document: dict, out: Path) -> None:
    """Write OUT.md (under the provenance of this command) and draw OUT.png from ``document``."""
    write_markdown(Path(f"{out}.md"), markdown(document))
    plot(document, Path(f"{out}.png"))


def write(document: dict, out: Path) -> None:
    """OUT.json (strict: NaN and ±inf as null; its provenance ``record`` first), OUT.md (under
    the same provenance) and OUT.png; a picture that rows of an older suite cannot fill is
    skipped with a line saying why."""
    out.parent.mkdir(parents=True, exist_ok=True)
    document = with_record(document)
    Path(f"{out}.json").write_text(json.dumps(finite_json(document), indent=1, allow_nan=False,
                                              default=python_scalar))
    write_markdown(Path(f"{out}.md"), markdown(document), document["record"])
    try:
        plot(document, Path(f"{out}.png"))
    except (KeyError, TypeError, ValueError, IndexError) as exc:  # rows of an older suite
        log(f"{out}.png not drawn: {type(exc).__name__}: {exc}")
