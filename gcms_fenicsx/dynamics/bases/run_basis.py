"""The body a scene runs on: the full basis of a reduced model, or its rotor basis
(``[basis] kind``, ``basis_choice.choose_basis``), and what a summary says about it.
NumPy only.
"""
from __future__ import annotations


import numpy as np

from gcms_fenicsx.config.basis import AttachmentLoad, ScenePatterns
from gcms_fenicsx.config.basis_choice import choose_basis
from gcms_fenicsx.dynamics.bodies.body import Body, body_from_reduced, elastic_modes
from gcms_fenicsx.dynamics.stepping.initial import initial_coordinates
from gcms_fenicsx.dynamics.bodies.rotor import RotorBody, rotor_body
from gcms_fenicsx.dynamics.bases.rotor_basis import attachment_fields, generalized_loads, mode_fields
from gcms_fenicsx.config.scene import Scene, SceneError
from gcms_fenicsx.dynamics.bases.static_shapes import shape_model, static_shapes
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.runtime.progress import Progress, quiet


def in_basis(model: ReducedModel, body: Body, scene: Scene, kind: str = "full",
             attachment: tuple[AttachmentLoad, ...] = (), progress: Progress = quiet,
             static: ScenePatterns | None = None) -> Body | RotorBody:
    """The body the scene runs on for ``[basis] kind`` ("full", "rotor" or "auto",
    ``basis_choice.choose_basis``): ``body`` itself, or its rotor body with the model's
    elastic modes (and, for ``attachment`` loads, ``config.basis.AttachmentLoad``, their
    attachment modes). A scene whose initial mode the rotor basis does not hold (a mode of the
    full basis beyond the model's free-free ones) runs in the full basis under "auto" and is
    refused under "rotor". With the scene's ``static`` patterns (``[basis] shapes =
    "static"``, ``config.basis.scene_patterns``) the body's fields are the held body's static
    shapes instead (``static_shapes``): the full basis on them, or the rotor basis."""
    choice = choose_basis(kind, scene)
    shapes = None
    if static is not None:
        hz, shapes = static_shapes(body, scene, static)
        progress(f"shapes: {shapes.shape[1]} static shapes of the held body: {len(hz)} held "
                 f"modes below the scene's band of {static.band_hz:.4g} Hz"
                 + (f" ({', '.join(f'{f:.4g}' for f in hz)} Hz)" if len(hz) else "")
                 + f" and the responses to {len(static.loads)} load patterns")
        if not shapes.shape[1]:
            progress("warning: no static shapes: the scene loads the body with nothing and "
                     "excites none of its held modes, so it runs rigid")
    if choice.kind == "full":
        if kind == "auto":
            progress(f"basis: full ({choice.reason})")
        if shapes is None:
            return body
        shaped = body_from_reduced(shape_model(model, shapes))
        progress(f"basis: full on the static shapes: {shaped.dofs} coordinates instead of "
                 f"{body.dofs}")
        return shaped
    assert choice.axis is not None
    if shapes is not None:
        fields = shapes
    else:
        lam, psi = elastic_modes(body)
        fields = mode_fields(psi, len(model.frequencies_hz))
        if attachment:
            loads = generalized_loads(body, attachment)
            fields = np.hstack([fields, attachment_fields(body, loads, lam, psi, fields)])
    rotor = rotor_body(body, np.array(choice.axis, float), fields)
    outside = _initial_outside(rotor, scene)
    if outside is not None:
        if kind == "rotor":
            raise SceneError(f'[scene.initial] mode {scene.initial.mode} is not in the rotor '
                             f"basis ({outside}); choose a lower mode or [basis] kind = "
                             '"full" or "auto"')
        progress(f"basis: full (the initial mode {scene.initial.mode} is not in the rotor "
                 f"basis: {outside})")
        return body
    dropped = rotor.basis.dropped
    progress(f"basis: rotor ({choice.reason}): {rotor.dofs} coordinates instead of "
             f"{body.dofs}" + (f"; {len(dropped)} columns dropped as dependent" if dropped
                               else ""))
    return rotor


#: The initial deformation of the full basis must lie in the rotor basis to this relative
#: Mr-norm.
ROTOR_START = 1e-6


def _initial_outside(rotor: RotorBody, scene: Scene) -> str | None:
    """Why the scene's initial state is not in the rotor basis, or None: the part of its
    deformation q − q0 outside it, relative, when above ROTOR_START."""
    if scene.initial.mode is None:
        return None
    _, residual = rotor.project(initial_coordinates(rotor.full, scene.initial))
    if residual <= ROTOR_START:
        return None
    return (f"{residual:.2g} of its shape lies outside it; the rotor basis holds the model's "
            f"{rotor.basis.fields} fields, the free-free modes first, not the other modes of "
            "the full basis")


def rotor_summary(rotor: RotorBody) -> dict:
    """What the rotor basis is: its axis, its coordinates beside the full basis's, and the
    columns dropped as dependent."""
    return {"axis": rotor.basis.axis.tolist(), "coordinates": rotor.dofs,
            "full_coordinates": rotor.full.dofs, "names": list(rotor.basis.names),
            "dropped": list(rotor.basis.dropped)}
