"""The package's plan, checked: layers by role that import only downwards (docs/design.md,
Layers), an import graph without cycles, ``geometry`` independent of ``gcms_fenicsx``, the
light set (runtime, numerics, configuration, file formats, dynamics) importable without the
finite-element stack, and modules and functions of a readable size."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO

PACKAGES = ("gcms_fenicsx", "geometry")
#: What a machine without the finite-element stack lacks.
FE_STACK = ("dolfinx", "ufl", "basix", "ffcx", "petsc4py", "slepc4py", "mpi4py", "gmsh", "scipy")
#: The subpackages that must import with NumPy and h5py only.
LIGHT = ("gcms_fenicsx.config", "gcms_fenicsx.files", "gcms_fenicsx.dynamics",
         "gcms_fenicsx.runtime", "gcms_fenicsx.numerics")
#: The layers of gcms_fenicsx, lowest first (docs/design.md, Layers): a package imports only
#: from its own layer's package and from the layers below; packages that share a layer do
#: not import each other. ``data`` (the default study) sits with the runtime; ``cli``, the
#: ``gcms`` entry point, is the top-level module above the application.
LAYERS = (("runtime", "data"), ("numerics",), ("config",), ("files",),
          ("fe", "reduction", "dynamics"), ("references",), ("app",), ("cli",))
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80


def modules() -> dict[str, Path]:
    """Every module of the two packages by dotted name (a package by its ``__init__``)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            parts = path.relative_to(REPO).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


def imports(path: Path, name: str, known: set[str]) -> set[str]:
    """The modules of ``known`` that ``path`` imports anywhere (top level, in functions, under
    TYPE_CHECKING): ``import a.b``, ``from a import b`` (module b or a name of a)."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            targets = [f"{base}.{alias.name}" for alias in node.names] + [base]
        else:
            continue
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                out.add(target)
    return out


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {name: imports(path, name, set(mods)) for name, path in mods.items()}


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in edges:
        if v not in index:
            visit(v)
    return out


def _is_package_init_edge(a: str, b: str) -> bool:
    """A package's ``__init__`` re-exporting its own submodule is not a cycle of design."""
    return b.startswith(a + ".")


def test_the_import_graph_has_no_cycles():
    edges = graph()
    edges = {a: {b for b in bs if not _is_package_init_edge(a, b)} for a, bs in edges.items()}
    assert cycles(edges) == []


def package_edges() -> dict[str, set[str]]:
    """Which packages of gcms_fenicsx each package's modules import (a package's own
    modules and the top-level ``gcms_fenicsx`` left out)."""
    def package(module: str) -> str | None:
        parts = module.split(".")
        return parts[1] if parts[0] == "gcms_fenicsx" and len(parts) > 1 else None

    edges: dict[str, set[str]] = {}
    for a, bs in graph().items():
        if package(a) is not None:
            edges.setdefault(package(a), set()).update(
                p for b in bs if (p := package(b)) not in (None, package(a)))
    return edges


def test_every_package_has_a_layer():
    layered = {p for layer in LAYERS for p in layer}
    assert set(package_edges()) <= layered, set(package_edges()) - layered


def test_packages_import_only_down_the_layers():
    """No package imports a package of its own layer or of a layer above it — so there is no
    cycle between packages either; e.g. dynamics (``python -m gcms_fenicsx.dynamics``)
    imports nothing of the application, fe nothing of dynamics."""
    rank = {p: i for i, layer in enumerate(LAYERS) for p in layer}
    upward = {a: sorted(b for b in bs if rank[b] >= rank[a])
              for a, bs in package_edges().items()}
    assert {a: bs for a, bs in upward.items() if bs} == {}


def test_geometry_imports_nothing_of_gcms_fenicsx():
    edges = graph()
    offending = {a: sorted(b for b in bs if b.startswith("gcms_fenicsx"))
                 for a, bs in edges.items() if a.startswith("geometry")}
    assert {a: bs for a, bs in offending.items() if bs} == {}


def test_the_light_set_imports_without_the_finite_element_stack():
    """Every module of the configuration, file formats, dynamics and runtime subpackages
    imports in a process where dolfinx, PETSc, SLEPc, MPI, Gmsh and SciPy cannot be."""
    light = sorted(name for name in modules() if name.startswith(LIGHT))
    script = f"""
import importlib, importlib.abc, sys
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {FE_STACK!r}:
            raise ImportError(name + " is not installed here")
sys.meta_path.insert(0, Block())
for name in {light!r}:
    importlib.import_module(name)
print(len({light!r}))
"""
    run = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert int(run.stdout) == len(light) > 20


@pytest.mark.parametrize("package", PACKAGES)
def test_modules_and_functions_are_of_a_readable_size(package):
    """No module over MAX_MODULE_LINES lines and no function over MAX_FUNCTION_LINES."""
    long_modules, long_functions = [], []
    for name, path in modules().items():
        if not name.startswith(package):
            continue
        text = path.read_text()
        if text.count("\n") > MAX_MODULE_LINES:
            long_modules.append((name, text.count("\n")))
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_functions.append((f"{name}.{node.name}", length))
    assert long_modules == [] and long_functions == []
