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
from dataclasses import asdict, dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from geometry.params import BeamParams, CrankshaftParams, MeshParams

from gcms_fenicsx import __version__
from gcms_fenicsx.config.geometry import parse_geometry, parse_mesh
from gcms_fenicsx.dynamics.scene import Scene, parse_scene
from gcms_fenicsx.config.material import Material, parse_material
from gcms_fenicsx.config.modes import ModesConfig, parse_modes
from gcms_fenicsx.config.basis import BasisConfig, attachment_loads, parse_basis, static_loads
from gcms_fenicsx.dynamics.basis_choice import choose_basis
from gcms_fenicsx.config.outputs import OutputsConfig, parse_outputs
from gcms_fenicsx.config.scene_band import scene_band
from gcms_fenicsx.config.selection import SelectionConfig, parse_selection
from gcms_fenicsx.config.table import ConfigError

#: Tables a study file may contain, in pipeline order.
KNOWN_TABLES = ("geometry", "mesh", "material", "modes", "selection", "scene", "outputs",
                "basis")
#: The tables a reduced model depends on: its input hash, and the key of its cache.
REDUCED_MODEL_TABLES = ("geometry", "mesh", "material", "modes", "selection")
#: The tables the mesh depends on: the key of mesh.msh.
MESH_TABLES = ("geometry", "mesh")


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

    def digest(self, *tables: str) -> str:
        """SHA-256 of the named tables (all when none given) and of this package's version: a
        cache key and provenance hash."""
        names = tables or KNOWN_TABLES
        payload = {name: _plain(getattr(self, name)) for name in names}
        payload["gcms_fenicsx_version"] = __version__
        return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()

    @property
    def needs_svk(self) -> bool:
        """Whether the scene's elastic law needs the Saint Venant–Kirchhoff coefficients in the
        reduced model (``[scene] elasticity = "svk"``)."""
        return self.scene is not None and self.scene.elasticity == "svk"

    def reduced_key(self, svk: bool | None = None) -> str:
        """The key of a cached reduced model: its tables' digest, and the elastic law when it
        carries the SVK coefficients (a co-rotated study's key is the digest alone). ``svk``:
        the key of the model with (True) or without (False) them, instead of what the scene
        needs."""
        digest = self.digest(*REDUCED_MODEL_TABLES)
        if not (self.needs_svk if svk is None else svk):
            return digest
        return hashlib.sha256(json.dumps([digest, "svk"]).encode()).hexdigest()

    def served_by(self, input_hash: str) -> bool:
        """Whether a reduced model of key ``input_hash`` is this study's: made from its tables,
        with the SVK coefficients if the scene needs them (one with them also serves a
        co-rotated scene)."""
        return input_hash == self.reduced_key() or (
            not self.needs_svk and input_hash == self.reduced_key(svk=True))

    def modes_key(self) -> str:
        """The key of cached free-free modes: what the solve depends on apart from how many
        modes it returns (more modes than asked serve as well: fewer are a leading block)."""
        accuracy = {"tolerance": self.modes.tolerance,
                    "max_iterations": self.modes.max_iterations}
        if self.modes.attachment is not None:
            accuracy["attachment"] = [asdict(load) for load in self.modes.attachment]
        return hashlib.sha256(json.dumps([self.digest("geometry", "mesh", "material"),
                                          accuracy]).encode()).hexdigest()


def parse_config(raw: Mapping[str, Any], source: str = "<dict>") -> StudyConfig:
    """Validate a whole study (a parsed TOML document)."""
    unknown = sorted(set(raw) - set(KNOWN_TABLES))
    if unknown:
        raise ConfigError(f"[{unknown[0]}]", raw[unknown[0]],
                          "unknown table (allowed: " + ", ".join(KNOWN_TABLES) + ")")
    geom = parse_geometry(raw.get("geometry"))
    modes, scene = parse_modes(raw.get("modes")), parse_scene(raw.get("scene"))
    if modes.count is None and modes.max_frequency_hz is None:  # count = "auto"
        if scene is None:
            raise ConfigError("[modes] count", "auto", "needs a [scene]: the band of modes "
                              "comes from its loads, drive and time step; give a number")
        band = scene_band(scene)
        modes = replace(modes, max_frequency_hz=band.max_frequency_hz, band=band)
    basis = parse_basis(raw.get("basis"))
    if basis.kind == "rotor" and scene is not None:
        choose_basis(basis.kind, scene)          # refused here, before any stage runs
    static_loads(basis, scene)                   # likewise
    modes = replace(modes, attachment=attachment_loads(basis, scene) or None)
    return StudyConfig(
        geometry=geom,
        mesh=parse_mesh(raw.get("mesh"), geom),
        material=parse_material(raw.get("material")),
        modes=modes,
        selection=parse_selection(raw.get("selection")),
        scene=scene,
        outputs=parse_outputs(raw.get("outputs")),
        basis=basis,
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


#: Fields added to a table after files keyed by its hash were written: left out of the hash
#: while they hold their default None, so those files are still reused.
LATER_FIELDS = ("band", "attachment")


def _plain(obj: Any) -> Any:
    if hasattr(obj, "__dataclass_fields__"):
        fields = {key: value for key, value in asdict(obj).items()
                  if not (key in LATER_FIELDS and value is None)}
        return {"type": type(obj).__name__, **fields}
    return obj
