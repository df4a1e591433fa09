"""``stress.xdmf`` and ``stress.h5``: the whole body's stress at a scene's ``stress_times``, a
time series ParaView opens (binary HDF5 data, XDMF 3 text; docs/files.md).

The mesh is written once: the undeformed node coordinates (``/geometry``, N × 3) and the
cells (``/cells``, C × 10 in XDMF's Tetrahedron_10 node order; C × 4 on a P1 mesh). Per time k: ``/displacement/k``
(N × 3, rigid motion included: ParaView's Warp By Vector with factor 1 shows the body where
it is), ``/von_mises/k`` (N, Pa) and ``/stress/k`` (N × 6, Pa, the Cauchy stress in the
global frame as XDMF's Tensor6: xx, xy, xz, yy, yz, zz). Both files are written beside each
other atomically (a failure leaves neither half-written). NumPy and h5py only.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import h5py
import numpy as np

from gcms_fenicsx.files.outputs import atomic_file

XDMF, DATA = "stress.xdmf", "stress.h5"
#: XDMF's Tensor6 order of a symmetric tensor's components.
TENSOR6 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _item(shape: tuple[int, ...], path: str, number: str = "Float") -> str:
    dims = " ".join(str(d) for d in shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="8" '
            f'Format="HDF">{DATA}:{path}</DataItem>')


#: XDMF's topology of a tetrahedron of 4 and of 10 nodes.
TOPOLOGY = {4: "Tetrahedron", 10: "Tetrahedron_10"}


def xdmf_text(node_count: int, cells: tuple[int, int], times: Sequence[float]) -> str:
    """The XDMF document of ``stress.h5`` (module docstring) for ``cells`` (count, nodes a
    cell)."""
    cell_count, width = cells
    grids = []
    for k, t in enumerate(times):
        attributes = "".join(
            f'<Attribute Name="{name}" AttributeType="{kind}" Center="Node">'
            f"{_item((node_count, *shape), f'/{name}/{k}')}</Attribute>"
            for name, kind, shape in (("displacement", "Vector", (3,)),
                                      ("von_mises", "Scalar", ()),
                                      ("stress", "Tensor6", (6,))))
        grids.append(
            f'<Grid Name="t{k}" GridType="Uniform"><Time Value="{t!r}"/>'
            f'<Topology TopologyType="{TOPOLOGY[width]}" NumberOfElements="{cell_count}">'
            f'{_item((cell_count, width), "/cells", "Int")}</Topology>'
            f'<Geometry GeometryType="XYZ">{_item((node_count, 3), "/geometry")}</Geometry>'
            f"{attributes}</Grid>")
    body = "\n".join(grids)
    return ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n<Domain>\n'
            '<Grid Name="stress" GridType="Collection" CollectionType="Temporal">\n'
            f"{body}\n</Grid>\n</Domain>\n</Xdmf>\n")


def write_stress_fields(folder: Path, nodes_m: np.ndarray, cells: np.ndarray,
                        fields: Sequence[tuple[float, np.ndarray, np.ndarray, np.ndarray]]
                        ) -> None:
    """``folder``/stress.xdmf and stress.h5 of ``fields``: (time, displacement N × 3, von
    Mises N, σ N × 6 in TENSOR6 order) each."""
    folder = Path(folder)
    with atomic_file(folder / DATA) as tmp_data, atomic_file(folder / XDMF) as tmp_text:
        with h5py.File(tmp_data, "w") as f:
            f.create_dataset("geometry", data=np.asarray(nodes_m, dtype="<f8"))
            f.create_dataset("cells", data=np.asarray(cells, dtype="<i8"))
            for k, (_, displacement, vm, sigma) in enumerate(fields):
                f.create_dataset(f"displacement/{k}", data=np.asarray(displacement, "<f8"))
                f.create_dataset(f"von_mises/{k}", data=np.asarray(vm, "<f8"))
                f.create_dataset(f"stress/{k}", data=np.asarray(sigma, "<f8"))
        tmp_text.write_text(xdmf_text(len(nodes_m), cells.shape, [t for t, *_ in fields]))
