"""The README and docs/ against the tree: fast checks, no finite-element solve.

(a) README.md stays a front door (at most 250 lines) whose first commands are the two the
    project promises; (b) docs/index.md links every file in docs/; (c) every repository path
    README.md and docs/*.md cite (in backticks or links) exists, and so does every module or
    name they cite as ``gcms_fenicsx.x.y`` or ``geometry.x.y`` (read from the source, not
    imported); (d) every ``gcms SUBCOMMAND``
    cited is a subcommand of the real parser; (e) docs/study-file.md documents exactly the
    keys the study parsers read, and the README's minimal study parses; (f) every record in
    docs/ (each JSON file, and each page beside a JSON record of the same name) names the
    command that made it.

The parsers and the CLI are reached by module attribute (``gcms_fenicsx.cli.build_parser``,
``gcms_fenicsx.config.*.parse_*``, ``gcms_fenicsx.config.scene.parse_scene``): when a module
moves, the failing import says which line here to update.
"""
from __future__ import annotations

import argparse
import json
import re
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"

#: The first two commands of the README, exactly (the project's contract).
FIRST_COMMANDS = ("bash scripts/run.sh", "bash scripts/test.sh")
#: Top-level folders and files of the repository whose cited paths are checked.
ROOTS = ("gcms_fenicsx/", "geometry/", "workflows/", "tests/", "scripts/", "docs/")
ROOT_FILES = ("README.md", "pyproject.toml")


def _pages() -> list[Path]:
    return [README, *sorted(DOCS.glob("*.md"))]


def _code_spans(text: str) -> list[str]:
    """Inline code spans and fenced code blocks' lines."""
    spans = re.findall(r"`([^`\n]+)`", re.sub(r"```.*?```", "", text, flags=re.S))
    for block in re.findall(r"```[^\n]*\n(.*?)```", text, flags=re.S):
        spans.extend(block.splitlines())
    return spans


def _links(text: str) -> list[str]:
    return [m.split("#")[0] for m in re.findall(r"\]\(([^)\s]+)\)", text)
            if not re.match(r"[a-z]+:", m)]


def _cited_paths(text: str) -> set[str]:
    """Repository paths in code spans (anywhere in them) and in links."""
    found = set()
    pattern = (r"(?<![\w./-])((?:" + "|".join(re.escape(r) for r in ROOTS) + r")[\w./-]*"
               r"|(?:" + "|".join(re.escape(f) for f in ROOT_FILES) + r"))")
    for span in _code_spans(text):
        found.update(m.rstrip(".,:;") for m in re.findall(pattern, span))
    return found


# (a) ---------------------------------------------------------------------------------------

def test_readme_is_short_and_starts_with_the_two_commands():
    lines = README.read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines (at most 250)"
    commands = []
    for line in lines:
        if line.startswith("bash "):
            commands.append(line.split("#")[0].strip())
        if len(commands) == 2:
            break
    assert tuple(commands) == FIRST_COMMANDS
    first_fence = next(i for i, line in enumerate(lines) if line.startswith("```"))
    assert lines[first_fence + 1].split("#")[0].strip() == FIRST_COMMANDS[0]
    assert lines[first_fence + 2].split("#")[0].strip() == FIRST_COMMANDS[1]
    assert first_fence < 5, "the two commands come first"


# (b) ---------------------------------------------------------------------------------------

def test_index_links_every_file_in_docs():
    index = (DOCS / "index.md").read_text()
    linked = {Path(link).name for link in _links(index)} | {
        Path(p).name for p in _cited_paths(index)}
    files = {p.name for p in DOCS.iterdir() if p.is_file() and p.name != "index.md"}
    missing = sorted(files - linked)
    assert not missing, f"docs/index.md does not link: {missing}"


# (c) ---------------------------------------------------------------------------------------

def _exists(path: Path) -> bool:
    """The path, or a stem of files (``--out docs/stability`` writes docs/stability.json, ...)."""
    return path.exists() or (path.suffix == "" and any(path.parent.glob(path.name + ".*")))


@pytest.mark.parametrize("page", _pages(), ids=lambda p: p.relative_to(REPO).as_posix())
def test_cited_paths_exist(page):
    text = page.read_text()
    missing = []
    for path in sorted(_cited_paths(text)):
        if any(c in path for c in "<>*…{}") or "X." in path:   # a pattern, not a path
            continue
        if not _exists(REPO / path):
            missing.append(path)
    for link in sorted(set(_links(text))):
        if not link or any(c in link for c in "<>*"):
            continue
        if not ((page.parent / link).exists() or (REPO / link).exists()):
            missing.append(link)
    assert not missing, f"{page.relative_to(REPO)} cites paths that do not exist: {missing}"


def _defines(module_file: Path, name: str) -> bool:
    """Whether a module's source defines or imports ``name`` (read, not imported)."""
    text = module_file.read_text()
    return bool(re.search(rf"^\s*(?:def|class)\s+{name}\b|^\s*{name}\s*[:=]|"
                          rf"^\s*from\s+\S+\s+import\s+[^\n]*\b{name}\b|"
                          rf"^\s*import\s+[^\n]*\b{name}\b", text, flags=re.M))


def _resolves(dotted: str) -> bool:
    """``gcms_fenicsx.files.modes_file.read_modes``: a module (a package folder or a .py
    file) followed by at most one name it defines or a submodule."""
    parts = dotted.split(".")
    path, i = REPO / parts[0], 1
    while i < len(parts) and ((path / parts[i]).is_dir() or (path / f"{parts[i]}.py").is_file()):
        path = path / parts[i] if (path / parts[i]).is_dir() else path / f"{parts[i]}.py"
        i += 1
    rest = parts[i:]
    if not rest:
        return True
    if len(rest) > 2:
        return False
    module = path / "__init__.py" if path.is_dir() else path
    # a name, or a class and its attribute
    return module.is_file() and _defines(module, rest[0]) and (
        len(rest) == 1 or rest[1] in module.read_text())


@pytest.mark.parametrize("page", _pages(), ids=lambda p: p.relative_to(REPO).as_posix())
def test_cited_modules_exist(page):
    """Dotted names of the two packages in code spans (``gcms_fenicsx.fe.mesh``,
    ``geometry.estimate.estimate_mesh``) name a module, or a name a module defines."""
    wrong = []
    for span in _code_spans(page.read_text()):
        for dotted in re.findall(r"(?<![\w./-])((?:gcms_fenicsx|geometry)(?:\.[A-Za-z_]\w*)+)",
                                 span):
            if not _resolves(dotted):
                wrong.append(dotted)
    assert not wrong, f"{page.relative_to(REPO)} cites modules or names that do not exist: {wrong}"


# (d) ---------------------------------------------------------------------------------------

def _subcommands() -> set[str]:
    from gcms_fenicsx.cli import build_parser
    parser = build_parser()
    return {name for action in parser._actions
            if isinstance(action, argparse._SubParsersAction) for name in action.choices}


def test_cited_gcms_subcommands_exist():
    known = _subcommands()
    assert known, "gcms_fenicsx.cli.build_parser() has no subcommands"
    wrong = []
    for page in _pages():
        for span in _code_spans(page.read_text()):
            for word in re.findall(r"(?:^|[\s`(])gcms\s+([a-z][\w-]*)", span):
                if word not in known:
                    wrong.append(f"{page.name}: gcms {word}")
    assert not wrong, f"unknown gcms subcommands cited: {wrong} (known: {sorted(known)})"


# (e) ---------------------------------------------------------------------------------------

def _documented_keys() -> dict[str, set[str]]:
    """``{table: {key, ...}}`` from the key tables of docs/study-file.md: a heading naming
    ``[table]`` (or ``[[table]]``) followed by a table headed ``| key |`` whose rows' first
    cells are the keys."""
    keys: dict[str, set[str]] = {}
    table, in_keys = None, False
    for line in (DOCS / "study-file.md").read_text().splitlines():
        heading = re.match(r"#+ .*?`\[\[?([\w.]+)\]?\]`", line)
        if heading:
            table = heading.group(1)
            keys.setdefault(table, set())
            continue
        if line.startswith("#"):
            table = None
        if line.startswith("| key |"):
            in_keys = True
        elif not line.startswith("|"):
            in_keys = False
        row = re.match(r"\| `(\w+)` \|", line)
        if table and in_keys and row:
            keys[table].add(row.group(1))
    return keys


def _parser_keys() -> dict[str, set[str]]:
    """``{table: {key, ...}}``: every key the parsers read, recorded from ``Table.get`` while
    they parse studies that reach each branch (the values need not be valid: a key is read
    before its value is checked)."""
    import geometry.params as params
    import geometry.sections as sections
    from gcms_fenicsx.config import basis, geometry, material, modes, outputs, selection
    from gcms_fenicsx.config import table as table_module
    from gcms_fenicsx.config import scene, system

    read: dict[str, set[str]] = {}
    original = table_module.Table.get

    def recording_get(self, key, *args, **kwargs):
        name = re.sub(r"\[\d+\]", "", self.name)
        read.setdefault(name, set()).add(key)
        return original(self, key, *args, **kwargs)

    def attempt(parse, *args):
        try:
            parse(*args)
        except table_module.ConfigError:
            pass

    table_module.Table.get = recording_get
    try:
        for section in sections.SECTION_KEYS:
            attempt(geometry.parse_geometry, {"kind": "beam", "section": section})
        attempt(geometry.parse_geometry, {"kind": "crankshaft"})
        attempt(geometry.parse_geometry, {"kind": "conrod"})
        crank = geometry.parse_geometry({"kind": "crankshaft"})
        attempt(geometry.parse_mesh, {"size": 0.01, "order": 2, "refine": {}}, crank)
        attempt(material.parse_material, {})
        attempt(modes.parse_modes, {})
        attempt(modes.parse_modes, {"max_frequency_hz": 100.0})
        attempt(selection.parse_selection, {})
        attempt(outputs.parse_outputs, {})
        attempt(basis.parse_basis, {})
        joint = {"type": "revolute", "group": "end_x0", "name": "pin", "axis": [0, 1, 0],
                 "drive": {"angular_velocity": 1.0, "ramp_time": 0.1, "ramp": "cosine"}}
        harmonic = {"group": "end_xL", "name": "f", "force": [0, 0, 1], "time": "harmonic",
                    "frequency_hz": 1.0, "ramp_time": 0.1, "phase_deg": 0.0}
        ramp = {"group": "end_xL", "force": [0, 0, 1], "time": "ramp", "ramp_time": 0.1}
        base = {"end_time": 1.0, "time_step": 0.01, "rho_inf": 0.8, "gravity": [0, 0, -9.81],
                "elasticity": "corotated", "damping": {"alpha": 0.0, "beta": 0.0},
                "solver": {"tolerance": 1e-10, "max_iterations": 25, "jacobian": "rotated"},
                "outputs": {"groups": ["end_xL"], "every": 1, "energy": True,
                            "constraint_forces": True, "coordinates": False,
                            "field_times": [0.5], "stress_groups": ["end_xL"],
                            "stress_times": [0.5]},
                "joints": [joint], "loads": [harmonic, ramp]}
        attempt(scene.parse_scene, {**base, "initial": {
            "velocity": [0, 0, 0], "angular_velocity": [0, 0, 0], "mode": 1,
            "amplitude": 1e-3, "direction": [0, 0, 1]}})
        attempt(scene.parse_scene, {**base, "initial": {"equilibrium": True}})
        rigid = {"mass": 1.0, "center": [0, 0, 0], "inertia": [1, 1, 1],
                 "points": {"p": [0, 0, 0]}}
        placed = {"position": [0, 0, 0], "velocity": [0, 0, 0], "angular_velocity": [0, 0, 0],
                  "rotation": {"axis": [0, 0, 1], "angle": 0.0}}
        attempt(system.parse_system, {
            "system": {"end_time": 1.0, "time_step": 0.1, "rho_inf": 0.8, "record_every": 1,
                       "gravity": [0, 0, 0], "tolerance": 1e-10, "max_iterations": 25},
            "bodies": {"NAME": {"rigid": rigid, **placed}, "other": {"rigid": rigid, "align": {
                "point": "p", "to_body": "NAME", "to_point": "p"}},
                       "mass": {"point_mass": 1.0}},
            "joints": [{"name": "j", "type": "revolute", "body": "NAME", "point": "p",
                        "to_body": "ground", "axis": [0, 0, 1], "drive": joint["drive"]},
                       {"type": "spherical", "body": "NAME", "point": "p", "to_body": "other",
                        "to_point": "p"}]})
        engine = {"pistons": ["mass"], "bore": 0.08, "towards_crank": [0, 0, -1],
                  "firing_order": [1], "first_firing_deg": 0.0, "crank_drive": "j",
                  "ramp_time": 0.01, "pressure": {"angles_deg": [0, 1], "pressures_bar": [1, 1]}}
        attempt(system.parse_system, {
            "system": {"end_time": 1.0, "time_step": 0.1},
            "bodies": {"NAME": {"rigid": rigid}, "mass": {"point_mass": 1.0}},
            "joints": [{"name": "j", "type": "revolute", "body": "NAME", "point": "p",
                        "axis": [0, 0, 1], "drive": joint["drive"]}], "engine": engine})
        attempt(system.parse_system, {"system": {"end_time": 1.0, "time_step": 0.1},
                                      "bodies": {"flexible": {"study": "none.toml"}}})
        attempt(system.parse_system, {"system": {"end_time": 1.0, "time_step": 0.1},
                                      "bodies": {"flexible": {
                                          **{k: {} for k in system.BODY_STUDY_TABLES},
                                          "as_rigid": True}}})
    finally:
        table_module.Table.get = original
    read.pop("mesh.refine", None)      # its keys are the body's surface groups
    for name in ("bodies.NAME.rigid", "bodies.other.rigid"):
        read["bodies.NAME.rigid"] = read.get("bodies.NAME.rigid", set()) | read.pop(name, set())
    for name in ("bodies.NAME.rigid.points", "bodies.other.rigid.points"):
        read.pop(name, None)           # the bodies' own point names
    read["bodies.NAME.align"] = read.pop("bodies.other.align", set())
    read["bodies.NAME.damping"] = read.pop("bodies.flexible.damping", set())
    for name in ("bodies.mass", "bodies.other", "bodies.flexible"):  # one table's keys
        read["bodies.NAME"] |= read.pop(name, set())
    read.pop("bodies", None)           # its keys are the bodies' names
    read.pop("joints.drive", None)     # the scene's drive (config.scene.parse_drive)
    # Every section's and the crankshaft's keys, declared where the geometry is.
    read["geometry"].update(k for keys in sections.SECTION_KEYS.values() for k in keys)
    read["geometry"].update(params.CRANKSHAFT_DEFAULTS)
    return read


def test_study_file_reference_matches_the_parsers():
    from gcms_fenicsx.config import study

    documented, parsed = _documented_keys(), _parser_keys()
    from gcms_fenicsx.config import system

    for name in (*study.KNOWN_TABLES, *system.SYSTEM_TABLES):
        assert name in documented or f"{name}.NAME" in documented, \
            f"docs/study-file.md has no section for [{name}]"
    undocumented = sorted(f"[{t}] {k}" for t, keys in parsed.items()
                          for k in keys - documented.get(t, set()))
    unknown = sorted(f"[{t}] {k}" for t, keys in documented.items()
                     for k in keys - parsed.get(t, set()))
    assert not undocumented, f"keys the parsers read, missing in docs/study-file.md: {undocumented}"
    assert not unknown, f"keys in docs/study-file.md the parsers do not read: {unknown}"


def test_readme_study_parses():
    from gcms_fenicsx.config import study

    text = README.read_text()
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    assert blocks, "README.md shows a minimal study file"
    for block in blocks:
        study.parse_config(tomllib.loads(block), "README.md")


# (f) ---------------------------------------------------------------------------------------

def _records() -> list[Path]:
    jsons = sorted(DOCS.glob("*.json"))
    pages = [p for p in sorted(DOCS.glob("*.md")) if p.with_suffix(".json").exists()]
    return jsons + pages


@pytest.mark.parametrize("record", _records(), ids=lambda p: p.name)
def test_every_record_names_its_command(record):
    if record.suffix == ".json":
        document = json.loads(record.read_text())
        header = document.get("record") if isinstance(document, dict) else None
        assert isinstance(header, dict) and header.get("command"), (
            f"{record.name} has no top-level \"record\" header with a \"command\"")
    else:
        assert "python workflows/" in record.read_text(), (
            f"{record.name} does not name the workflow command that writes it")
