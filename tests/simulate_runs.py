"""Simulations run as commands in the tests: the cantilever scene, the study files around it,
output folders holding a file of the user's, and the check of a one-line error.

Shared by the ``gcms simulate`` tests of the main suite and the standalone ones of
``tests/dynamics`` (which run without the finite-element stack: nothing here imports it).
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from beams import beam_study
from gcms_fenicsx.files.versioned import seal

REPO = Path(__file__).resolve().parents[1]

#: A cantilever under gravity for 10 ms: cheap, with joints, loads and every output; in the
#: basis of the six-mode beam ``gcms reduce`` makes without a scene (``beam6_reduced``, the
#: committed ``beam6.h5``), so a cached copy of that model is this study's: no attachment
#: modes (the default "auto" would add the clamp's).
SCENE = """
[scene]
end_time = 0.01
time_step = 1e-3
gravity = [0.0, 0.0, -9.81]
outputs = { groups = ["end_xL"] }

[[scene.joints]]
type = "fixed"
group = "end_x0"
name = "clamp"

[basis]
attachment = "none"
"""

#: Bad [scene] input and the key its one-line error names: time_step = 0, rho_inf outside
#: 0..1, a zero joint axis, no [scene] at all, the rotor basis for a clamped body, a
#: misspelt basis kind.
BAD_SCENES = {
    "time_step=0": (SCENE.replace("time_step = 1e-3", "time_step = 0"), "[scene] time_step"),
    "rho_inf=1.5": (SCENE.replace("time_step = 1e-3", "time_step = 1e-3\nrho_inf = 1.5"),
                    "[scene] rho_inf"),
    "zero_axis": (SCENE.replace('name = "clamp"', 'name = "clamp"\naxis = [0, 0, 0]'),
                  "[scene.joints[0]] axis"),
    "no_scene": ("", "[scene]"),
    "rotor_basis_clamped": (SCENE + 'kind = "rotor"\n', "joint 'clamp' is fixed"),
    "basis_kind": (SCENE + 'kind = "rotr"\n', "[basis] kind"),
}

#: Modules the standalone integrator must do without.
FE_STACK = ("dolfinx", "ufl", "basix", "ffcx", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy")


def standalone(*args: str) -> subprocess.CompletedProcess:
    """``python -m gcms_fenicsx.dynamics ARGS`` from the repository root, finished."""
    return subprocess.run([sys.executable, "-m", "gcms_fenicsx.dynamics", *args], cwd=REPO,
                          capture_output=True, text=True, timeout=600)


def study(tmp_path: Path, scene: str = SCENE, name: str = "study.toml", count: int = 6) -> Path:
    """The test beam's study with ``scene``, written to ``tmp_path / name``."""
    path = tmp_path / name
    path.write_text(beam_study(count) + scene)
    return path


def output_folder(tmp_path: Path, reduced: Path | None = None, name: str = "out") -> Path:
    """An output folder holding a file of the user's, and the cached reduced model if given
    (same upstream tables as :func:`study`, so ``gcms simulate`` reuses it)."""
    out = tmp_path / name
    out.mkdir()
    (out / "notes.txt").write_text("the user's own file\n")
    if reduced is not None:
        shutil.copy2(reduced, out / "reduced.h5")
    return out


def contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def assert_one_line_error(run: subprocess.CompletedProcess, *needles: str) -> None:
    """Exit status 2 and, besides progress lines ("[   0.1 s] ..."), one line: the error."""
    assert run.returncode == 2, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr, run.stderr
    lines = [line for line in run.stderr.splitlines() if not line.startswith("[")]
    assert len(lines) == 1 and "error" in lines[0], run.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def non_finite_copy(reduced: Path, path: Path) -> Path:
    """A copy of ``reduced`` at ``path`` with a NaN in Kr, resealed (checksums that fit it, so
    only the content check can catch it)."""
    shutil.copy2(reduced, path)
    with h5py.File(path, "r+") as f:
        f["stiffness"][3, 3] = np.nan
        seal(f)
    return path
