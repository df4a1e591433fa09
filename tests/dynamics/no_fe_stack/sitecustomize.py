"""A machine without the finite-element stack, for ``tests/dynamics``.

With this folder first on PYTHONPATH, every Python process started with that environment —
the pytest run of ``tests/dynamics`` that ``tests/test_standalone_dynamics.py`` starts, and
the commands its tests start in turn — imports this module at interpreter start-up, before
pytest, its plugins or any test module. It puts first in ``sys.meta_path`` a finder that
raises ImportError for dolfinx, ufl, basix, ffcx, petsc4py, slepc4py, mpi4py, gmsh and
scipy (and their submodules), as if they were not installed, and names them in
GCMS_NO_FE_STACK: ``tests/conftest.py`` collects ``tests/dynamics`` only then, and
``tests/dynamics/test_no_fe_stack.py`` checks the blocker works. By hand::

    PYTHONPATH=tests/dynamics/no_fe_stack python -m pytest tests/dynamics

The sitecustomize this one hides (Debian's installs the apport crash hook) is run after it.
"""
import importlib.machinery
import importlib.util
import os
import sys

BLOCKED = ("dolfinx", "ufl", "basix", "ffcx", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy")
ENVIRONMENT = "GCMS_NO_FE_STACK"


class NoFiniteElementStack:
    """Refuse every module of the finite-element stack, as on a machine without it."""

    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ImportError(f"{name} is not installed here (tests/dynamics runs without the "
                              "finite-element stack)", name=name)
        return None


def _install() -> None:
    # nothing has imported them yet (start-up imports only the standard library), but say
    # so rather than assume: a module already in sys.modules would bypass the finder
    loaded = sorted(m for m in sys.modules if m.partition(".")[0] in BLOCKED)
    if loaded:
        os.environ.pop(ENVIRONMENT, None)
        print(f"sitecustomize: already imported, cannot be blocked: {loaded}", file=sys.stderr)
        return
    sys.meta_path.insert(0, NoFiniteElementStack())
    os.environ[ENVIRONMENT] = ",".join(BLOCKED)


def _run_the_hidden_sitecustomize() -> None:
    here = os.path.dirname(os.path.abspath(__file__))
    rest = [p for p in sys.path if os.path.abspath(p or os.curdir) != here]
    spec = importlib.machinery.PathFinder.find_spec("sitecustomize", rest)
    if spec is not None and spec.loader is not None:
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)


_install()
_run_the_hidden_sitecustomize()
