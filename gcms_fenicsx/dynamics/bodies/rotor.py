"""The rotor basis: a body that may turn about one fixed axis only, in three coordinates per
mode instead of nine (Ziegler, Humer, Pechstein & Gerstmayr, J. Comput. Nonlinear Dynam.
11(4), 2016; docs/design.md §7.1).

With the axis a and (b1, b2) completing it to a right-handed orthonormal frame,
R(φ) = A1 + cos φ A2 + sin φ A3 (A1 = a aᵀ, A2 = I − a aᵀ, A3 = [a]×). A body turned by
R(φ) and deformed along the vector fields w_j (its centred position X̃ = X − c, its two
tilts and its elastic modes: ``rotor_basis``) is

    x = t + Σ_j (A1 w_j η_j + A2 w_j ξ_j + A3 w_j ζ_j),                        (R1)

linear in the coordinates p: the translation t (its components along a, b1 and b2) and, for
every field, an axial coordinate η_j and an in-plane pair (ξ_j, ζ_j) — for X̃ these are
(κ, cos φ, sin φ), at rest (1, 1, 0). A_k w is the field w with every 3-vector turned, so in the
GCMS coordinates of the full basis (R1) is q = B p with a constant B (columns Q ↦ Q A_kᵀ),
and Mp = Bᵀ Mr B, Kp = Bᵀ Kr B are constant.

Rotation. Turning the body by R(α) about a maps p to T(α) p: the axial coordinates stay and
every pair turns by the 2 × 2 rotation R2(α) (R(α) A2 = cos α A2 + sin α A3, R(α) A3 =
cos α A3 − sin α A2). The kinetic energy does not change, so Tᵀ Mp T = Mp. Axial and in-plane
columns are Mr-orthogonal (A1 A2 = A1 A3 = 0 pointwise), and a pair's two columns are turned
into each other by T(90°), so the columns are pruned as the full basis prunes its fields: the
axial ones among themselves, the pairs whole (``rotor_basis``).

Elasticity (co-rotated, as ``corotated`` for the full basis). The frame angle ψ is the polar
angle of the in-plane block N of the body's affine map A(q) = Qᵀ H (``body``):
ψ = atan2(w_s · p, w_c · p) with w_c · p = N11 + N22 and w_s · p = N21 − N12, both linear
in p; (w_c + i w_s) · T(α) p = e^{iα} (w_c + i w_s) · p, so ψ turns with the body. With
p_l = T(ψ)ᵀ p and K̃ = P Kp P (P removes t: the centre of mass is t, since X̃ and the modes
have no mass-weighted mean),

    V = ½ eᵀ K̃ e,  e = p_l − p0,                                               (R2)
    Tᵀ ∂V/∂p = f − β s,  f = K̃ e,  c = P Ĵ p_l,  β = f · c,  s = w_s / ρ,       (R3)

ρ = |(w_c · p, w_s · p)| and Ĵ the generator of T (pairs (x, y) ↦ (−y, x), axial ↦ 0).
With J_l = I − c sᵀ (the change of p_l for a local change dp_l, dψ = s · dp_l; exactly
I − Ĵ p_l sᵀ, equal to it in every row but t's, which K̃ does not see) and
d²ψ = −2 (w_c · x)(w_s · x) / ρ² in the local frame, the exact tangent is

    Tᵀ (∂²V/∂p²) T = K̃ − (a sᵀ + s aᵀ) + κ s sᵀ,                                (R4)
    a = K̃ c + Ĵᵀ f − (β / ρ) w_c,  κ = cᵀ K̃ c + fᵀ Ĵ c,

a rank-2 change of frame (:func:`rotor_frame_update`; the full basis has rank 9).
NumPy only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Callable, NamedTuple

import numpy as np

from gcms_fenicsx.dynamics.bodies.body import Body
from gcms_fenicsx.numerics.rotation import InvertedBodyError
from gcms_fenicsx.dynamics.bases.rotor_basis import (RELATIVE_RESIDUAL, RotorBasis, axis_projectors,
                                               rotor_basis)

#: The in-plane affine map N of a body that still has a frame has det N above this fraction
#: of ρ² (ρ = |(N11 + N22, N21 − N12)|; ρ² = 4 det N for a rotation).
COLLAPSED = 1e-12


@dataclass(frozen=True)
class RotorFrame:
    """T(ψ) on rotor coordinates, which hold the ``pairs`` in-plane pairs first, then the axial
    coordinates: the pairs, read as complex numbers ξ + iζ, are multiplied by e^{iψ} (R2(ψ)
    acts on (ξ, ζ) as that product), the axial coordinates stay.

    The frame's rotation is the phase e^{iψ} (``RotorState.rotation``); the 3 × 3 world
    rotation R = A1 + cos ψ A2 + sin ψ A3 is formed only for the constraint directions
    (:meth:`directions`).
    """

    pairs: int
    axis: np.ndarray
    plane: np.ndarray    # (3, 2): b1, b2

    def to_local(self, y: np.ndarray, phase: complex) -> np.ndarray:
        """Tᵀ y."""
        out = y.copy()
        pairs = out[:2 * self.pairs].view(np.complex128)
        pairs *= phase.conjugate()
        return out

    def to_global(self, y: np.ndarray, phase: complex) -> np.ndarray:
        """T y."""
        out = y.copy()
        pairs = out[:2 * self.pairs].view(np.complex128)
        pairs *= phase
        return out

    @staticmethod
    def back_operator(phase: complex) -> complex:
        """What :meth:`back` turns with: the phase itself."""
        return phase

    def back(self, z: np.ndarray, phase: complex) -> np.ndarray:
        """−T z (a Newton correction turned back to global coordinates)."""
        out = -z
        pairs = out[:2 * self.pairs].view(np.complex128)
        pairs *= phase
        return out

    def residual(self, y: np.ndarray, gradient: np.ndarray, phase_state: complex,
                 phase: complex) -> np.ndarray:
        """Tᵀ y + (T_Rᵀ T_state) gradient: y global, ``gradient`` in the state's frame."""
        r = self.to_local(y, phase)
        r += gradient if phase_state == phase else self.to_local(gradient,
                                                                 phase / phase_state)
        return r

    def turn_rows(self, C: np.ndarray, phase: complex, out: np.ndarray) -> None:
        """out = C T for the rows C (m × n): c · (T x) = ⟨c, e^{iψ} x⟩ on each pair, so the
        row's pairs are multiplied by e^{−iψ}: (x, y) ↦ (x cos ψ + y sin ψ, −x sin ψ + y cos ψ)."""
        k = 2 * self.pairs
        out[:, k:] = C[:, k:]
        np.multiply(C[:, :k].view(np.complex128), phase.conjugate(),
                    out=out[:, :k].view(np.complex128))

    @cached_property
    def _projectors(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return axis_projectors(self.axis)

    def rotation_matrix(self, phase: complex) -> np.ndarray:
        """R = A1 + cos ψ A2 + sin ψ A3 (3 × 3, world)."""
        A1, A2, A3 = self._projectors
        return A1 + phase.real * A2 + phase.imag * A3

    def directions(self, U: np.ndarray, phase: complex) -> np.ndarray:
        """Rᵀ u_i for the constraint directions U (m × 3): (U R)."""
        return U.dot(self.rotation_matrix(phase))

    def matrix(self, phase: complex, n: int) -> np.ndarray:
        """T (n × n), dense."""
        return np.column_stack([self.to_global(e, phase) for e in np.eye(n)])

    def generator(self, p: np.ndarray) -> np.ndarray:
        """Ĵ p = d/dα T(α) p at α = 0: the pairs times i, the axial coordinates 0."""
        out = np.zeros_like(p)
        out[:2 * self.pairs].view(np.complex128)[:] = 1j * p[:2 * self.pairs].view(np.complex128)
        return out


@dataclass(frozen=True)
class RotorBody:
    """A body in rotor coordinates p (q = B p of its full body ``full``): what the integrator
    needs (Mp, K̃, p0, the frame weights, the total mass and the size) and the maps between p
    and q."""

    full: Body
    basis: RotorBasis
    mass: np.ndarray
    stiffness: np.ndarray     # K̃ = P Kp P
    q0: np.ndarray            # p0
    plane_map: np.ndarray     # (4, np): N11, N12, N21, N22 (N · p, row by row)
    frame: RotorFrame

    @cached_property
    def weights(self) -> np.ndarray:
        """(w_c, w_s) (2, np): w_c · p = N11 + N22, w_s · p = N21 − N12."""
        N = self.plane_map
        return np.array([N[0] + N[3], N[2] - N[1]])

    @cached_property
    def turn(self) -> np.ndarray:
        """P Ĵ (np × np): Ĵ without t's rows, so that c = P Ĵ p_l is one product."""
        J = np.column_stack([self.frame.generator(e) for e in np.eye(self.dofs)])
        J[list(self.basis.translation), :] = 0.0
        return J

    @property
    def dofs(self) -> int:
        return self.q0.shape[0]

    @property
    def mass_product(self) -> np.ndarray:
        return self.mass

    @property
    def total_mass_kg(self) -> float:
        return self.full.total_mass_kg

    @property
    def size_m(self) -> float:
        return self.full.size_m

    @property
    def coordinates(self) -> np.ndarray:
        return self.basis.coordinates

    @cached_property
    def projector(self) -> np.ndarray:
        """Mp⁻¹ Bᵀ Mr (np × n): the p nearest a q in the kinetic-energy norm."""
        B = self.coordinates
        return np.linalg.solve(self.mass, B.T @ np.asarray(self.full.mass))

    def project(self, q: np.ndarray) -> tuple[np.ndarray, float]:
        """(p, |q − B p|_Mr / |q − q0|_Mr) for the p nearest q (q0 = B p0 is in the basis, so
        the residual is the deformation's, whatever the body's place and size)."""
        p = self.projector @ q
        d = q - self.coordinates @ p
        u = q - self.full.q0
        Mr = self.full.mass
        norm = math.sqrt(max(float(u @ (Mr @ u)), 0.0))
        return p, (math.sqrt(max(float(d @ (Mr @ d)), 0.0)) / norm if norm > 0 else 0.0)

    def rigid_velocities(self, p: np.ndarray) -> np.ndarray:
        """The six rigid velocities of the full basis at B p, nearest in p (np × 6): the
        translations, the rotation about a and the two tilts are in the rotor basis (the
        tilt fields), so they are exact."""
        return self.projector @ self.full.rigid_velocities(self.coordinates @ p)

    def damping_force(self, operator: np.ndarray) -> RotorDamping:
        """The damping force of D₀ = ``operator`` (α Mp + β K̃) on the deformation rate."""
        return RotorDamping(self, _without_translation(operator, self.basis.translation))


def _without_translation(A: np.ndarray, t: tuple[int, ...]) -> np.ndarray:
    """P A P: a copy of A with t's rows and columns zeroed."""
    A = np.array(A, dtype=float)
    A[list(t), :] = 0.0
    A[:, list(t)] = 0.0
    return A


def rotor_body(body: Body, axis: np.ndarray, fields: np.ndarray,
               tolerance: float = RELATIVE_RESIDUAL) -> RotorBody:
    """The rotor body of ``body`` about ``axis`` with the vector fields ``fields`` (n × k)."""
    basis = rotor_basis(body, axis, fields, tolerance)
    B = basis.coordinates
    Mp = B.T @ np.asarray(body.mass @ B)
    Kp = B.T @ np.asarray(body.stiffness @ B)
    K = _without_translation(0.5 * (Kp + Kp.T), basis.translation)
    nf = body.field_count
    E2 = basis.plane
    N = np.array([(E2.T @ B[:, j].reshape(nf, 3).T @ body.affine @ E2).ravel()
                  for j in range(B.shape[1])]).T                       # (4, np)
    frame = RotorFrame(pairs=basis.pairs, axis=basis.axis, plane=basis.plane)
    return RotorBody(full=body, basis=basis, mass=0.5 * (Mp + Mp.T), stiffness=K,
                     q0=basis.rest.copy(), plane_map=N, frame=frame)


class RotorState(NamedTuple):
    """One evaluation of (R2)–(R3) at p; ``rotation`` is the frame's phase e^{iψ}."""

    rotation: complex
    local: np.ndarray           # p_l = T(ψ)ᵀ p
    local_force: np.ndarray     # f = K̃ e
    lever: np.ndarray           # c = P Ĵ p_l
    frame_term: float           # β = f · c
    local_gradient: np.ndarray  # Tᵀ ∂V/∂p = f − β s
    deformation: np.ndarray     # e = p_l − p0 (its t entries are not seen by K̃)
    radius: float               # ρ
    slope: np.ndarray           # s = w_s / ρ: dψ = s · dp_l
    frame: RotorFrame

    @property
    def energy(self) -> float:
        return 0.5 * float(self.deformation.dot(self.local_force))

    @property
    def force(self) -> np.ndarray:
        """∂V/∂p = T (f − β s)."""
        return self.frame.to_global(self.local_gradient, self.rotation)


def rotor_state(rotor: RotorBody, p: np.ndarray) -> RotorState:
    """(R2)–(R3) at p; InvertedBodyError when the in-plane affine map N is inverted or has
    collapsed (det N ≤ 0: no rotation about a can be taken from it). The integrator's hot
    path: a few products with constant matrices."""
    n11, n12, n21, n22 = rotor.plane_map.dot(p).tolist()
    X, Y = n11 + n22, n21 - n12
    rho = math.hypot(X, Y)
    if not n11 * n22 - n12 * n21 > COLLAPSED * rho * rho:
        N = np.array([[n11, n12], [n21, n22]])
        raise InvertedBodyError(np.linalg.det(N), np.linalg.svd(N, compute_uv=False))
    phase = complex(X / rho, Y / rho)
    local = rotor.frame.to_local(p, phase)
    e = local - rotor.q0
    f = rotor.stiffness.dot(e)
    c = rotor.turn.dot(local)
    beta = float(f.dot(c))
    slope = rotor.weights[1] / rho
    return RotorState(phase, local, f, c, beta, f - beta * slope, e, rho, slope, rotor.frame)


def rotor_frame_update(rotor: RotorBody, s: RotorState,
                       apply_A: Callable[[np.ndarray], np.ndarray]
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(X_loc, Y_loc) with J_lᵀ A J_l + geometric terms = A + X_loc Y_loc in the local frame
    (R4), for A = K̃ (the tangent) or A = γ' D₀ + K̃ (the Newton matrix with damping)."""
    rho, c, f, beta, sv = s.radius, s.lever, s.local_force, s.frame_term, s.slope
    Ac = np.asarray(apply_A(c))
    a = Ac - rotor.turn.dot(f) - (beta / rho) * rotor.weights[0]   # Ĵᵀ f = −Ĵ f (no t part)
    kappa = float(c.dot(Ac)) + float(f.dot(rotor.turn.dot(c)))
    return np.column_stack((a, sv)), np.vstack((-sv, kappa * sv - a))


def rotor_tangent(rotor: RotorBody, p: np.ndarray) -> np.ndarray:
    """∂²V/∂p² (np × np, dense) = T (K̃ + X Y) Tᵀ (R4); checked against finite differences."""
    s = rotor_state(rotor, p)
    X, Y = rotor_frame_update(rotor, s, lambda V: rotor.stiffness @ V)
    T = rotor.frame.matrix(s.rotation, rotor.dofs)
    return T @ (rotor.stiffness + X @ Y) @ T.T


@dataclass(frozen=True)
class RotorDamping:
    """Rayleigh damping on the rotor's deformation rate ė = J_l Tᵀ ṗ (``damping``): the
    force J_lᵀ D₀ ė in the local frame and its power ėᵀ D₀ ė, D₀ = P (α Mp + β K̃) P."""

    rotor: RotorBody
    operator: np.ndarray

    def local_force(self, v: np.ndarray, es: RotorState) -> tuple[np.ndarray, float]:
        x = es.frame.to_local(v, es.rotation)
        rate = x - es.lever * float(es.slope.dot(x))
        y = self.operator.dot(rate)
        return y - es.slope * float(es.lever.dot(y)), float(rate.dot(y))
