"""The study resolved once: every choice a study makes about its stages is decided here, and
only here, into frozen data each stage takes its piece of (docs/design.md §1, The study's
plan). The stages decide nothing about the study again.

A study is a list of bodies (one today) and the system's scene::

    StudyPlan ─ bodies ─ BodyPlan: geometry, mesh, material, selection, outputs,
              │                    modes (the request: a count, or a band; the attachment loads),
              │                    svk (whether reduced.h5 carries the SVK coefficients),
              │                    keys (mesh.msh, modes.h5, reduced.h5, stress_modes.h5:
              │                          the caches' keys),
              │                    stress (the nodes whose stresses the scene records)
              └─ scene ── ScenePlan: the [scene], its basis kind, its static shapes' patterns,
                                     the attachment loads the run expects in the model

The choices and the function that makes each: the modes request — a count, every mode
below ``max_frequency_hz``, or ``count = "auto"``: the scene's band (:func:`modes_request`);
the attachment loads ([basis] attachment with the scene's joints and loads:
:func:`config.basis.attachment_loads`, called once, in :func:`plan_study`); the basis kind
and shapes ([basis] kind and shapes against the scene: :func:`scene_plan`); the elastic law
(``[scene] elasticity``: :func:`needs_svk`, which also puts the law into the reduced model's
key). The keys keep the payload the earlier ``StudyConfig.digest`` hashed, so caches made
before stay valid.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, replace
from typing import Any

from geometry.params import BeamParams, CrankshaftParams, MeshParams

from gcms_fenicsx import __version__
from gcms_fenicsx.config.basis import (AttachmentLoad, BasisConfig, ScenePatterns,
                                       attachment_loads, scene_patterns)
from gcms_fenicsx.config.basis_choice import choose_basis
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.modes import ModesConfig
from gcms_fenicsx.config.outputs import OutputsConfig
from gcms_fenicsx.config.scene import Scene
from gcms_fenicsx.config.scene_band import scene_band
from gcms_fenicsx.config.selection import SelectionConfig
from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.config.table import ConfigError

#: The tables a reduced model depends on: its input hash, and the key of its cache.
REDUCED_MODEL_TABLES = ("geometry", "mesh", "material", "modes", "selection")
#: The tables the mesh depends on: the key of mesh.msh.
MESH_TABLES = ("geometry", "mesh")
#: Fields added to a table after files keyed by its hash were written: left out of the hash
#: while they hold their default None, so those files are still reused.
LATER_FIELDS = ("band", "attachment")


@dataclass(frozen=True)
class CacheKeys:
    """The keys of a body's cached products (``app.stage_cache``): mesh.msh ([geometry] and
    [mesh]), modes.h5 (what the solve depends on but the mode count: more modes serve as
    well) and reduced.h5 (its tables, and the elastic law when it carries the SVK
    coefficients); ``serving``: the reduced models' keys that serve the study (one with the
    SVK coefficients also serves a co-rotated scene)."""

    mesh: str
    modes: str
    reduced: str
    serving: tuple[str, ...]
    stress: str = ""


@dataclass(frozen=True)
class BodyPlan:
    """What the stages of one body receive."""

    name: str
    geometry: BeamParams | CrankshaftParams
    mesh: MeshParams
    material: Material
    modes: ModesConfig
    selection: SelectionConfig
    outputs: OutputsConfig
    svk: bool
    keys: CacheKeys
    stress: StressOutputs | None = None

    def digest(self, *tables: str) -> str:
        """SHA-256 of the named tables as this plan resolved them (the modes request with its
        band and attachment loads) and of this package's version."""
        return tables_digest({name: getattr(self, name) for name in tables})

    def served_by(self, input_hash: str) -> bool:
        """Whether a reduced model of key ``input_hash`` is this body's."""
        return input_hash in self.keys.serving


@dataclass(frozen=True)
class ScenePlan:
    """What the simulation stage receives: the scene, the basis kind it runs in, the static
    shapes' patterns (None: the modes), and the attachment loads whose modes the study's
    model holds (none: ``attachment``, the [basis] value that asked for none)."""

    scene: Scene
    basis: str
    shapes: ScenePatterns | None
    attachment: tuple[AttachmentLoad, ...]
    attachment_setting: str


@dataclass(frozen=True)
class StudyPlan:
    """The bodies' plans and the system's scene (None: the study simulates nothing)."""

    source: str
    bodies: tuple[BodyPlan, ...]
    scene: ScenePlan | None

    @property
    def body(self) -> BodyPlan:
        """The study's one body (every study has one today)."""
        (only,) = self.bodies
        return only


def tables_digest(tables: dict[str, Any]) -> str:
    """SHA-256 of ``tables`` (name → parsed table) and this package's version: a cache key and
    provenance hash."""
    payload = {name: _plain(table) for name, table in tables.items()}
    payload["gcms_fenicsx_version"] = __version__
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _plain(obj: Any) -> Any:
    if hasattr(obj, "__dataclass_fields__"):
        fields = {key: value for key, value in asdict(obj).items()
                  if not (key in LATER_FIELDS and value is None)}
        return {"type": type(obj).__name__, **fields}
    return obj


def modes_request(modes: ModesConfig, scene: Scene | None,
                  attachment: tuple[AttachmentLoad, ...]) -> ModesConfig:
    """The modes the eigen-solve returns: ``count``, or every elastic mode below
    ``max_frequency_hz``, which ``count = "auto"`` sets to the scene's band
    (``config.scene_band``; ConfigError without a scene); with the ``attachment`` loads."""
    if modes.count is None and modes.max_frequency_hz is None:
        if scene is None:
            raise ConfigError("[modes] count", "auto", "needs a [scene]: the band of modes "
                              "comes from its loads, drive and time step; give a number")
        band = scene_band(scene)
        modes = replace(modes, max_frequency_hz=band.max_frequency_hz, band=band)
    return replace(modes, attachment=attachment or None)


def needs_svk(scene: Scene | None) -> bool:
    """Whether the scene's elastic law needs the Saint Venant–Kirchhoff coefficients in the
    reduced model (``[scene] elasticity = "svk"``); its compatibility with the rest of the
    scene is the scene table's (``config.scene``), with the basis :func:`scene_plan`'s."""
    return scene is not None and scene.elasticity == "svk"


def cache_keys(body: BodyPlan) -> CacheKeys:
    """The keys of ``body``'s cached products (:class:`CacheKeys`)."""
    reduced = body.digest(*REDUCED_MODEL_TABLES)
    with_svk = hashlib.sha256(json.dumps([reduced, "svk"]).encode()).hexdigest()
    accuracy: dict[str, Any] = {"tolerance": body.modes.tolerance,
                                "max_iterations": body.modes.max_iterations}
    if body.modes.attachment is not None:
        accuracy["attachment"] = [asdict(load) for load in body.modes.attachment]
    modes = hashlib.sha256(json.dumps([body.digest("geometry", "mesh", "material"),
                                       accuracy]).encode()).hexdigest()
    mesh = body.digest(*MESH_TABLES)
    return CacheKeys(mesh=mesh, modes=modes, reduced=with_svk if body.svk else reduced,
                     serving=(with_svk,) if body.svk else (reduced, with_svk),
                     stress=stress_key(mesh, body.stress))


def stress_key(mesh_key: str, stress: StressOutputs | None) -> str:
    """The key of the stress modes (``stress_modes.h5``): the mesh's and the nodes they cover
    (the groups, the surface, every node when whole-body stresses are written); "" when the
    scene asks for no stresses."""
    if stress is None:
        return ""
    nodes = {"groups": sorted(stress.groups), "surface": stress.surface,
             "whole_body": stress.whole_body}
    return hashlib.sha256(json.dumps([mesh_key, "stress", nodes]).encode()).hexdigest()


def scene_plan(scene: Scene | None, basis: BasisConfig,
               attachment: tuple[AttachmentLoad, ...]) -> ScenePlan | None:
    """The scene's piece of the plan: [basis] kind checked against the scene ("rotor" refused
    naming the joints that do not allow it; "auto" is chosen when the run starts, from the
    same rule), the static shapes' patterns of [basis] shapes (ConfigError where the scene
    cannot have them)."""
    if scene is None:
        scene_patterns(basis, None)              # shapes = "static" without a scene: refused
        return None
    if basis.kind == "rotor":
        choose_basis(basis.kind, scene)
    return ScenePlan(scene=scene, basis=basis.kind, shapes=scene_patterns(basis, scene),
                     attachment=attachment, attachment_setting=basis.attachment)


def plan_study(source: str, geometry: BeamParams | CrankshaftParams, mesh: MeshParams,
               material: Material, modes: ModesConfig, selection: SelectionConfig,
               scene: Scene | None, outputs: OutputsConfig, basis: BasisConfig) -> StudyPlan:
    """Resolve a study's tables, as read (``config.study.StudyConfig``), into its plan (module
    docstring)."""
    attachment = attachment_loads(basis, scene)
    body = BodyPlan(name="body", geometry=geometry, mesh=mesh, material=material,
                    modes=modes_request(modes, scene, attachment), selection=selection,
                    outputs=outputs, svk=needs_svk(scene), keys=CacheKeys("", "", "", ()),
                    stress=scene.outputs.stress if scene is not None else None)
    body = replace(body, keys=cache_keys(body))
    return StudyPlan(source=source, bodies=(body,), scene=scene_plan(scene, basis, attachment))
