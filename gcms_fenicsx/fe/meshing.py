"""Geometry and meshing in a child process (``python -m geometry build``), stoppable at once.

The command keeps control while Gmsh works: it prints progress, a SIGINT or SIGTERM stops
the child and cleans up without waiting for the mesher, and a crash of the geometry
kernel (a signal in OpenCASCADE) becomes a one-line error naming the geometry keys
instead of the end of the command.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from geometry.info import MeshInfo
from geometry.__main__ import params_to_json
from geometry.params import Geometry, MeshParams, geometry_keys

from gcms_fenicsx.runtime.progress import Progress, quiet
from gcms_fenicsx.config.table import ConfigError

#: Seconds between progress lines while the child meshes.
PROGRESS_INTERVAL_S = 5.0


def _kernel_error(geom: Geometry, mesh: MeshParams, what: str) -> ConfigError:
    return ConfigError("[geometry]", geom.kind, f"the geometry kernel {what} building it from "
                       f"{', '.join(geometry_keys(geom))} with [mesh] size = {mesh.size:g}: check those "
                       "values")


def mesh_in_process(geom: Geometry, mesh: MeshParams, path: Path,
                    progress: Progress = quiet) -> MeshInfo:
    """``geometry.build_msh(geom, mesh, path)`` in a child process; its MeshInfo.

    ConfigError for bad input (as the child reports it) and for a failure or crash of the
    geometry kernel; the child is killed if this process is interrupted.
    """
    path = Path(path)
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=".meshing-") as work:
        params, info, log = (Path(work) / name for name in ("params.json", "info.json", "log"))
        params.write_text(json.dumps(params_to_json(geom, mesh)))
        start = time.perf_counter()
        with open(log, "w") as err:
            child = subprocess.Popen([sys.executable, "-m", "geometry", "build", str(params),
                                      str(path), str(info)], stdout=subprocess.DEVNULL,
                                     stderr=err)
            try:
                status = _wait(child, start, progress)
            finally:
                if child.poll() is None:
                    child.kill()
                    child.wait()
        report = json.loads(info.read_text()) if info.is_file() else None
        if status < 0 or report is None:
            name = signal.Signals(-status).name if status < 0 else f"exit status {status}"
            raise _kernel_error(geom, mesh, f"crashed ({name}; {log.read_text()[-300:]!r})")
    if status == 2:
        raise ConfigError(**report["error"])
    if status != 0:
        raise _kernel_error(geom, mesh, f"failed ({report['failure']})")
    return MeshInfo.from_json(report)


def _wait(child: subprocess.Popen, start: float, progress: Progress) -> int:
    """The child's exit status, with a progress line every PROGRESS_INTERVAL_S seconds."""
    while True:
        try:
            return child.wait(timeout=PROGRESS_INTERVAL_S)
        except subprocess.TimeoutExpired:
            progress(f"geometry and mesh: meshing ({time.perf_counter() - start:.0f} s)")
