"""Which step a run takes — the compiled one (``compiled``, Numba) or the NumPy one
(``integrator``, the reference) — and the compiled one's driver (docs/design.md §8.5).

``[scene.solver] kernel``: "auto" (default) compiles where Numba imports and the stepper is
one the kernel runs (``kernel_data.unsupported``), else steps in NumPy; "numba" insists (a
SceneError says why it cannot); "numpy" never compiles. The environment variable
``GCMS_KERNEL`` (auto, numba, numpy) overrides the scene's choice for a whole session.

Numba compiles the kernel once per machine and caches it on disk (:func:`cache_folder`): beside
the package, in ``compiled/__pycache__/kernel-<digest>``; under ``$NUMBA_CACHE_DIR`` if that is
set; in ``$XDG_CACHE_HOME/gcms-fenicsx`` (else ``~/.cache``) where the package's folder is not
writable. The run says whether it compiled and how long it took. Processes that start at once
compile it once: the first holds a lock on the cache folder (:func:`compile_lock`) while it
compiles, the others wait for it and load what it cached.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np

from gcms_fenicsx.config.scene import KERNELS, SceneError
from gcms_fenicsx.dynamics.stepping.kernel_data import StepData, step_data, unsupported
from gcms_fenicsx.dynamics.stepping.state import State, StepInfo
from gcms_fenicsx.runtime.progress import Progress

#: A stretch of compiled steps is at most this long, so a run reports progress and answers
#: an interrupt between stretches (a few ms to a few hundred ms of stepping).
STRETCH_STEPS = 2000
KERNEL_VARIABLE = "GCMS_KERNEL"


class KernelElastic(NamedTuple):
    """What the recorder reads of a compiled step's elastic state."""

    energy: float


@dataclass(frozen=True)
class KernelChoice:
    """The step a run takes: "numba" or "numpy", why, and the compile (or cache load) time."""

    name: str
    reason: str = ""
    compile_s: float | None = None
    cached: bool | None = None

    def summary(self) -> dict:
        """summary.json's ``kernel`` block."""
        return {"name": self.name, "reason": self.reason or None,
                "compile_s": self.compile_s, "loaded_from_cache": self.cached}


def requested(setting: str) -> str:
    """The scene's ``kernel`` unless ``GCMS_KERNEL`` overrides it (checked like the key)."""
    value = os.environ.get(KERNEL_VARIABLE, "").strip()
    if not value:
        return setting
    if value not in KERNELS:
        raise SceneError(f"{KERNEL_VARIABLE} = {value!r} must be one of "
                         + ", ".join(repr(k) for k in KERNELS))
    return value


def numba_missing() -> str | None:
    """Why Numba cannot compile the kernel here (None: it can): Numba itself, and SciPy, whose
    BLAS Numba's matrix products call."""
    try:
        import numba  # noqa: F401
    except ImportError as exc:
        return f"Numba is not installed ({exc}); scripts/setup.sh installs python3-numba"
    try:
        import scipy.linalg.cython_blas  # noqa: F401
    except ImportError as exc:
        return (f"Numba's matrix products need SciPy's BLAS, which is not importable ({exc}); "
                "scripts/setup.sh installs python3-scipy")
    return None


#: The kernel's sources: the cache is keyed by their digest.
KERNEL_SOURCES = Path(__file__).resolve().parent / "compiled"


def cache_folder() -> Path:
    """Where the compiled kernel is cached (module docstring), in a folder named by the digest
    of the kernel's sources and of Numba's version: Numba keys a cached function by its own
    file's time stamp only, so a helper changed in another of the kernel's modules would
    otherwise leave a stale kernel in use."""
    import numba

    digest = hashlib.sha256(numba.__version__.encode())
    for source in sorted(KERNEL_SOURCES.glob("*.py")):
        digest.update(source.name.encode() + source.read_bytes())
    name = f"kernel-{digest.hexdigest()[:16]}"
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / "gcms-fenicsx" / name
    beside = KERNEL_SOURCES / "__pycache__"
    try:
        beside.mkdir(exist_ok=True)
        if os.access(beside, os.W_OK):
            return beside / name
    except OSError:
        pass
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return home / "gcms-fenicsx" / name


@contextmanager
def compile_lock() -> Iterator[None]:
    """An exclusive lock (``flock``) on ``<cache folder>.lock``, held while a process compiles
    or loads the kernel: a second process waits, then finds the cache the first wrote. The
    lock goes with the process that holds it, however it ends; where no lock file can be made
    (a read-only place), no lock is taken."""
    import fcntl

    path = cache_folder().with_suffix(".lock")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(path, "a")
    except OSError:
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def compile_for_generic_model() -> None:
    """Have Numba compile for LLVM's generic CPU model with this machine's instruction set
    (``NUMBA_CPU_NAME=generic``, ``NUMBA_CPU_FEATURES`` the host's), unless the user chose a
    model (``NUMBA_CPU_NAME``) or this process has compiled with Numba already (its CPU target
    is then fixed). LLVM 14's model of the host can cost the compile dearly: the kernel took
    275 s for AMD's znver3 and 86 s for the generic model with the same features, which step
    alike (the products are BLAS calls, the loops scalar; docs/compiled-step.md). Numba keys
    its cache by the model and features, so a kernel cached for another is not served."""
    import numba
    from numba.core import registry
    from numba.core.codegen import get_host_cpu_features

    if (os.environ.get("NUMBA_CPU_NAME")
            or "_toplevel_target_context" in vars(registry.cpu_target)):
        return
    numba.config.CPU_NAME = "generic"
    if numba.config.CPU_FEATURES is None:
        numba.config.CPU_FEATURES = get_host_cpu_features()


@lru_cache(maxsize=1)
def kernel_module() -> ModuleType:
    """``compiled.step``, its functions cached in :func:`cache_folder` (older kernels' folders
    beside it removed), compiled for the generic CPU model (:func:`compile_for_generic_model`)."""
    import numba

    compile_for_generic_model()
    folder = cache_folder()
    for old in folder.parent.glob("kernel-*"):
        if old != folder:
            shutil.rmtree(old, ignore_errors=True)
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(folder)
    try:
        from gcms_fenicsx.dynamics.stepping.compiled import step
    finally:
        numba.config.CACHE_DIR = previous
    return step


class CompiledStepper:
    """Stretches of compiled steps of one run, handing a step the kernel leaves to the NumPy
    step of the same stepper (module docstring of ``compiled``)."""

    def __init__(self, integrator: Any, data: StepData) -> None:
        self.integrator, self.data, self.compiled = integrator, data, kernel_module()
        self.policy = np.zeros(3, dtype=np.int64)
        self.last = np.zeros(3)          # last step's iterations, its energy; iterations sum
        self.work: tuple | None = None   # the stretches' work arrays, made by warm_up

    def warm_up(self, recorder: Any, state: State) -> tuple[float, bool | None]:
        """Compile the kernel (or load it from the cache) by a stretch of no steps, under
        :func:`compile_lock`, and make the run's work arrays: (seconds, whether it came from the
        cache; None if this process had it already). A cache that does not load is removed and
        the kernel compiled again; a second failure is raised."""
        run = self.compiled.run_stretch
        stats = run.stats
        hits, misses = sum(stats.cache_hits.values()), sum(stats.cache_misses.values())
        start = time.perf_counter()
        args = (self.data, recorder.raw, state.Z.copy(), state.lam.copy(), state.t, 0, 0,
                self.integrator.h, self.policy, self.last)
        with compile_lock():
            try:
                self.work = self.compiled.work_arrays(self.data)
                run(*args, self.work)
            except Exception:    # a damaged cache fails to load: drop it and compile afresh
                shutil.rmtree(cache_folder(), ignore_errors=True)
                self.work = self.compiled.work_arrays(self.data)
                run(*args, self.work)
        seconds = time.perf_counter() - start
        if sum(stats.cache_hits.values()) > hits:
            return seconds, True
        return seconds, (False if sum(stats.cache_misses.values()) > misses else None)

    def stretch(self, state: State, index: int, stop: int, recorder: Any
                ) -> tuple[int, int, State, StepInfo | None, int]:
        """Steps index + 1 … stop (fewer if the block fills or a step is handed over):
        (status, steps taken, the state reached, its step's info (None if no step), the
        Newton iterations of those steps)."""
        it = self.integrator
        policy = self.policy
        policy[:] = it.policy.frame_terms, it.policy.kept_steps, it.linear.kept
        Z, lam = state.Z.copy(), state.lam.copy()
        self.last[2] = 0.0
        status, taken, t = self.compiled.run_stretch(self.data, recorder.raw, Z, lam, state.t,
                                                     index, stop, it.h, policy, self.last,
                                                     self.work)
        it.policy.frame_terms, it.policy.kept_steps = bool(policy[0]), int(policy[1])
        it.linear.kept = bool(policy[2])
        if not taken:
            return status, 0, state, None, 0
        info = StepInfo(KernelElastic(float(self.last[1])), 0.0, it.constraints.directions,
                        int(self.last[0]), it.forces.gravity_force)
        return status, taken, State(t, Z, lam), info, int(self.last[2])

    @property
    def handed_over(self) -> int:
        return self.compiled.HANDED_OVER

    @property
    def block_full(self) -> int:
        return self.compiled.BLOCK_FULL


def choose_kernel(integrator: Any, setting: str, progress: Progress
                  ) -> tuple[KernelChoice, CompiledStepper | None]:
    """The step a run takes (module docstring), and the compiled stepper if it is Numba's."""
    wanted = requested(setting)
    if wanted == "numpy":
        return KernelChoice("numpy", "asked for"), None
    why = numba_missing() or unsupported(integrator)
    if why is not None:
        if wanted == "numba":
            raise SceneError(f'[scene.solver] kernel = "numba" cannot run this scene: {why}; '
                             'kernel = "numpy" or "auto" steps it in NumPy')
        return KernelChoice("numpy", why), None
    return KernelChoice("numba"), CompiledStepper(integrator, step_data(integrator))
