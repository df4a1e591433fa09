"""The columns of the rotor basis (docs/design.md §7.1; the kinematics and the elastic law
are ``rotor``'s, when a scene gets it ``config.basis.choose_basis``).

For the axis a with (b1, b2) completing it to a right-handed orthonormal frame, every vector
field w gives the columns A1 w (axial) and the pair A2 w, A3 w (in-plane) of q = B p
(``rotor``, (R1)); the fields are the body's centred position X̃, its two tilts b_k × X̃, and
the elastic (and attachment) modes a caller gives. Columns are pruned as the selection prunes
fields: axial ones among themselves and pairs whole, since axial and in-plane columns are
Mr-orthogonal and T(90°) turns a pair's columns into each other. NumPy only.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from gcms_fenicsx.config.basis import AttachmentLoad
from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.dynamics.constraints.joints import plane_basis
from gcms_fenicsx.numerics.group_geometry import moment_lever
from gcms_fenicsx.numerics.rotation import skew

#: A candidate column is kept when its part independent of the columns kept before it has at
#: least this fraction of its Mr-norm (the selection's svd_tolerance, docs/design.md §4).
RELATIVE_RESIDUAL = 1e-6


@dataclass(frozen=True)
class RotorBasis:
    """The columns of B (n × np, q = B p) and what they are, in the order of p: ``pairs``
    in-plane pairs ((t1, t2), (cos φ, sin φ), then (ξ, ζ) of the kept fields), then the axial
    coordinates (t_a, κ, then η of the kept fields). ``dropped``: the fields whose axial or
    in-plane columns depend on the kept ones, with their relative residuals."""

    axis: np.ndarray
    plane: np.ndarray
    coordinates: np.ndarray
    pairs: int
    names: tuple[str, ...]
    rest: np.ndarray       # p0: B p0 = q0
    dropped: tuple[dict, ...]
    fields: int            # the vector fields its columns came from (X̃ and the tilts too)

    @property
    def dofs(self) -> int:
        return self.coordinates.shape[1]

    @property
    def translation(self) -> tuple[int, int, int]:
        """The indices of t along a, b1 and b2."""
        return 2 * self.pairs, 0, 1


def axis_projectors(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A1 = a aᵀ, A2 = I − a aᵀ, A3 = [a]× of the unit axis a: R(φ) = A1 + cos φ A2 + sin φ A3."""
    return np.outer(a, a), np.eye(3) - np.outer(a, a), skew(a)


def axis_frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(a, [b1 b2]) with (a, b1, b2) right-handed and orthonormal, a = axis / |axis|: the
    joints' own (``joints.plane_basis``), so the rotor's pairs are the drive rows' plane."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return a, np.column_stack(plane_basis(a))


def rotor_basis(body: Body, axis: np.ndarray, fields: np.ndarray,
                tolerance: float = RELATIVE_RESIDUAL) -> RotorBasis:
    """B of (R1) for the vector fields ``fields`` (n × k, each a q of the full basis: an
    elastic mode's or an attachment mode's coordinates), pruned (module docstring).

    Besides X̃ the fields include the two tilts b_k × X̃: the joints hold them, and without
    them a moment about an axis ⊥ a would be resisted by the stiffness of turned mode
    columns instead of by the joints (their pairs span one plane, so one pair is dropped:
    4 columns, the rotations about b1 and b2 and the shears that go with them).

    Columns are compared in the Mr-norm: with Mr = L Lᵀ they are mapped to Lᵀ b, and their
    part independent of the kept ones (a QR of the kept ones, applied twice) is measured
    against the field's own norm; a field's axial column and its pair are kept or dropped
    separately (t, κ and (cos φ, sin φ) always stay).
    """
    a, plane = axis_frame(axis)
    A = axis_projectors(a)
    nf = body.field_count
    L = np.linalg.cholesky(np.asarray(body.mass))

    def turned(q: np.ndarray, k: int) -> np.ndarray:
        return q.reshape(nf, 3).dot(A[k].T).ravel()

    center = body.center_of_mass(body.q0)
    centred = body.q0.reshape(nf, 3) - np.outer(body.unit, center)
    tilts = [("tilt_b1", (centred @ skew(plane[:, 0]).T).ravel()),
             ("tilt_b2", (centred @ skew(plane[:, 1]).T).ravel())]
    shapes = ([("X", centred.ravel())] + tilts
              + [(f"w{j + 1}", fields[:, j]) for j in range(fields.shape[1])])
    translation = [np.kron(body.unit, d) for d in (a, *plane.T)]
    axial_cols, axial_names = [translation[0]], ["t_a"]
    pair_cols, pair_names = [translation[1:]], [("t_1", "t_2")]
    kept_axial, kept_pairs = [L.T.dot(translation[0])], [L.T.dot(v) for v in translation[1:]]
    dropped: list[dict] = []
    for name, w in shapes:
        rigid = name == "X"
        size = float(np.linalg.norm(L.T.dot(w)))
        col = turned(w, 0)
        residual = _residual(L.T.dot(col), kept_axial, size)
        if rigid or residual > tolerance:
            axial_cols.append(col)
            axial_names.append("kappa" if rigid else f"eta_{name}")
            kept_axial.append(L.T.dot(col))
        else:
            dropped.append({"field": name, "column": "axial", "relative_residual": residual})
        pair = [turned(w, 1), turned(w, 2)]
        residual = _residual(L.T.dot(pair[0]), kept_pairs, size)
        if rigid or residual > tolerance:
            pair_cols.append(pair)
            pair_names.append(("cos", "sin") if rigid else (f"xi_{name}", f"zeta_{name}"))
            kept_pairs += [L.T.dot(v) for v in pair]
        else:
            dropped.append({"field": name, "column": "in-plane", "relative_residual": residual})
    B = np.column_stack([v for pair in pair_cols for v in pair] + axial_cols)
    k = len(pair_cols)
    rest = np.zeros(B.shape[1])
    rest[[2 * k, 0, 1]] = a @ center, plane[:, 0] @ center, plane[:, 1] @ center
    rest[2] = rest[2 * k + 1] = 1.0                       # cos φ = κ = 1
    names = tuple(n for pair in pair_names for n in pair) + tuple(axial_names)
    return RotorBasis(axis=a, plane=plane, coordinates=B, pairs=k, names=names, rest=rest,
                      dropped=tuple(dropped), fields=len(shapes))


def _residual(y: np.ndarray, kept: list[np.ndarray], size: float) -> float:
    """|y − its projection on span(kept)| / ``size`` (the Mr-norm of the field y is a column
    of: a column that is a field's round-off, the axial part of a torsion mode say, counts
    as nothing)."""
    if size == 0.0:
        return 0.0
    Qk, _ = np.linalg.qr(np.column_stack(kept))
    r = y - Qk @ (Qk.T @ y)
    r -= Qk @ (Qk.T @ r)
    return float(np.linalg.norm(r)) / size


def mode_fields(modes: np.ndarray, count: int) -> np.ndarray:
    """The lowest ``count`` elastic modes as fields (n × count), from the Mr-orthonormal
    eigenvectors of (Kr, Mr), rigid first (``body.elastic_modes``): the free-free modes the
    reduced model was built from (Rayleigh–Ritz reproduces them, ``reduce``)."""
    return modes[:, 6:6 + count]


def attachment_fields(body: Body, loads: np.ndarray, eigenvalues: np.ndarray,
                      modes: np.ndarray, fields: np.ndarray,
                      tolerance: float = RELATIVE_RESIDUAL) -> np.ndarray:
    """Attachment modes in the full basis (n × k ≤ loads) for generalized unit loads: the
    static responses with inertia relief, u = Σ_elastic ψ ψᵀ f / λ over every elastic mode of
    (Kr, Mr) (``eigenvalues``, ``modes``: the Galerkin solution of K u = P f in span Φ,
    docs/design.md §3.7), Mr-orthogonalised against ``fields`` and scaled to unit Mr-norm, as
    the modes are; a response whose part orthogonal to them is below ``tolerance`` of it
    adds nothing and is left out."""
    U = (modes[:, 6:] / eigenvalues[6:]) @ (modes[:, 6:].T @ loads)
    Mr = body.mass
    before = np.sqrt(np.einsum("ij,ij->j", U, Mr @ U))
    U -= fields @ (fields.T @ (Mr @ U))
    after = np.sqrt(np.einsum("ij,ij->j", U, Mr @ U))
    keep = after > tolerance * before
    return U[:, keep] / after[keep]


def generalized_loads(body: Body, loads: Sequence[AttachmentLoad]) -> np.ndarray:
    """Generalized forces (n × k) of attachment unit loads (``config.basis.AttachmentLoad``):
    a force F at a group's mean position is kron(h, F); a moment about c is the force conjugate
    to the group's small rotation about c, kron(H_G d, c × d) for a lever d ⊥ c in the group's
    span — the joint's moment row itself (``numerics.group_geometry.moment_lever``); the centrifugal load of a
    spin at 1 rad/s about e is Mr applied to the field (I − e eᵀ)(X − x̄_G), the inertia of
    an angular acceleration of 1 rad/s² about e ("tangential") Mr applied to e × (X − x̄_G),
    that of an acceleration of 1 m/s² along e ("gravity") the body's gravity forces for e."""
    cols = []
    for load in loads:
        g = body.groups[load.group]
        direction = np.asarray(load.direction, float)
        if load.kind == "force":
            cols.append(np.kron(g.position, direction))
            continue
        if load.kind == "gravity":
            cols.append(body.gravity @ direction)
            continue
        if load.kind in ("centrifugal", "tangential"):
            radial = body.q0.reshape(-1, 3) - np.outer(body.unit, g.center_m)
            field = (radial - np.outer(radial @ direction, direction)
                     if load.kind == "centrifugal" else radial @ skew(direction).T)
            cols.append(body.mass @ field.ravel())
            continue
        d = moment_lever(g.span, load.group, load.direction, load.turning)
        cols.append(np.kron(g.affine @ d, np.cross(direction, d)))
    return np.column_stack(cols) if cols else np.zeros((body.dofs, 0))
