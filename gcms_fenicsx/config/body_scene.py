"""The scene a system study's joints imply on a flexible body, and the body's study parsed
with it (``config.system``, docs/study-file.md "System studies").

A flexible body's own ``[scene]`` is replaced by one the system's joints imply: a joint at
each group they hold (:data:`SCENE_JOINT`), so ``[basis] attachment = "scene"`` gives it the
attachment modes of the assembly's joints, and its ``elasticity`` (the Saint Venant–Kirchhoff
law puts its coefficients into the reduced model). Bodies whose tables and implied scene are
the same share one reduced model (``model_key``).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from typing import Any, Sequence

import numpy as np

from gcms_fenicsx.config.basis import parse_basis
from gcms_fenicsx.config.basis_choice import BasisChoice, choose_basis
from gcms_fenicsx.config.scene import Scene, SceneError
from gcms_fenicsx.config.study import StudyConfig, parse_config
from gcms_fenicsx.config.table import ConfigError

#: The other end of a joint that holds a body where it starts.
GROUND = "ground"
#: The scene joint a system joint implies on a flexible body's group (its attachment loads).
SCENE_JOINT = {"spherical": "spherical", "revolute": "revolute", "cylindrical": "revolute",
               "prismatic": "fixed", "fixed": "fixed"}


def _implied(joints: Sequence[Any], body: Any) -> list[tuple[dict[str, Any], bool]]:
    """The scene joints the system's ``joints`` imply on ``body`` (:func:`body_scene`), each
    with whether its system joint holds the body to the ground."""
    R0 = body.placement.matrix
    implied: list[tuple[dict[str, Any], bool]] = []
    for j in joints:
        for owner, group, other in ((j.body, j.point, j.to_body), (j.to_body, j.to_point, j.body)):
            if owner == body.name:
                held = sum(e["group"] == group for e, _ in implied)
                entry: dict[str, Any] = {"name": f"{group}_{held}" if held else group,
                                         "type": SCENE_JOINT[j.type], "group": group}
                if entry["type"] == "revolute":
                    entry["axis"] = (np.round(R0.T @ np.array(j.axis), 12) + 0.0).tolist()
                implied.append((entry, other == GROUND))
    return implied


def basis_in_system(body: Any, joints: Sequence[Any]) -> tuple[BasisChoice, Scene | None]:
    """The basis the flexible ``body`` (its study parsed) steps in, and, for the rotor basis,
    the scene of its joints to the ground it is chosen by: ``[basis] kind = "rotor"`` or
    "auto" takes it when the joints that hold the body to the ground leave it turning about
    one axis (``basis_choice.choose_basis``; its joints to other bodies load it, they do not
    turn its axis) and its placement turns it about that axis only. ConfigError for "rotor"
    otherwise, naming the body, the key and why; "auto" is then the full basis."""
    kind, scene = parse_basis(body.tables.get("basis")).kind, body.study.scene
    if kind == "full":
        return BasisChoice("full", None, '[basis] kind = "full"'), None
    ground_names = {entry["name"] for entry, grounded in _implied(joints, body) if grounded}
    ground = (None if scene is None else
              replace(scene, joints=tuple(j for j in scene.joints if j.name in ground_names)))
    where = f"body {body.name!r} ({body.source}): [basis] kind"
    if ground is None or not ground.joints:
        if kind == "rotor":
            raise ConfigError(where, kind, "needs joints to the ground that leave the body "
                              "turning about one axis, and it has none (its joints to other "
                              "bodies load it, they do not hold its axis)")
        return BasisChoice("full", None, "no joint holds it to the ground"), None
    try:
        choice = choose_basis(kind, ground)
    except SceneError as exc:
        raise ConfigError(where, kind, "needs joints to the ground that leave the body turning "
                          f"about one axis (its joints to other bodies load it): {exc}") from exc
    if choice.kind == "rotor":
        axis = np.array(choice.axis)
        if np.abs(body.placement.matrix @ axis - axis).max() > 1e-9:
            why = (f"its rotation turns it about another axis than its rotor axis "
                   f"{np.round(axis, 6).tolist()} (its own coordinates)")
            if kind == "rotor":
                raise ConfigError(where, kind, f"cannot be taken: {why}; the rotor basis holds "
                                  "turns about that axis only")
            return BasisChoice("full", None, why), None
    return choice, (ground if choice.kind == "rotor" else None)


def body_scene(joints: Sequence[Any], body: Any, end_time_s: float, time_step_s: float
               ) -> dict[str, Any] | None:
    """The ``[scene]`` table of the flexible ``body`` (``config.system.FlexibleSpec``) that the
    system's ``joints`` imply: a joint of the scene's kind (:data:`SCENE_JOINT`) at each group
    they hold, its axis in the body's own coordinates, and the body's ``elasticity`` when not
    co-rotated; None when nothing is to be said."""
    implied = [entry for entry, _ in _implied(joints, body)]
    if not implied and body.elasticity == "corotated":
        return None
    return {"end_time": end_time_s, "time_step": time_step_s, "joints": implied,
            **({"elasticity": body.elasticity} if body.elasticity != "corotated" else {})}


#: What a system study's body may not ask of its ``[basis]``: the static shapes are the
#: responses of one body held by its scene's joints (``dynamics.bases``), and the scene a
#: system implies holds every group its joints use, the groups other bodies load as well.
NOT_IN_SYSTEMS = {"shapes": ("static", '"modes"')}


def _check_basis(body: Any) -> None:
    """ConfigError for a ``[basis]`` the assembly's step does not take (:data:`NOT_IN_SYSTEMS`),
    naming the body and where its study is."""
    basis = body.tables.get("basis")
    for key, (refused, allowed) in NOT_IN_SYSTEMS.items():
        if isinstance(basis, dict) and basis.get(key) == refused:
            raise ConfigError(f"body {body.name!r} ({body.source}): [basis] {key}", refused,
                              f"{allowed}: a body of a system study deforms along its modes "
                              "(the static shapes are built for one-body studies only: they "
                              "need the body held by its joints to the ground and loaded at "
                              "the others)")


def body_study(body: Any, scene: dict[str, Any] | None) -> tuple[StudyConfig, str]:
    """The flexible ``body``'s study parsed with ``scene`` added, and its model key (the digest
    of its tables and scene); a ConfigError in it names the body."""
    tables = dict(body.tables) | ({"scene": scene} if scene else {})
    _check_basis(body)
    try:
        # the basis kind is the system's to choose (basis_in_system), not the implied scene's
        study = parse_config(dict(tables, basis=dict(tables.get("basis") or {}, kind="full")),
                             body.source)
        parse_basis(tables.get("basis"))
    except ConfigError as exc:
        raise ConfigError(f"body {body.name!r} ({body.source}): {exc.key}", exc.value,
                          exc.allowed) from exc
    return study, hashlib.sha256(json.dumps(tables, sort_keys=True, default=repr)
                                 .encode()).hexdigest()
