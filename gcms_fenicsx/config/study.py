"""The study configuration: one TOML file, one table per stage.

``load_config`` reads a TOML file (or the built-in default) and validates every
table it knows; an unknown table or key is an error. Each stage's table is parsed by
the module that owns it (``config.geometry``, ``config.material``, ``config.modes``,
``config.selection``, ``config.scene``), so this module only composes them into a
:class:`StudyConfig`.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from geometry.params import BeamParams, CrankshaftParams, MeshParams

from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from gcms_fenicsx.config.scene import Scene, parse_scene
from gcms_fenicsx.config.material import Material, parse_material
from gcms_fenicsx.config.modes import ModesConfig, parse_modes
from gcms_fenicsx.config.basis import BasisConfig, parse_basis
from gcms_fenicsx.config.outputs import OutputsConfig, parse_outputs
from gcms_fenicsx.config.plan import StudyPlan, plan_study
from gcms_fenicsx.config.selection import SelectionConfig, parse_selection
from gcms_fenicsx.config.table import ConfigError

#: Tables a study file may contain, in pipeline order.
KNOWN_TABLES = ("geometry", "mesh", "material", "modes", "selection", "scene", "outputs",
                "basis")


@dataclass(frozen=True)
class StudyConfig:
    geometry: BeamParams | CrankshaftParams
    mesh: MeshParams
    material: Material = field(default_factory=Material)
    modes: ModesConfig = field(default_factory=ModesConfig)
    selection: SelectionConfig = field(default_factory=SelectionConfig)
    scene: Scene | None = None
    outputs: OutputsConfig = field(default_factory=OutputsConfig)
    basis: BasisConfig = field(default_factory=BasisConfig)
    source: str = "<built-in default>"

    @cached_property
    def plan(self) -> StudyPlan:
        """What the study decides for its stages (``config.plan.plan_study``), made once."""
        return plan_study(self.source, self.geometry, self.mesh, self.material, self.modes,
                          self.selection, self.scene, self.outputs, self.basis)


def parse_config(raw: Mapping[str, Any], source: str = "<dict>") -> StudyConfig:
    """Validate a whole study (a parsed TOML document)."""
    unknown = sorted(set(raw) - set(KNOWN_TABLES))
    if "system" in raw:
        raise ConfigError("[system]", "…", "this is a system study (several bodies): gcms run "
                          "runs it; the other commands take one body's study")
    if unknown:
        raise ConfigError(f"[{unknown[0]}]", raw[unknown[0]],
                          "unknown table (allowed: " + ", ".join(KNOWN_TABLES) + ")")
    geom = parse_geometry(raw.get("geometry"))
    cfg = StudyConfig(
        geometry=geom,
        mesh=parse_mesh(raw.get("mesh"), geom),
        material=parse_material(raw.get("material")),
        modes=parse_modes(raw.get("modes")),
        selection=parse_selection(raw.get("selection")),
        scene=parse_scene(raw.get("scene")),
        outputs=parse_outputs(raw.get("outputs")),
        basis=parse_basis(raw.get("basis")),
        source=source,
    )
    cfg.plan          # the study's choices, refused here if they do not fit, before any stage
    return cfg


def default_config_text() -> str:
    """The built-in one-body study: the driven inline-4 crankshaft (also shipped as
    ``workflows/default.toml``; ``gcms run`` without a study runs the crank train,
    ``config.system.built_in_system``)."""
    return resources.files("gcms_fenicsx.data").joinpath("default.toml").read_text()


def load_config(path: str | Path | None = None) -> StudyConfig:
    """Read and validate a study file; ``None`` gives the built-in one-body study."""
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
