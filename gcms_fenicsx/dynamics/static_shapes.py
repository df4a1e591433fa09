"""The static shapes of a held body (``[basis] shapes = "static"``, docs/design.md §7.1): the
held body's modes in the scene's band and its static responses to the scene's loads, in place
of the free-free modes.

A scene whose joints hold the body, up to at most a rotation about one axis a, deforms it
under a few load patterns only: each load along the directions it takes in the body's frame,
gravity likewise, and, for the rotation the joints leave, the inertia of its angular
acceleration (the field a × (X − x̄_G)) and of its spin (the centrifugal field)
(``config.basis.static_loads``). The held body's modes above the band of frequencies the
scene excites (``config.scene_band``) answer to these quasi-statically, those in it
dynamically: so the shapes are the held modes below the band and the static responses to the
patterns (the mode-acceleration idea; load-dependent Ritz vectors of Wilson, Yuan & Dickens,
Earthquake Eng. Struct. Dyn. 10, 1982, their first block). A response is

    [Kr  Cᵀ] [u]   [f]
    [C   0 ] [λ] = [0]        (``statics.held_static``, every joint row; a revolute joint
                               without a drive is held about its axis for it),

and a held mode an eigenvector of (Kr, Mr) on C u = 0 (:func:`held_modes`), both in the
reduced model's span — with the scene's attachment modes the span holds the full model's u
(design §3.7), so the Galerkin u is the full model's. The shapes are made Mr-orthogonal to the
rigid modes and to each other, Mr-normalised; one that lies, to ``RELATIVE_RESIDUAL`` of its
size, in the span of those before it adds nothing and is left out.

They become the body's fields either in the rotor basis (three columns each, ``rotor``) or in
the full one: :func:`shape_model` is the reduced model whose fields are the shapes' x, y and z
components, F T (with the four rigid fields kept), so Mr, Kr and the gravity forces transform
as (T ⊗ I3)ᵀ · (T ⊗ I3): the same model restricted to the shapes. NumPy only.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from gcms_fenicsx.dynamics.body import Body
from gcms_fenicsx.dynamics.joints import build_constraints
from gcms_fenicsx.dynamics.rotor_basis import RELATIVE_RESIDUAL, generalized_loads
from gcms_fenicsx.dynamics.scene import Drive, Scene
from gcms_fenicsx.dynamics.statics import held_static
from gcms_fenicsx.files.reduced_model import ReducedModel

RIGID_FIELDS = 4


def held_scene(scene: Scene) -> Scene:
    """The scene with nothing left to turn: when no joint carries a drive, the first revolute
    one is held about its axis (a drive at rest), so the static problem has one solution."""
    if any(j.drive is not None for j in scene.joints):
        return scene
    joints = list(scene.joints)
    for k, j in enumerate(joints):
        if j.type == "revolute":
            joints[k] = replace(j, drive=Drive(angular_velocity=0.0))
            break
    return replace(scene, joints=tuple(joints))


def held_modes(body: Body, scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The modes of ``body`` held by ``scene``'s joints (``held_scene``) in its span, lowest
    first: (frequencies in Hz, modes n × k). With the rows' null space Z (C Z = 0), the
    eigenpairs of (Zᵀ Kr Z, Zᵀ Mr Z) (Rayleigh–Ritz in span Φ: upper bounds of the full
    model's held frequencies, close for the lowest)."""
    c = build_constraints(body, held_scene(scene).joints, body.q0)
    Z = np.linalg.svd(c.jacobian(c.directions))[2][c.count:].T
    Mz, Kz = Z.T @ np.asarray(body.mass) @ Z, Z.T @ np.asarray(body.stiffness) @ Z
    L_inv = np.linalg.inv(np.linalg.cholesky(0.5 * (Mz + Mz.T)))
    A = L_inv @ Kz @ L_inv.T
    lam, Y = np.linalg.eigh(0.5 * (A + A.T))
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), Z @ (L_inv.T @ Y)


def static_shapes(body: Body, scene: Scene, patterns: Any,
                  tolerance: float = RELATIVE_RESIDUAL) -> tuple[np.ndarray, np.ndarray]:
    """(the held modes' frequencies in Hz, the shapes): the held body's modes below the band
    ``patterns.band_hz``, then its static responses to the load patterns ``patterns.loads``
    (``config.basis.ScenePatterns``), each a q of the full basis (n × k),
    Mr-orthonormal and Mr-orthogonal to the rigid modes (module docstring)."""
    U = held_static(body, held_scene(scene),
                    generalized_loads(body, patterns.loads)).displacement
    hz, modes = held_modes(body, scene)
    below = hz < patterns.band_hz
    U = np.hstack([modes[:, below], U])
    Mr = np.asarray(body.mass)
    kept = body.rigid_velocities(body.q0)
    kept = kept @ np.linalg.inv(np.linalg.cholesky(kept.T @ Mr @ kept)).T   # Mr-orthonormal
    shapes = []
    for u in U.T:
        size = np.sqrt(u @ Mr @ u)
        for _ in range(2):                                                    # twice: round-off
            u = u - kept @ (kept.T @ (Mr @ u))
        norm = np.sqrt(u @ Mr @ u)
        if size > 0.0 and norm > tolerance * size:
            shapes.append(u / norm)
            kept = np.column_stack([kept, u / norm])
    return hz[below], np.column_stack(shapes) if shapes else np.zeros((body.dofs, 0))


def shape_model(model: ReducedModel, shapes: np.ndarray,
                tolerance: float = RELATIVE_RESIDUAL) -> ReducedModel:
    """The reduced model of the full basis on ``shapes`` (n × k, q's of ``model``): fields
    F T with T keeping the four rigid fields and, for the rest, a G-orthonormal basis
    (G = Fᵀ Ms F) of the shapes' x, y and z components made G-orthogonal to the rigid fields,
    'static_field{i}' (module docstring). The full basis on the shapes is span(F T) ⊗ I3
    whichever basis of the components is taken; the components themselves are not one (a
    planar shape has no out-of-plane component, and a dozen shapes' components can be
    dependent on a model's few dozen fields to 1e-9), so they are taken by their singular
    values in G, those below ``tolerance`` of the largest left out, as the selection leaves
    dependent fields out."""
    nf = model.fields.shape[1]
    k = shapes.shape[1]
    components = shapes.T.reshape(k, nf, 3).transpose(1, 0, 2).reshape(nf, 3 * k)
    L = np.linalg.cholesky(model.mass[::3, ::3])               # G = Fᵀ Ms F = L Lᵀ
    Y = L.T @ components
    Q, _ = np.linalg.qr(L.T[:, :RIGID_FIELDS])                 # the rigid fields, in Lᵀ
    for _ in range(2):
        Y -= Q @ (Q.T @ Y)
    U, sigma, _ = np.linalg.svd(Y, full_matrices=False)
    kept = U[:, sigma > tolerance * sigma[0]] if k else U[:, :0]
    T = np.hstack([np.eye(nf)[:, :RIGID_FIELDS], np.linalg.solve(L.T, kept)])
    names = model.field_names[:RIGID_FIELDS] + tuple(
        f"static_field{i + 1}" for i in range(kept.shape[1]))
    T3 = np.kron(T, np.eye(3))

    def restricted(A: np.ndarray) -> np.ndarray:
        B = T3.T @ A @ T3
        return 0.5 * (B + B.T)

    return replace(model, mass=restricted(model.mass), stiffness=restricted(model.stiffness),
                   gravity=T3.T @ model.gravity, fields=model.fields @ T,
                   field_names=names, frequencies_hz=np.zeros(0),
                   reduced_frequencies_hz=np.zeros(0), svk=None)

