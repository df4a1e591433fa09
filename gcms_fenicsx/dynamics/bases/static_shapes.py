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
Earthquake Eng. Struct. Dyn. 10, 1982, their first block). Held means every joint row and, for
a rigid motion ψ the joints leave free (the turning of undriven revolute joints), its inertia
relief (Mr ψ)ᵀ u = 0 (:func:`held_rows`): a response is

    [Kr  Cᵀ] [u]   [f]
    [C   0 ] [λ] = [0],

and a held mode an eigenvector of (Kr, Mr) on C u = 0 (:func:`held_modes`), both in the
reduced model's span. The right-hand side K u = f − Cᵀλ is self-equilibrated, and the
relief's part (Mr ψ) is a rigid inertia field, which inertia relief removes: so with the
scene's attachment modes the span holds the full model's u (design §3.7) and the Galerkin u
is the full model's, for every Nm. The shapes are made Mr-orthogonal to the rigid modes and to
each other, Mr-normalised; one that lies, to ``RELATIVE_RESIDUAL`` of its size, in the span of
those before it adds nothing and is left out.

They become the body's fields either in the rotor basis (three columns each, ``rotor``) or in
the full one: :func:`shape_model` is the reduced model whose fields span the shapes' x, y and
z components, F T (with the four rigid fields kept), so Mr, Kr and the gravity forces
transform as (T ⊗ I3)ᵀ · (T ⊗ I3): the same model restricted to the shapes. NumPy only.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from gcms_fenicsx.config.basis import ScenePatterns
from gcms_fenicsx.dynamics.bodies.body import Body, mass_normalised_modes
from gcms_fenicsx.dynamics.constraints.joints import build_constraints
from gcms_fenicsx.dynamics.bases.rotor_basis import RELATIVE_RESIDUAL, generalized_loads
from gcms_fenicsx.config.scene import Scene
from gcms_fenicsx.dynamics.constraints.statics import dense_kkt_solve, free_rigid_motions
from gcms_fenicsx.files.reduced_model import ReducedModel

RIGID_FIELD_COUNT = 4


def held_rows(body: Body, scene: Scene) -> tuple[np.ndarray, int]:
    """(C, f): the rows that hold ``body`` for its static shapes — its joints' independent rows
    (``joints.build_constraints``) and, for each of the f rigid motions ψ they leave free (the
    turning about the axis of undriven revolute joints), its inertia relief (Mr ψ)ᵀ u = 0: the
    reaction is the inertia of an acceleration along ψ, distributed as the mass is, not a
    moment at a joint (module docstring)."""
    c = build_constraints(body, scene.joints, body.q0)
    C = c.jacobian(c.directions) if c.count else np.zeros((0, body.dofs))
    free = free_rigid_motions(C, body.rigid_velocities(body.q0))
    return np.vstack([C, (np.asarray(body.mass) @ free).T]), free.shape[1]


def held_modes(body: Body, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The modes of ``body`` held by the independent ``rows`` C (``held_rows``) in its span,
    lowest first: (frequencies in Hz, modes n × k). With the rows' null space Z (C Z = 0),
    the eigenpairs of (Zᵀ Kr Z, Zᵀ Mr Z) (Rayleigh–Ritz in span Φ: upper bounds of the full
    model's held frequencies, close for the lowest)."""
    Z = np.linalg.svd(rows)[2][rows.shape[0]:].T
    lam, Y = mass_normalised_modes(Z.T @ np.asarray(body.stiffness) @ Z,
                                   Z.T @ np.asarray(body.mass) @ Z)
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi), Z @ Y


def static_shapes(body: Body, scene: Scene, patterns: ScenePatterns,
                  tolerance: float = RELATIVE_RESIDUAL) -> tuple[np.ndarray, np.ndarray]:
    """(the held modes' frequencies in Hz, the shapes): the held body's modes below the band
    ``patterns.band_hz``, then its static responses to the load patterns ``patterns.loads``
    (``config.basis.ScenePatterns``; the angular acceleration's, "tangential", only when a
    joint holds the turning: when it is free its inertia relief holds it), each a q of the
    full basis (n × k), Mr-orthonormal and Mr-orthogonal to the rigid modes (module
    docstring)."""
    rows, free = held_rows(body, scene)
    loads = [ld for ld in patterns.loads if not (free and ld.kind == "tangential")]
    F = generalized_loads(body, loads)
    U = dense_kkt_solve(body.stiffness, rows,
                        np.vstack([F, np.zeros((rows.shape[0], F.shape[1]))]))[:body.dofs]
    hz, modes = held_modes(body, rows)
    below = hz < patterns.band_hz
    return hz[below], _orthonormal(body, np.hstack([modes[:, below], U]), tolerance)


def _orthonormal(body: Body, U: np.ndarray, tolerance: float) -> np.ndarray:
    """The columns of U made Mr-orthogonal to the rigid modes and to those before them (twice:
    round-off), Mr-normalised; one whose part left is below ``tolerance`` of it is dropped."""
    Mr = np.asarray(body.mass)
    kept = body.rigid_velocities(body.q0)
    kept = kept @ np.linalg.inv(np.linalg.cholesky(kept.T @ Mr @ kept)).T   # Mr-orthonormal
    shapes = []
    for u in U.T:
        size = np.sqrt(u @ Mr @ u)
        for _ in range(2):
            u = u - kept @ (kept.T @ (Mr @ u))
        norm = np.sqrt(u @ Mr @ u)
        if size > 0.0 and norm > tolerance * size:
            shapes.append(u / norm)
            kept = np.column_stack([kept, u / norm])
    return np.column_stack(shapes) if shapes else np.zeros((body.dofs, 0))


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
    Q, _ = np.linalg.qr(L.T[:, :RIGID_FIELD_COUNT])           # the rigid fields, in Lᵀ
    for _ in range(2):
        Y -= Q @ (Q.T @ Y)
    U, sigma, _ = np.linalg.svd(Y, full_matrices=False)
    kept = U[:, sigma > tolerance * sigma[0]] if k else U[:, :0]
    T = np.hstack([np.eye(nf)[:, :RIGID_FIELD_COUNT], np.linalg.solve(L.T, kept)])
    names = model.field_names[:RIGID_FIELD_COUNT] + tuple(
        f"static_field{i + 1}" for i in range(kept.shape[1]))
    T3 = np.kron(T, np.eye(3))

    def restricted(A: np.ndarray) -> np.ndarray:
        B = T3.T @ A @ T3
        return 0.5 * (B + B.T)

    return replace(model, mass=restricted(model.mass), stiffness=restricted(model.stiffness),
                   gravity=T3.T @ model.gravity, fields=model.fields @ T,
                   field_names=names, frequencies_hz=np.zeros(0),
                   reduced_frequencies_hz=np.zeros(0), svk=None)
