"""``python -m geometry build PARAMS.json MESH.msh INFO.json``: build and mesh one body in a
process of its own.

PARAMS.json holds ``{"geometry": ..., "mesh": ...}`` as :func:`params_to_json` writes them;
the mesh goes to MESH.msh (atomically) and the :class:`~geometry.meshing.MeshInfo` to
INFO.json. A bad input ends with exit status 2 and INFO.json holding
``{"error": {"key", "value", "allowed"}}``; any other failure of the geometry kernel with
exit status 1 and ``{"failure": message}``.

Why a process: Gmsh and OpenCASCADE run for seconds to minutes inside one C call, where
Python cannot act on SIGINT or SIGTERM (importing Gmsh's API even resets SIGINT to kill the
process at once), and a kernel crash would take the whole command with it. The caller can
stop this process at any moment and clean up after it.
"""
from __future__ import annotations

import json
import sys
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from geometry.errors import GeometryError
from geometry.params import BeamParams, ConrodParams, CrankshaftParams, Geometry, MeshParams

#: The parameter type of each ``kind``.
PARAMS = {"beam": BeamParams, "crankshaft": CrankshaftParams, "conrod": ConrodParams}


def params_to_json(geom: Geometry, mesh: MeshParams) -> dict[str, Any]:
    """The parameters as plain JSON types (dataclass fields; ``kind`` tells the type)."""
    return {"geometry": asdict(geom), "mesh": asdict(mesh)}


def params_from_json(data: dict[str, Any]) -> tuple[Geometry, MeshParams]:
    """Inverse of :func:`params_to_json` (lists back to the tuples the dataclasses hold)."""
    raw = dict(data["geometry"])
    cls = PARAMS[raw.pop("kind")]
    init = {f.name for f in fields(cls) if f.init}
    values = {key: _tuples(value) for key, value in raw.items() if key in init}
    if cls is BeamParams:
        values["dimensions"] = {key: _tuples(value) for key, value in raw["dimensions"].items()}
    return cls(**values), MeshParams(**data["mesh"])


def _tuples(value: Any) -> Any:
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value


def main(argv: list[str]) -> int:
    if len(argv) != 4 or argv[0] != "build":
        print(__doc__.splitlines()[0], file=sys.stderr)
        return 2
    params, msh, info = (Path(a) for a in argv[1:])
    from geometry.meshing import build_msh
    geom, mesh = params_from_json(json.loads(params.read_text()))
    try:
        result = build_msh(geom, mesh, msh).to_json()
        status = 0
    except GeometryError as exc:
        result = {"error": {"key": exc.key, "value": exc.value, "allowed": exc.allowed}}
        status = 2
    except Exception as exc:  # the kernel's bare Exception: reported, not a traceback
        result = {"failure": f"{type(exc).__name__}: {exc}"}
        status = 1
    info.write_text(json.dumps(result))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
