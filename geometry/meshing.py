"""Params → OCC model → tetrahedral mesh → ``.msh`` file, inside a clean Gmsh session.

``build_msh`` builds the body with the OCC kernel, tags the physical groups (a 3D group
``body`` and the named surfaces, see ``geometry.groups``), reads the kernel's mass
properties, meshes in 3D (order 2: 10-node tetrahedra whose edge midpoints lie on the
CAD, so round surfaces are curved), and writes MSH 4.1 with only the physical groups'
elements, as ``dolfinx.io.gmshio.read_from_msh`` wants. The model is built in units of
the power of ten nearest the body's size and the file written in metres, so the kernel's
absolute tolerances scale with the body. A failure of the kernel is a GeometryError. The file
appears atomically or not at all, and Gmsh is finalized on every path.
"""
from __future__ import annotations

import contextlib
import os
import secrets
import sys
from collections.abc import Callable, Iterator
from functools import singledispatch
from pathlib import Path
from typing import Any

import gmsh
import numpy as np

from geometry import groups
from geometry.beam import add_beam
from geometry.errors import GeometryError, KernelFailure
from geometry.info import MeshInfo
from geometry.solid import Solid
from geometry.conrod import add_conrod
from geometry.crankshaft import add_crankshaft
from geometry.extent import largest_extent
from geometry.params import (ELEMENTS_PER_CIRCLE, BeamParams, ConrodParams, CrankshaftParams,
                             Geometry, MeshParams, geometry_keys, model_unit, surface_groups)

SetOption = Callable[[str, float], None]  # gmsh.option.setNumber, undone after the session
MODEL_NAME = "gcms_geometry"  # the model a session works in inside someone else's Gmsh

#: Element type of Gmsh's 3D elements by order: 4-node and 10-node tetrahedra.
TETRAHEDRON = {1: 4, 2: 11}


def build_msh(geom: Geometry, mesh: MeshParams, path: Path, *, verbose: bool = False) -> MeshInfo:
    """Build ``geom``, mesh it as ``mesh`` says, and write ``path`` (MSH 4.1, binary).

    The model is built and meshed in units of the power of ten nearest the body's largest
    extent (``params.model_unit``) and written in metres (``Mesh.ScalingFactor``), so OCC's
    and Gmsh's absolute tolerances are relative to the body: a body scaled by 1e-3 or 1e3,
    its mesh sizes with it, gets the same mesh scaled. A failure of the geometry kernel or
    the mesher is a GeometryError naming the geometry's keys and the kernel's message.
    """
    path = Path(path)
    unit = model_unit(largest_extent(geom))
    with gmsh_session(verbose) as set_option:
        with kernel_errors(geom, mesh):
            body = add_body(geom.in_units(unit))
            group_tags = _add_physical_groups(geom, body)
            mass = _mass_properties(body.volume, unit)
            set_mesh_sizes(set_option, body, mesh.in_units(unit))
            gmsh.model.mesh.generate(3)
            if mesh.order == 2:
                gmsh.model.mesh.setOrder(2)
                _check_curved_cells(mesh)
        nodes = len(gmsh.model.mesh.getNodes()[0])
        cells = len(gmsh.model.mesh.getElementsByType(TETRAHEDRON[mesh.order])[0])
        set_option("Mesh.MshFileVersion", 4.1)
        set_option("Mesh.Binary", 1)
        set_option("Mesh.SaveAll", 0)  # physical groups only
        set_option("Mesh.ScalingFactor", unit)  # model units → metres in the file
        _write_atomically(path)
    return MeshInfo(nodes=nodes, cells=cells, groups=group_tags, mass_properties=mass)


@contextlib.contextmanager
def kernel_errors(geom: Geometry, mesh: MeshParams) -> Iterator[None]:
    """Turn the bare ``Exception`` Gmsh raises with the kernel's last error (OCC's or the
    mesher's) and a :class:`KernelFailure` into a one-line GeometryError naming the keys of
    the geometry, the mesh size and the kernel's message; other exceptions pass unchanged."""
    try:
        yield
    except Exception as exc:
        if type(exc) not in (Exception, KernelFailure):
            raise
        key = "section" if isinstance(geom, BeamParams) else "kind"
        message = " ".join(str(exc).split())
        raise GeometryError(f"[geometry] {key}", getattr(geom, key),
                          f"the geometry kernel could not build or mesh this {geom.kind} "
                          f"({message}): check {', '.join(geometry_keys(geom))} against "
                          f"each other and [mesh] size = {mesh.size:g}") from exc


@singledispatch
def add_body(geom) -> Solid:
    """Build ``geom`` in the current Gmsh model."""
    raise TypeError(f"no builder for {type(geom).__name__}")


add_body.register(BeamParams, add_beam)
add_body.register(CrankshaftParams, add_crankshaft)
add_body.register(ConrodParams, add_conrod)


def _add_physical_groups(geom: Geometry, body: Solid) -> dict[str, tuple[int, int]]:
    gmsh.model.addPhysicalGroup(3, [body.volume], groups.BODY_TAG)
    gmsh.model.setPhysicalName(3, groups.BODY_TAG, groups.BODY)
    tags = {groups.BODY: (3, groups.BODY_TAG)}
    for name, tag in surface_groups(geom).items():
        if not body.surfaces.get(name):
            raise KernelFailure(f"surface group {name!r} matched no face of the model")
        gmsh.model.addPhysicalGroup(2, body.surfaces[name], tag)
        gmsh.model.setPhysicalName(2, tag, name)
        tags[name] = (2, tag)
    return tags


def _mass_properties(volume: int, unit: float) -> dict[str, Any]:
    """OCC's mass properties of ``volume`` (modelled in units of ``unit`` metres) in SI."""
    occ = gmsh.model.occ
    box = np.array(occ.getBoundingBox(3, volume)) * unit
    return {
        "volume_m3": occ.getMass(3, volume) * unit**3,
        "center_of_mass_m": (np.array(occ.getCenterOfMass(3, volume)) * unit).tolist(),
        "inertia_m5": (np.reshape(occ.getMatrixOfInertia(3, volume), (3, 3)) * unit**5).tolist(),
        "bounding_box_m": [box[:3].tolist(), box[3:].tolist()],
    }


def _check_curved_cells(mesh: MeshParams) -> None:
    """Moving edge midpoints onto the CAD can fold a 10-node cell where a coarse mesh meets
    a thin curved wall (dolfinx would integrate negative volume there); Gmsh's high-order
    optimizer does not repair such meshes, so reject the size that caused them."""
    kind = TETRAHEDRON[2]
    points, _ = gmsh.model.mesh.getIntegrationPoints(kind, "Gauss4")
    _, determinants, _ = gmsh.model.mesh.getJacobians(kind, points)
    folded = int(np.sum(determinants.reshape(-1, len(points) // 3).min(axis=1) <= 0.0))
    if folded:
        raise GeometryError("[mesh] size", mesh.size,
                          f"folds {folded} curved order-2 cells (a thin round wall meshed too "
                          "coarsely): use a smaller size, or order = 1")


def set_mesh_sizes(set_option: SetOption, body: Solid, mesh: MeshParams) -> None:
    """Element sizes: at most ``mesh.size``, at most 1/ELEMENTS_PER_CIRCLE of a round
    surface's circumference, and ``refine[name]`` on each named surface, growing linearly
    to ``mesh.size`` over two mesh sizes (Distance + Threshold fields, minimum of all)."""
    set_option("Mesh.MeshSizeMax", mesh.size)
    set_option("Mesh.MeshSizeFromCurvature", ELEMENTS_PER_CIRCLE)
    if not mesh.refine:
        return
    field = gmsh.model.mesh.field
    thresholds = []
    for name, size in mesh.refine.items():
        distance = field.add("Distance")
        field.setNumbers(distance, "SurfacesList", body.surfaces[name])
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", size)
        field.setNumber(threshold, "SizeMax", mesh.size)
        field.setNumber(threshold, "DistMin", 0.0)
        field.setNumber(threshold, "DistMax", 2.0 * mesh.size)
        thresholds.append(threshold)
    smallest = field.add("Min")
    field.setNumbers(smallest, "FieldsList", thresholds)
    field.setAsBackgroundMesh(smallest)


def _write_atomically(path: Path) -> None:
    """gmsh.write to a uniquely named ``.msh`` beside ``path`` (Gmsh picks the format by
    the suffix), then rename it over ``path``."""
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.msh")
    try:
        gmsh.write(str(tmp))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def gmsh_session(verbose: bool = False) -> Iterator[SetOption]:
    """A fresh Gmsh model for the block; yields ``set_option(name, value)``.

    If nobody has initialized Gmsh, the session initializes and finalizes it. If someone
    has, it leaves their session alone: it works in a model of its own, removes it at
    the end, makes theirs current again and restores every option it set. (With Gmsh 4.8
    a caller's session is recognised if it was opened after this module's import.)
    """
    saved: dict[str, float] = {}

    def set_option(name: str, value: float) -> None:
        saved.setdefault(name, gmsh.option.getNumber(name))
        gmsh.option.setNumber(name, value)

    def restore_options() -> None:
        for name, value in saved.items():
            gmsh.option.setNumber(name, value)

    def leave_model(previous: str) -> None:
        gmsh.model.remove()
        gmsh.model.setCurrent(previous)

    with contextlib.ExitStack() as cleanup:
        if gmsh_initialized():
            cleanup.callback(restore_options)
            previous = gmsh.model.getCurrent()
            gmsh.model.add(MODEL_NAME)
            cleanup.callback(leave_model, previous)
        else:
            gmsh.initialize(readConfigFiles=False)
            cleanup.callback(gmsh.finalize)
        set_option("General.Terminal", 1 if verbose else 0)
        yield set_option


#: Gmsh 4.8 has no isInitialized, and an API call made before the process's first
#: gmsh.initialize reads options that were never set: depending on the heap it returns,
#: raises, or ends the process with status 1 (seen as a silent pytest exit). Every
#: gmsh.initialize after this module's import is recorded, so the probe in
#: gmsh_initialized runs only once Gmsh has been initialized at least once.
_ever_initialized = False


def _recording(initialize: Callable[..., None]) -> Callable[..., None]:
    """gmsh.initialize, noting in ``_ever_initialized`` that the process has called it."""
    def recorded(*args: Any, **kwargs: Any) -> None:
        global _ever_initialized
        initialize(*args, **kwargs)
        _ever_initialized = True
    return recorded


if not hasattr(gmsh, "isInitialized"):
    gmsh.initialize = _recording(gmsh.initialize)


def gmsh_initialized() -> bool:
    """gmsh.isInitialized() where it exists (Gmsh ≥ 4.9). Gmsh 4.8 lacks it: False until
    gmsh.initialize has been called in this process (see ``_ever_initialized``), then a
    probe with gmsh.model.list(), which lists at least one model while initialized and
    raises (after printing an error, silenced here) once finalized."""
    if hasattr(gmsh, "isInitialized"):
        return bool(gmsh.isInitialized())
    if not _ever_initialized:
        return False
    with _silenced_output():
        try:
            return bool(gmsh.model.list())
        except Exception:
            return False


@contextlib.contextmanager
def _silenced_output() -> Iterator[None]:
    """Send the process's stdout and stderr (file descriptors 1 and 2) to /dev/null."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)
