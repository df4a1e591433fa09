"""Stresses recovered from the recorded motion, in the body's own elastic law (docs/design.md §9).

With x(X) = Σ_f F_f(X) Q_f the deformation gradient at a node is F = Qᵀ D, D = ∇F there
(nf × 3): linear in q. The stress modes give D = B F for the run's fields (B: the nodal
gradient operator of ``stress_modes.h5``, ``files.stress_nodes``), once when the run starts;
every recorded step then costs one product D Q (9 nf multiply-adds a node) and the law:

- co-rotated: ε = sym(Rᵀ F) − I with the body's co-rotated frame R = polar(Qᵀ H),
  σ_loc = λ tr(ε) I + 2 μ ε, σ = R σ_loc Rᵀ (so a rigid rotation leaves σ_loc as it was and
  turns σ);
- Saint Venant–Kirchhoff: E = ½ (Fᵀ F − I), S = λ tr(E) I + 2 μ E, σ = F S Fᵀ / det F.

Von Mises and principal stresses are invariants of σ (of σ_loc alike). Recorded per recorded
step: the von Mises stress at every requested node (``stress/von_mises``, float32: the
series is large and its use is to be looked at), and per group its largest von Mises stress
and the principal stresses (σ1 ≥ σ2 ≥ σ3) at that node; kept over the run: each node's peak
von Mises stress and its time (over the recorded steps). At ``stress_times`` the whole
body's stress (every node; the time of the nearest step) for ``stress.xdmf``. NumPy only.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.scene import Scene, SceneError
from gcms_fenicsx.config.stress_outputs import StressOutputs
from gcms_fenicsx.files.results import Series
from gcms_fenicsx.files.stress_fields import TENSOR6
from gcms_fenicsx.files.reduced_model import ReducedModel
from gcms_fenicsx.files.stress_nodes import StressNodes
from gcms_fenicsx.numerics.rotation import InvertedBodyError

#: The recorded steps × nodes of one pass (9 doubles each: 5 MB an array; four times as many
#: were measured no faster on the default crankshaft's surface).
NODE_ROWS_PER_PASS = 1 << 16
VON_MISES = "stress/von_mises"


@dataclass(frozen=True)
class StressSetup:
    """What a run needs to recover stresses: the stress modes' mesh part, the material's
    Lamé parameters (μ, λ in Pa) and what the scene asks for."""

    nodes: StressNodes
    lame: tuple[float, float]
    outputs: StressOutputs


def stress_setup(model: ReducedModel, scene: Scene,
                 nodes: StressNodes | None) -> StressSetup | None:
    """What the run needs to recover the stresses the scene asks for (None: it asks for
    none); SceneError when it asks and ``nodes`` (the stress modes) or the model's material
    is missing."""
    asked = scene.outputs.stress
    if asked is None:
        return None
    if nodes is None:
        raise SceneError("[scene.outputs] stress_groups: the stresses need the stress modes "
                         "(stress_modes.h5, made by gcms run or gcms simulate with this scene)")
    try:
        material = Material(**{k: float(model.material[k]) for k in ("E", "nu", "rho")})
    except (KeyError, TypeError, ValueError) as exc:
        raise SceneError("[scene.outputs] stress_groups: the reduced model records no "
                         f"material ({exc}); reduce the body again") from exc
    check_nodes(nodes, asked, len(model.nodes_m))
    return StressSetup(nodes=nodes, lame=material.lame, outputs=asked)


def check_nodes(nodes: StressNodes, asked: StressOutputs, node_count: int) -> None:
    """SceneError unless the stress modes ``nodes`` are those ``asked`` for (the same
    groups, the cells for whole-body stresses) on a mesh of ``node_count`` nodes."""
    where = "[scene.outputs] stress_groups: the stress modes (stress_modes.h5)"
    if nodes.node_count != node_count:
        raise SceneError(f"{where} are of a mesh of {nodes.node_count} nodes, the reduced "
                         f"model's has {node_count}: they belong to another body")
    if set(nodes.groups) != set(asked.labels):
        raise SceneError(f"{where} hold the groups {sorted(nodes.groups)}, the scene asks for "
                         f"{sorted(asked.labels)}; form them for this scene (gcms reduce or "
                         "gcms run of this study)")
    if asked.whole_body and not len(nodes.cells):
        raise SceneError(f"{where} were formed without the whole body, which stress_times "
                         "asks for; form them for this scene (gcms reduce or gcms run of "
                         "this study)")


def rotations(A: np.ndarray) -> np.ndarray:
    """The rotations R of the polar decompositions A = R U of a stack of maps (rows, 3, 3)
    (``numerics.rotation.polar`` for one): R = W Vᵀ of A = W Σ Vᵀ; InvertedBodyError for
    the first map with det ≤ 0."""
    W, s, Vt = np.linalg.svd(A)
    R = W @ Vt
    bad = np.flatnonzero(np.linalg.det(R) <= 0.0)
    if len(bad):
        raise InvertedBodyError(np.linalg.det(A[bad[0]]), s[bad[0]])
    return R


def hooke(strain: np.ndarray, mu: float, lmbda: float) -> np.ndarray:
    """λ tr(ε) I + 2 μ ε for a stack of strains (..., 3, 3)."""
    trace = np.trace(strain, axis1=-2, axis2=-1)[..., None, None]
    return lmbda * trace * np.eye(3) + 2.0 * mu * strain


def corotated_local_stress(local: np.ndarray, mu: float, lmbda: float) -> np.ndarray:
    """σ_loc = C : ε, ε = sym(Rᵀ F) − I, from the body frame's gradients Rᵀ F (..., 3, 3)."""
    return hooke(0.5 * (local + np.swapaxes(local, -1, -2)) - np.eye(3), mu, lmbda)


def corotated_stress(F: np.ndarray, R: np.ndarray, mu: float, lmbda: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """(σ_loc, σ) of the co-rotated law: σ_loc of Rᵀ F (:func:`corotated_local_stress`),
    σ = R σ_loc Rᵀ; F (..., 3, 3), R broadcast against it."""
    sigma_local = corotated_local_stress(np.swapaxes(R, -1, -2) @ F, mu, lmbda)
    return sigma_local, R @ sigma_local @ np.swapaxes(R, -1, -2)


def svk_stress(F: np.ndarray, mu: float, lmbda: float) -> np.ndarray:
    """Cauchy stress of Saint Venant–Kirchhoff: F S Fᵀ / det F, S = C : ½ (Fᵀ F − I)."""
    Ft = np.swapaxes(F, -1, -2)
    S = hooke(0.5 * (Ft @ F - np.eye(3)), mu, lmbda)
    return F @ S @ Ft / np.linalg.det(F)[..., None, None]


def von_mises(s: np.ndarray) -> np.ndarray:
    """√(½ [(σ11 − σ22)² + (σ22 − σ33)² + (σ33 − σ11)²] + 3 (σ12² + σ23² + σ13²))."""
    a, b, c = s[..., 0, 0], s[..., 1, 1], s[..., 2, 2]
    shear = s[..., 0, 1] ** 2 + s[..., 1, 2] ** 2 + s[..., 0, 2] ** 2
    return np.sqrt(0.5 * ((a - b) ** 2 + (b - c) ** 2 + (c - a) ** 2) + 3.0 * shear)


def principal(s: np.ndarray) -> np.ndarray:
    """The principal stresses σ1 ≥ σ2 ≥ σ3 of symmetric stresses (..., 3, 3)."""
    return np.linalg.eigvalsh(0.5 * (s + np.swapaxes(s, -1, -2)))[..., ::-1]


def _gradients(D: Any, Q: np.ndarray) -> np.ndarray:
    """F = Qᵀ D_i at every node i of D (3 nodes × nf) for rows Q (rows, nf, 3): one product,
    (rows, nodes, 3, 3), F[l, c] = ∂x_l/∂X_c."""
    rows, nf, _ = Q.shape
    G = np.asarray(D @ Q.transpose(1, 0, 2).reshape(nf, 3 * rows))   # (3 nodes, 3 rows)
    return G.reshape(-1, 3, rows, 3).transpose(2, 0, 3, 1)


def field_gradients(B: Any, fields: Any) -> Any:
    """D = B F (3 r × nf): dense for dense fields; sparse (SciPy) for a sparse F (the
    full-order model's F = I, whose D is B itself)."""
    if hasattr(fields, "tocsr"):
        import scipy.sparse
        return scipy.sparse.csr_matrix((B.data, B.indices, B.indptr), shape=B.shape) @ fields
    return B.dot(np.asarray(fields))


class StressRecovery:
    """The stresses of a run at the requested nodes, block by block of recorded rows
    (module docstring). ``body``: the run's body in the full basis (its fields F, frame
    operator H and undeformed nodes); ``law``: ``[scene] elasticity``."""

    def __init__(self, setup: StressSetup, body: Any, law: str) -> None:
        nodes = setup.nodes
        check_nodes(nodes, setup.outputs, len(body.nodes_m))
        self.setup, self.law, self.affine = setup, law, np.asarray(body.affine)
        self.mu, self.lmbda = setup.lame
        D = field_gradients(nodes.gradient, body.node_fields)
        rows = (3 * nodes.requested[:, None] + np.arange(3)).ravel()
        self.recorded = D[rows]
        self.whole = D if setup.outputs.whole_body else None
        self.positions = np.asarray(body.nodes_m)[nodes.nodes]
        self.all_positions = np.asarray(body.nodes_m)
        self.node_fields = body.node_fields
        k = len(nodes.requested)
        self.peak = np.full(k, -np.inf)
        self.peak_time = np.zeros(k)
        self.fields: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []
        self.rows = 0
        self.seconds = 0.0          # spent recovering, after the stress modes' D = B F

    def layout(self) -> tuple[Series, ...]:
        """The recorded series: von Mises at every requested node, per group its largest and
        the principal stresses there."""
        k = len(self.setup.nodes.requested)
        return (Series(VON_MISES, (k,), "<f4"),
                *(Series(f"stress/groups/{g}/{s}", shape) for g in self.setup.nodes.groups
                  for s, shape in (("von_mises", ()), ("principal", (3,)))))

    def stresses(self, D: Any, Q: np.ndarray, turned: bool = True
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        """(σ_loc — SVK: σ — for the invariants, σ in the global frame or None unless
        ``turned``) at D's nodes for the coordinate rows Q (rows, nf, 3): (rows, nodes, 3, 3).
        Co-rotated, Rᵀ F = (Q R)ᵀ D: the frame turns the rows' Q, not every node's F."""
        if self.law == "svk":
            sigma = svk_stress(_gradients(D, Q), self.mu, self.lmbda)
            return sigma, sigma
        R = rotations(np.swapaxes(Q, 1, 2) @ self.affine)
        sigma_local = corotated_local_stress(_gradients(D, Q @ R), self.mu, self.lmbda)
        if not turned:
            return sigma_local, None
        R = R[:, None]
        return sigma_local, R @ sigma_local @ np.swapaxes(R, -1, -2)

    def block(self, times: np.ndarray, Q: np.ndarray) -> dict[str, np.ndarray]:
        """The series of a block of recorded rows at ``times`` with coordinates Q (rows, nf, 3),
        and the peaks updated."""
        t0 = time.perf_counter()
        k = len(self.setup.nodes.requested)
        step = max(1, NODE_ROWS_PER_PASS // max(k, 1))
        vm = np.empty((len(times), k))
        at = {g: np.empty((len(times), 3)) for g in self.setup.nodes.groups}
        for start in range(0, len(times), step):
            invariant, _ = self.stresses(self.recorded, Q[start:start + step], turned=False)
            v = vm[start:start + step] = von_mises(invariant)
            for g, members in self.setup.nodes.groups.items():
                top = members[np.argmax(v[:, members], axis=1)]
                at[g][start:start + step] = principal(invariant[np.arange(len(v)), top])
        best = np.argmax(vm, axis=0)
        better = vm[best, np.arange(k)] > self.peak
        self.peak[better] = vm[best[better], np.flatnonzero(better)]
        self.peak_time[better] = times[best[better]]
        self.rows += len(times)
        block = {VON_MISES: vm.astype("<f4")}
        for g, members in self.setup.nodes.groups.items():
            block[f"stress/groups/{g}/von_mises"] = vm[:, members].max(axis=1)
            block[f"stress/groups/{g}/principal"] = at[g]
        self.seconds += time.perf_counter() - t0
        return block

    def snapshot(self, t: float, q: np.ndarray) -> None:
        """The whole body's stress at coordinates q (the full basis) at time t: displacement,
        von Mises and σ (global frame, ``stress_fields.TENSOR6``) at every node, kept for
        ``stress.xdmf``."""
        t0 = time.perf_counter()
        Q = q.reshape(1, -1, 3)
        _, sigma = self.stresses(self.whole, Q)
        sigma = sigma[0]
        displacement = np.asarray(self.node_fields @ Q[0]) - self.all_positions
        tensor = np.stack([sigma[:, i, j] for i, j in TENSOR6], axis=1)
        self.fields.append((t, displacement, von_mises(sigma), tensor))
        self.seconds += time.perf_counter() - t0

    def datasets(self) -> dict[str, np.ndarray]:
        """results.h5's ``/stress`` datasets that are not time series."""
        nodes = self.setup.nodes
        out = {"stress/nodes": self.positions, "stress/node_index": nodes.nodes,
               "stress/peak_von_mises": np.where(np.isfinite(self.peak), self.peak, 0.0),
               "stress/peak_time": self.peak_time}
        out.update({f"stress/groups/{g}/nodes": m for g, m in nodes.groups.items()})
        return out

    def summary(self) -> dict:
        """summary.json's ``stress`` block: the hot spot (the peak von Mises stress over the
        requested nodes and the run), its group, position and time, and each group's peak."""
        nodes = self.setup.nodes
        if not self.rows:
            return {"peak_von_mises_pa": None, "peak_group": None, "peak_position_m": None,
                    "peak_time_s": None, "nodes": len(nodes.requested)}
        hot = int(np.argmax(self.peak))
        group = next(g for g, m in nodes.groups.items() if hot in m)
        return {"peak_von_mises_pa": float(self.peak[hot]), "peak_group": group,
                "peak_position_m": self.positions[hot].tolist(),
                "peak_time_s": float(self.peak_time[hot]), "peak_node": int(nodes.nodes[hot]),
                "nodes": len(nodes.requested), "law": self.law,
                "groups": {g: {"peak_von_mises_pa": float(self.peak[m].max()),
                               "nodes": len(m)} for g, m in nodes.groups.items()},
                "whole_body_times_s": [t for t, *_ in self.fields],
                "recovery_s": self.seconds,
                "recovery_per_recorded_step_ms": 1e3 * self.seconds / self.rows}
