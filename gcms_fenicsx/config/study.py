"""The study configuration: one TOML file, one table per stage.

``load_config`` reads a TOML file (or the built-in default) and validates every
table it knows; an unknown table or key is an error. Each stage's table is parsed by
the module that owns it (``config.geometry``, ``config.material``, ``config.modes``,
``config.selection``, ``dynamics.scene``), so this module only composes them into a
:class:`StudyConfig`.
"""
from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from geometry.params import BeamParams, CrankshaftParams, MeshParams

from gcms_fenicsx import __version__
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from gcms_fenicsx.dynamics.scene import Scene, parse_scene
from gcms_fenicsx.config.material import Material, parse_material
from gcms_fenicsx.config.modes import ModesConfig, parse_modes
from gcms_fenicsx.config.selection import SelectionConfig, parse_selection
from gcms_fenicsx.config.table import ConfigError

#: Tables a study file may contain, in pipeline order.
KNOWN_TABLES = ("geometry", "mesh", "material", "modes", "selection", "scene")
#: The tables a reduced model depends on: its input hash, and the key of its cache.
REDUCED_MODEL_TABLES = ("geometry", "mesh", "material", "modes", "selection")


@dataclass(frozen=True)
class StudyConfig:
    geometry: BeamParams | CrankshaftParams
    mesh: MeshParams
    material: Material = field(default_factory=Material)
    modes: ModesConfig = field(default_factory=ModesConfig)
    selection: SelectionConfig = field(default_factory=SelectionConfig)
    scene: Scene | None = None
    source: str = "<built-in default>"

    def digest(self, *tables: str) -> str:
        """SHA-256 of the named tables (all when none given) and of this package's version: a
        cache key and provenance hash."""
        names = tables or KNOWN_TABLES
        payload = {name: _plain(getattr(self, name)) for name in names}
        payload["gcms_fenicsx_version"] = __version__
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def parse_config(raw: Mapping[str, Any], source: str = "<dict>") -> StudyConfig:
    """Validate a whole study (a parsed TOML document)."""
    unknown = sorted(set(raw) - set(KNOWN_TABLES))
    if unknown:
        raise ConfigError(f"[{unknown[0]}]", raw[unknown[0]],
                          "unknown table (allowed: " + ", ".join(KNOWN_TABLES) + ")")
    geom = parse_geometry(raw.get("geometry"))
    return StudyConfig(
        geometry=geom,
        mesh=parse_mesh(raw.get("mesh"), geom),
        material=parse_material(raw.get("material")),
        modes=parse_modes(raw.get("modes")),
        selection=parse_selection(raw.get("selection")),
        scene=parse_scene(raw.get("scene")),
        source=source,
    )


def default_config_text() -> str:
    """The built-in default study (also shipped as ``workflows/default.toml``)."""
    return resources.files("gcms_fenicsx.data").joinpath("default.toml").read_text()


def load_config(path: str | Path | None = None) -> StudyConfig:
    """Read and validate a study file; ``None`` gives the built-in default."""
    if path is None:
        return parse_config(tomllib.loads(default_config_text()), "<built-in default>")
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError("config file", str(path), f"cannot be read ({exc.strerror})") from exc
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("config file", str(path), f"is not valid TOML ({exc})") from exc
    return parse_config(raw, str(path))


def _plain(obj: Any) -> Any:
    if hasattr(obj, "__dataclass_fields__"):
        return {"type": type(obj).__name__, **asdict(obj)}
    return obj
