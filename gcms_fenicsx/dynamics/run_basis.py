"""The body a scene runs on: the full basis of a reduced model, or its rotor basis
(``[basis] kind``, ``rotor_basis.choose_basis``), with the maps the run needs between the two
(its initial state, its summary block). NumPy only.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.rotor import RotorBody, rotor_body
from gcms_fenicsx.dynamics.rotor_basis import attachment_fields, generalized_loads, mode_fields
from gcms_fenicsx.dynamics.scene import Scene, SceneError
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.runtime.progress import Progress, quiet


def in_basis(model: ReducedModel, body: Body, scene: Scene, kind: str = "full",
             attachment: tuple[Any, ...] = (), progress: Progress = quiet) -> Body | RotorBody:
    """The body the scene runs on for ``[basis] kind`` ("full", "rotor" or "auto",
    ``rotor.choose_basis``): ``body`` itself, or its rotor body with the model's elastic modes
    (and, for ``attachment`` loads, ``config.basis.AttachmentLoad``, their attachment modes)."""
    from gcms_fenicsx.config.basis import choose_basis   # config.basis reads dynamics.scene
    choice = choose_basis(kind, scene)
    if choice.kind == "full":
        if kind == "auto":
            progress(f"basis: full ({choice.reason})")
        return body
    assert choice.axis is not None
    fields = mode_fields(body, len(model.frequencies_hz))
    if attachment:
        fields = np.hstack([fields, attachment_fields(body, generalized_loads(body, attachment),
                                                      fields)])
    rotor = rotor_body(body, np.array(choice.axis, float), fields)
    dropped = rotor.basis.dropped
    progress(f"basis: rotor ({choice.reason}): {rotor.dofs} coordinates instead of "
             f"{body.dofs}" + (f"; {len(dropped)} columns dropped as dependent" if dropped
                               else ""))
    return rotor


#: The initial state of the full basis must lie in the rotor basis to this relative Mr-norm.
ROTOR_START = 1e-6


def rotor_start(rotor: RotorBody, q: np.ndarray, scene: Scene) -> np.ndarray:
    """The rotor coordinates of the full basis's initial state q; SceneError when it is not in
    the rotor basis (an initial mode beyond the ones it holds)."""
    p, residual = rotor.project(q)
    if residual > ROTOR_START:
        raise SceneError(
            f"[scene.initial] mode {scene.initial.mode} is not in the rotor basis ({residual:.2g} "
            "of the initial state lies outside it: the rotor basis holds the model's free-free "
            'modes, not the other modes of its full basis); choose a lower mode or [basis] '
            'kind = "full"')
    return p


def rotor_summary(rotor: RotorBody) -> dict:
    """What the rotor basis is: its axis, its coordinates beside the full basis's, and the
    columns dropped as dependent."""
    return {"axis": rotor.basis.axis.tolist(), "coordinates": rotor.dofs,
            "full_coordinates": rotor.full.dofs, "names": list(rotor.basis.names),
            "dropped": list(rotor.basis.dropped)}
