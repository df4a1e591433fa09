"""The constant coefficients of the reduced Saint Venant–Kirchhoff energy, from the mesh's
quadrature points (docs/design.md §7.2; the energy and its use: ``dynamics.bodies.svk``).

At a quadrature point with weight w (the rule's weight times |det J|) and field gradients
D = ∇F (nf × 3), C_ij = r_ijᵀ p with r_ij = svec(sym(D_i D_jᵀ)) and p = svec(Q Qᵀ), so

    W = λ/8 (tr C − 3)² + μ/4 |C − I|²
      = λ/8 (tᵀp)² + μ/4 Σ_{i≤j} ω_ij (r_ijᵀ p)² − (3λ/4 + μ/2) tᵀp + 9λ/8 + 3μ/4,

with t = r_11 + r_22 + r_33 and ω_ij = 1 (i = j), 2 (i < j). Summed over the points:

    A = Σ w (λ/4 t tᵀ + μ/2 Σ ω_ij r_ij r_ijᵀ),   b = −(3λ/4 + μ/2) Σ w t,
    c = (9λ/8 + 3μ/4) Σ w,

two Gram matrices of weighted rows (one t and six r per point), accumulated in blocks of
points. The quadrature is exact for the energy density of fields of the
mesh's order on straight cells (degree 4 (p − 1)), the rule of the full-order reference's
SVK forms for P2. Each rank sums its owned cells, a block of cells at a time, and rank 0 the
ranks, so one and two ranks give the same coefficients to round-off.
"""
from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import basix
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.numerics.packing import packing
from gcms_fenicsx.files.svk_data import SVKCoefficients, packed_size
from gcms_fenicsx.files.versioned import dataset_digest
from gcms_fenicsx.fe.node_order import input_node_indices
from gcms_fenicsx.runtime.machine import available_memory_bytes
from gcms_fenicsx.runtime.progress import Progress, quiet

#: Quadrature points per block of the Gram products: 7 rows each, so a block holds
#: 7 · 512 · s doubles (23 MB at nf = 34 fields, 60 MB at 64).
POINTS_PER_BLOCK = 512
#: Cells whose field gradients are evaluated at once: 14 points each at degree 4, so a block
#: holds 14 · 1024 · nf · 3 doubles (16 MB at 47 fields) however large the mesh.
CELLS_PER_BLOCK = 1024
#: Copies of A (s × s doubles) alive at once on rank 0: the two sums (A is formed in one of
#: them), the transpose's temporary while symmetrising and the upper triangle written to
#: reduced.h5 (with a margin).
COEFFICIENT_COPIES = 4
#: The components (i, j), i ≤ j, of C and their weights ω_ij in |C − I|².
COMPONENTS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
OFF_DIAGONAL_WEIGHT = (1.0, 1.0, 1.0, 2.0, 2.0, 2.0)


def quadrature_degree(mesh_order: int) -> int:
    """4 (p − 1): exact for W of degree-p fields on straight cells (at least 1)."""
    return max(4 * (mesh_order - 1), 1)


def gradient_blocks(mesh: Any, fields: np.ndarray | None, comm: Any
                    ) -> tuple[int, Iterator[tuple[np.ndarray, np.ndarray]]]:
    """(number of blocks, blocks): for blocks of CELLS_PER_BLOCK of this rank's owned cells,
    the gradients of every field at their quadrature points, (points, nf, 3), and the points'
    weights w = rule weight · |det J|. The fields are the components of one function of a
    blocked space (the same nodes as the scalar space), so each block is one evaluation.

    ``fields`` (N × nf, the mesh file's node order) on rank 0, None elsewhere; collective."""
    order = mesh.geometry.cmap.degree
    Vs = fem.FunctionSpace(mesh, ("Lagrange", order))
    index = input_node_indices(Vs)
    fields = comm.bcast(fields, root=0)
    nf = fields.shape[1]
    V = fem.VectorFunctionSpace(mesh, ("Lagrange", order), dim=nf)
    u = fem.Function(V)
    u.x.array[:len(index) * nf] = fields[index].ravel()
    u.x.scatter_forward()
    points, rule = basix.make_quadrature(basix.CellType.tetrahedron, quadrature_degree(order))
    gradient = fem.Expression(ufl.grad(u), points)
    detJ = fem.Expression(abs(ufl.JacobianDeterminant(mesh)), points)
    cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
    starts = range(0, len(cells), CELLS_PER_BLOCK)

    def blocks() -> Iterator[tuple[np.ndarray, np.ndarray]]:
        for start in starts:
            block = cells[start:start + CELLS_PER_BLOCK]
            weights = (detJ.eval(block).reshape(len(block), len(points)) * rule).ravel()
            yield gradient.eval(block).reshape(-1, nf, 3), weights

    return len(starts), blocks()


@dataclass
class GramSums:
    """The sums the coefficients are made of, accumulated over points (module docstring):
    T = Σ w t tᵀ, R = Σ w ω r rᵀ (s × s), Σ w t (s) and Σ w (the volume). Kept apart until
    the end, so λ < 0 (ν < 0) needs no square root and one pair of s × s arrays serves every
    block of points."""

    T: np.ndarray
    R: np.ndarray
    t: np.ndarray
    volume: float = 0.0

    @classmethod
    def zeros(cls, field_count: int) -> GramSums:
        s = packed_size(field_count)
        return cls(np.zeros((s, s)), np.zeros((s, s)), np.zeros(s))

    def add(self, D: np.ndarray, weights: np.ndarray) -> None:
        """Add the points with gradients D (points × nf × 3) and weights, POINTS_PER_BLOCK
        at a time (two Gram products each)."""
        pack = packing(D.shape[1])
        s = len(self.t)
        omega = np.sqrt(np.array(OFF_DIAGONAL_WEIGHT))
        for start in range(0, len(D), POINTS_PER_BLOCK):
            Dk, wk = D[start:start + POINTS_PER_BLOCK], weights[start:start + POINTS_PER_BLOCK]
            r = np.stack([pack.svec(Dk[:, :, i, None] * Dk[:, None, :, j])
                          for i, j in COMPONENTS], axis=1)                   # (k, 6, s)
            t = r[:, 0] + r[:, 1] + r[:, 2]
            self.t += wk.dot(t)
            root = np.sqrt(wk)[:, None]
            Xt = t * root
            Xr = (r * (root * omega)[:, :, None]).reshape(-1, s)
            self.T += Xt.T.dot(Xt)
            self.R += Xr.T.dot(Xr)
        self.volume += float(weights.sum())

    def coefficients(self, material: Material) -> tuple[np.ndarray, np.ndarray, float]:
        """(A, b, c): A = λ/4 T + μ/2 R, formed in T's memory (the sums are spent),
        symmetrised; b = −(3λ/4 + μ/2) Σ w t; c = (9λ/8 + 3μ/4) Σ w."""
        mu, lmbda = material.lame
        A = self.T
        A *= 0.25 * lmbda
        self.R *= 0.5 * mu
        A += self.R
        A += A.T
        A *= 0.5
        return A, -(0.75 * lmbda + 0.5 * mu) * self.t, (1.125 * lmbda + 0.75 * mu) * self.volume


def check_memory(field_count: int, available: float | None = None, comm: Any = None) -> None:
    """ConfigError on ``[scene] elasticity`` if the coefficients of ``field_count`` fields
    (COEFFICIENT_COPIES of s × s doubles) need more memory than this machine has (with
    ``comm``: the least any rank has, so every rank decides alike). Checked before the mesh
    is made for the most fields the modes can give (``stage_files``), and again for the
    fields kept."""
    need = COEFFICIENT_COPIES * 8.0 * packed_size(field_count) ** 2
    limit = available_memory_bytes() if available is None else available
    if comm is not None:
        limit = comm.allreduce(limit, op=MPI.MIN)
    if need > limit:
        raise ConfigError("[scene] elasticity", "svk",
                          f"its coefficients for {field_count} fields need "
                          f"{need / 2 ** 30:.3g} GiB (s² doubles, s = nf (nf + 1) / 2 = "
                          f"{packed_size(field_count)}), more than the {limit / 2 ** 30:.3g} "
                          "GiB this machine has available; ask fewer [modes] count, "
                          '[basis] attachment = "none" (attachment modes add fields) or '
                          'elasticity = "corotated"')


def svk_coefficients(mesh: Any, fields: np.ndarray | None, material: Material,
                     progress: Progress = quiet) -> tuple[SVKCoefficients | None, dict]:
    """The coefficients of the fields ``fields`` (N × nf in the mesh file's node order, on
    rank 0) on rank 0 (None on the others), and a report: size, points, wall time.
    Collective."""
    comm = mesh.comm
    t0 = time.perf_counter()
    nf = comm.bcast(None if fields is None else fields.shape[1], root=0)
    check_memory(nf, comm=comm)
    progress(f"Saint Venant–Kirchhoff coefficients of {nf} fields "
             f"({packed_size(nf) ** 2 * 8 / 1e6:.0f} MB)")
    count, blocks = gradient_blocks(mesh, fields, comm)
    sums, points = GramSums.zeros(nf), 0
    report = {count * k // 10 for k in range(1, 10)} if count >= 10 else set()
    for k, (D, weights) in enumerate(blocks):
        if k in report:
            progress(f"  SVK coefficients: {100 * k // count} % of the cells")
        sums.add(D, weights)
        points += len(weights)
    points = comm.reduce(points, op=MPI.SUM, root=0)
    sums.volume = comm.reduce(sums.volume, op=MPI.SUM, root=0)
    for array in (sums.T, sums.R, sums.t):               # summed into rank 0's own arrays
        comm.Reduce(MPI.IN_PLACE if comm.rank == 0 else array, array, op=MPI.SUM, root=0)
    if comm.rank != 0:
        return None, {}
    A, b, c = sums.coefficients(material)
    coefficients = SVKCoefficients(quadratic=A, linear=b, constant=float(c),
                                   fields_digest=dataset_digest(fields))
    return coefficients, {"fields": nf, "packed_size": len(b), "quadrature_points": points,
                          "bytes": coefficients.nbytes,
                          "stored_bytes": coefficients.stored_bytes,
                          "seconds": time.perf_counter() - t0}
