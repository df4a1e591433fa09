"""Memory a study will need, estimated from its inputs before anything is meshed or allocated.

A study whose estimate exceeds the memory this machine has available is refused in one line
naming the key that drives the estimate ([mesh] size or [modes] count), the estimate and
the limit, instead of growing until the kernel kills it.

The model, from measured peak resident memory of ``gcms modes`` (2026-11-30, P2, ten modes):
default crankshaft 82k DOFs 0.83 GB, 244k DOFs 2.8 GB, 539k DOFs 6.0 GB (10.1–11.3 kB per
DOF); 10 m × 10 mm beam 255k DOFs 2.1 GB (8.1 kB per DOF). The finite-element part (mesh,
K, M, their factorisation, one spare) is taken as ``FE_BYTES_PER_DOF`` per DOF above a
fixed ``BASE_BYTES``; the Krylov basis adds one vector per basis column and the reduction
its dense matrices (Mr, Kr and their eigen-decomposition: ``DENSE_COPIES`` matrices of
(3·fields)² numbers).
"""
from __future__ import annotations

from dataclasses import dataclass

from gcms_fenicsx.config.table import ConfigError
from gcms_fenicsx.runtime.machine import available_memory_bytes

BASE_BYTES = 400e6
FE_BYTES_PER_DOF = 13e3
#: Peak memory of the meshing process per tetrahedron: 408 MB for 110k cells of a
#: crankshaft, 150 MB for 20k of a beam (about 90 MB of it Python and Gmsh themselves).
GMSH_BYTES_PER_CELL = 4e3
DENSE_COPIES = 8
GIB = 2.0 ** 30


@dataclass(frozen=True)
class MemoryEstimate:
    """Bytes each part of a modes-and-reduction run needs at its peak."""

    dofs: int
    elastic_modes: int
    finite_elements: float
    krylov: float
    reduction: float

    @property
    def total(self) -> float:
        return BASE_BYTES + self.finite_elements + max(self.krylov, self.reduction)

    @property
    def mesh_driven(self) -> bool:
        """Whether the finite-element part (the mesh) dominates, rather than the mode count."""
        return self.finite_elements >= max(self.krylov, self.reduction)

    def describe(self) -> str:
        return (f"{self.dofs:.3g} DOFs and {self.elastic_modes} elastic modes need an "
                f"estimated {self.total / GIB:.3g} GiB (finite elements "
                f"{self.finite_elements / GIB:.3g}, Krylov basis {self.krylov / GIB:.3g}, "
                f"reduction {self.reduction / GIB:.3g})")


def check_meshing(cells: int, size: float, available: float | None = None) -> None:
    """ConfigError on ``[mesh] size`` if meshing ``cells`` tetrahedra (estimated before
    meshing) needs more memory than this machine has available."""
    limit = available_memory_bytes() if available is None else available
    need = BASE_BYTES + GMSH_BYTES_PER_CELL * cells
    if need > limit:
        raise ConfigError("[mesh] size", size, f"gives an estimated {cells:.3g} cells, whose "
                          f"meshing needs {need / GIB:.3g} GiB, more than the "
                          f"{limit / GIB:.3g} GiB this machine has available")


def memory_estimate(dofs: int, elastic_modes: int, nodes: int | None = None) -> MemoryEstimate:
    """The estimate for ``dofs`` degrees of freedom and ``elastic_modes`` modes (module docstring).

    Krylov–Schur keeps max(2 nev, nev + 15) basis vectors (nev = modes + 1) and the six
    deflated rigid modes; the reduction holds F (nodes × fields, a few copies) and
    ``DENSE_COPIES`` dense matrices of order 3·fields, fields = 4 + 3·modes.
    """
    nodes = dofs // 3 if nodes is None else nodes
    nev = elastic_modes + 1
    ncv = max(2 * nev, nev + 15)
    fields = 4 + 3 * elastic_modes
    return MemoryEstimate(
        dofs=dofs, elastic_modes=elastic_modes,
        finite_elements=FE_BYTES_PER_DOF * dofs,
        krylov=8.0 * dofs * (ncv + 6 + 2 * nev) + 8.0 * 4 * ncv ** 2,
        reduction=8.0 * (4 * nodes * fields + DENSE_COPIES * (3 * fields) ** 2))


Setting = tuple[str, object]  # a config key as messages name it, and its value


def check_memory(estimate: MemoryEstimate, mesh: Setting, modes: Setting,
                 available: float | None = None) -> None:
    """ConfigError on the setting that drives the estimate (``mesh`` or ``modes``) if the
    estimate exceeds the memory available (default: :func:`available_memory_bytes`)."""
    limit = available_memory_bytes() if available is None else available
    if estimate.total > limit:
        key, value = mesh if estimate.mesh_driven else modes
        raise ConfigError(key, value, f"{estimate.describe()}, more than the "
                                      f"{limit / GIB:.3g} GiB this machine has available")
