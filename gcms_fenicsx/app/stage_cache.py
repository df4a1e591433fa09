"""The stage cache: which products in ``--out`` a command may reuse instead of computing.

Each stage's product is kept in ``--out`` with the key of exactly the tables it depends on
and a content checksum:

- the mesh, ``mesh.msh``: key ``input_digest`` = [geometry] + [mesh] in ``mesh.json``;
- the free-free modes with the modal basis, ``modes.h5`` (``files.modes_file``): key
  [geometry] + [mesh] + [material] + the solve's accuracy + the attachment loads
  (``config.plan.CacheKeys``), not
  the mode count: a file with more modes than asked serves, restricted to the lowest ones
  (a leading block), and one whose verified Sylvester count reaches past
  ``max_frequency_hz`` serves that band;
- the reduced model, ``reduced.h5``: key ``input_hash`` over REDUCED_MODEL_TABLES, and the
  elastic law where ``[scene] elasticity = "svk"`` adds its coefficients
  (``config.plan.CacheKeys``), which are computed on the modes' own mesh; a model with
  them also serves a co-rotated scene (the co-rotated law ignores them);
- the stress modes' mesh part, ``stress_modes.h5`` (``files.stress_nodes``), when the scene
  asks for stresses: key the mesh's and the requested nodes (``config.plan.stress_key``), so
  asking for stresses later forms only it, on the cached mesh.

Every command writes ``cache.json``, the SHA-256 of each cached file's bytes (mesh.msh,
mesh.json, modes.h5, reduced.h5), and a listed file is hashed and compared before it is
parsed: a damaged HDF5 file can crash the HDF5 library itself. Every cached file can also
be verified without the manifest: mesh.json records mesh.msh's SHA-256 and carries its own
(``files.checksums``), and the HDF5 files carry the checksums of every dataset, of their
root attributes and of their layout (``files.versioned``). A file the manifest does not
list — copied in by hand, or the manifest missing or damaged — is reused only if its own
checks hold (a mesh.msh or mesh.json of an earlier version, which carry none, is not), and
the manifest written next lists it again. A product whose bytes do not match a recorded
checksum, whose key differs or that cannot be read is never used: the command says why in
one progress line and computes it again. The plan is
made before anything runs (rank 0), so the command knows which files it will replace.
The simulation always runs: it is what a scene asks for. NumPy and h5py only.
"""
from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from gcms_fenicsx.config.plan import REDUCED_MODEL_TABLES, BodyPlan
from gcms_fenicsx.files.checksums import document_intact, file_sha256
from gcms_fenicsx.files.modes_file import ModesFileError, StoredModes, read_modes
from gcms_fenicsx.files.reduced_model import ReducedModel, ReducedModelError, read_reduced
from gcms_fenicsx.files.stress_nodes import StressNodes, StressNodesError, read_stress_nodes
from gcms_fenicsx.numerics.spectrum import clusters, cut_cluster_warning
from gcms_fenicsx.runtime.progress import Progress
from geometry.info import MeshInfo

T = TypeVar("T")
#: The cache's manifest in --out, and the files it covers.
MANIFEST = "cache.json"
CACHED_FILES = ("mesh.msh", "mesh.json", "modes.h5", "reduced.h5", "stress_modes.h5")
#: Files of each reusable stage, and of the stages above it that a reuse skips.
MESH_PRODUCT = ("mesh.msh", "mesh.json")
MODES_PRODUCT = (*MESH_PRODUCT, "modes.h5")
REDUCED_PRODUCT = (*MODES_PRODUCT, "modes.json", "reduced.h5", "selection.json")


@dataclass(frozen=True)
class CachedMesh:
    """A reusable mesh: the .msh file, what Gmsh reported, and its mesh.json document."""

    msh_path: Path
    info: MeshInfo
    document: dict


@dataclass(frozen=True)
class Reuse:
    """What a command reuses (None: computed): the same on every rank."""

    mesh: CachedMesh | None = None
    modes: StoredModes | None = None
    reduced: ReducedModel | None = None
    stress: StressNodes | None = None

    def kept(self) -> tuple[str, ...]:
        """The files of ``--out`` this plan leaves as they are."""
        stress = ("stress_modes.h5",) if self.stress is not None else ()
        if self.reduced is not None and self.modes is None and self.mesh is None:
            return REDUCED_PRODUCT + stress
        reused = MODES_PRODUCT if self.modes is not None else \
            MESH_PRODUCT if self.mesh is not None else ()
        return reused + (("reduced.h5", "selection.json") if self.reduced is not None
                         else ()) + stress

    def verified(self) -> tuple[str, ...]:
        """The cached files of ``--out`` this plan checked before reusing them: not those a
        reuse further down merely leaves in place (a reused reduced.h5 leaves mesh.msh and
        modes.h5 unread)."""
        return (("mesh.msh", "mesh.json") if self.mesh is not None else ()) + \
            (("modes.h5",) if self.modes is not None else ()) + \
            (("reduced.h5",) if self.reduced is not None else ()) + \
            (("stress_modes.h5",) if self.stress is not None else ())


def owned_files(reuse: Reuse, owns: tuple[str, ...]) -> tuple[str, ...]:
    """The files of ``owns`` the command replaces, or removes if it does not write them."""
    return tuple(name for name in owns if name not in reuse.kept())


#: The mesh.json entry holding mesh.msh's SHA-256.
MESH_CHECKSUM = "mesh_sha256"


def read_manifest(out: Path) -> dict[str, str] | None:
    """``out/cache.json``'s file → SHA-256 entries; None if it is absent or damaged (not a
    manifest): then nothing is known of the files but what they carry themselves."""
    try:
        files = json.loads((Path(out) / MANIFEST).read_text())["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not isinstance(files, dict) or not all(isinstance(sha, str) for sha in files.values()):
        return None
    return {name: sha for name, sha in files.items() if name in CACHED_FILES}


def write_manifest(out: Path, folder: Path, owned: tuple[str, ...], reuse: Reuse) -> None:
    """``folder/cache.json``: the cached files this command staged and those it checked and
    reused (:meth:`Reuse.verified`), hashed, and the entries of ``out``'s manifest for the
    other cached files it leaves as they are (not in ``owned``): a file nothing checked is
    never listed on its own word."""
    from gcms_fenicsx.files.outputs import write_json

    files = {name: sha for name, sha in (read_manifest(out) or {}).items() if name not in owned}
    files.update({name: file_sha256(out / name) for name in reuse.verified()})
    files.update({name: file_sha256(folder / name) for name in CACHED_FILES
                  if (folder / name).is_file()})
    write_json(folder / MANIFEST, {"files": dict(sorted(files.items()))})


def _intact(out: Path, manifest: dict[str, str] | None, names: tuple[str, ...],
            progress: Progress, what: str) -> bool:
    """Whether the files ``names`` of ``out`` are those the manifest recorded (a line if not).
    A file it does not list is left to its own checks."""
    for name in names:
        if name in (manifest or {}) and file_sha256(out / name) != manifest[name]:
            progress(f"{what}: {out / name} does not match its checksum in {MANIFEST} "
                     "(changed or damaged); computing again")
            return False
    return True


def _mesh_record_intact(out: Path, manifest: dict[str, str] | None, document: dict,
                        progress: Progress) -> bool:
    """Whether mesh.json and mesh.msh pass the checks they carry themselves (mesh.json its own
    checksum, mesh.msh the one mesh.json records); a file the manifest does not list must
    carry one (a line if not)."""
    listed = manifest or {}
    own = document_intact(document)
    if own is False or (own is None and "mesh.json" not in listed):
        progress(f"mesh: {out / 'mesh.json'} " + ("does not match its own checksum (changed or "
                 "damaged)" if own is False else f"carries no checksum and {MANIFEST} does not "
                 "list it") + "; meshing again")
        return False
    recorded = document.get(MESH_CHECKSUM)
    if recorded is None and "mesh.msh" not in listed:
        progress(f"mesh: {out / 'mesh.msh'} has no checksum (none in mesh.json, not listed in "
                 f"{MANIFEST}); meshing again")
        return False
    if recorded is not None and file_sha256(out / "mesh.msh") != recorded:
        progress(f"mesh: {out / 'mesh.msh'} does not match its checksum in mesh.json (changed "
                 "or damaged); meshing again")
        return False
    return True


def reuse(body: BodyPlan, out: Path, upto: str, fresh: bool, progress: Progress) -> Reuse:
    """What to reuse for a command that needs the stages up to ``upto`` ("mesh", "modes",
    "reduced"): the furthest reusable product, and nothing above it that it makes
    unnecessary. Mode shapes asked for (``[outputs]``) need the modes and the mesh, and so
    does a reduced model with SVK coefficients (integrated on the mesh) that must be built."""
    out = Path(out)
    if fresh:
        progress("--fresh: every stage is computed, nothing in the output folder is reused")
        return Reuse()
    manifest = read_manifest(out)
    if manifest is None and any((out / name).is_file() for name in CACHED_FILES):
        progress(f"cache: {out / MANIFEST} is " + ("damaged" if (out / MANIFEST).exists() else
                 "missing") + ": each cached file is reused only if its own checksums hold, "
                 "and the manifest is written anew")
    shapes = body.outputs.mode_shapes and upto != "mesh"
    reduced = cached_reduced(body, out, manifest, progress) if upto == "reduced" else None
    asked = upto == "reduced" and body.stress is not None
    stress = cached_stress(body, out, manifest, progress) if asked else None
    if reduced is not None and not shapes and (stress is not None or not asked):
        return _said(Reuse(reduced=reduced, stress=stress), out, progress)
    on_mesh = shapes or (upto == "reduced" and reduced is None and body.svk) or \
        (asked and stress is None)
    modes = cached_modes(body, out, manifest, progress) if upto != "mesh" else None
    if modes is not None and not on_mesh:
        return _said(Reuse(modes=modes, reduced=reduced, stress=stress), out, progress)
    mesh = cached_mesh(body, out, manifest, progress)
    if on_mesh and (modes is not None or reduced is not None) and mesh is None:
        why = "mode shapes are written" if shapes else \
            "the SVK coefficients are integrated" if body.svk and reduced is None else \
            "the stress modes are formed"
        progress(f"modes: the cached modes' mesh cannot be reused, so neither can they nor the "
                 f"reduced model ({why} on that mesh); solving again")
        modes = reduced = None
    return _said(Reuse(mesh=mesh, modes=modes, reduced=reduced, stress=stress), out, progress)


def _said(reuse: Reuse, out: Path, progress: Progress) -> Reuse:
    """``reuse``, with a line for each of the reduced model and the stress modes it reuses
    (said once the plan is final: a product found intact may still be dropped with the mesh
    it was made on)."""
    if reuse.reduced is not None:
        progress(f"reduced model: reusing {out / 'reduced.h5'} ({reuse.reduced.dofs} "
                 "coordinates; inputs unchanged)")
    if reuse.stress is not None:
        progress(f"stress modes: reusing {out / 'stress_modes.h5'} "
                 f"({len(reuse.stress.requested)} nodes; inputs unchanged)")
    return reuse


def cached_mesh(body: BodyPlan, out: Path, manifest: dict[str, str] | None,
                progress: Progress) -> CachedMesh | None:
    """``out/mesh.msh`` if mesh.json says it was made from this study's [geometry] and [mesh]
    and the checksums of both hold, else None."""
    msh, record = out / "mesh.msh", out / "mesh.json"
    if not (msh.is_file() and record.is_file()) or \
            not _intact(out, manifest, ("mesh.msh", "mesh.json"), progress, "mesh"):
        return None
    try:
        document = json.loads(record.read_text())
        key = document["input_digest"]
        info = MeshInfo.from_json(document["geometry"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        progress(f"mesh: {record} cannot be read ({exc}); meshing again")
        return None
    if not _mesh_record_intact(out, manifest, document, progress):
        return None
    if key != body.keys.mesh:
        progress(f"mesh: {msh} was made from other [geometry] or [mesh] values; meshing again")
        return None
    progress(f"mesh: reusing {msh} ({info.nodes} nodes; inputs unchanged)")
    return CachedMesh(msh_path=msh, info=info, document=document)


def cached_modes(body: BodyPlan, out: Path, manifest: dict[str, str] | None,
                 progress: Progress) -> StoredModes | None:
    """``out/modes.h5`` restricted to the modes this study asks for, if it was solved from
    the same inputs and holds them all, intact; else None."""
    path = out / "modes.h5"
    if not path.is_file() or not _intact(out, manifest, ("modes.h5",), progress, "modes"):
        return None
    try:
        stored = read_modes(path)
    except ModesFileError as exc:
        progress(f"modes: {exc}; solving again")
        return None
    if stored.key != body.keys.modes:
        progress(f"modes: {path} was solved from other [geometry], [mesh], [material] or "
                 "[modes] accuracy values, or other attachment loads ([basis] attachment "
                 "and the [scene]'s joints and loads); solving again")
        return None
    held, request = stored.basis.mode_count, body.modes
    if request.cut is None:
        count = request.count_from(0)
        if count > held:
            progress(f"modes: {path} holds {held} elastic modes, {count} asked; solving again")
            return None
    else:
        verified = stored.document["verification"]["sylvester"]["shift"]
        elastic = stored.basis.eigenvalues[stored.basis.rigid_count:]
        count = request.count_from(int(np.count_nonzero(elastic < request.cut)))
        if request.cut >= verified:
            progress(f"modes: {path} does not cover every mode below "
                     f"{request.max_frequency_hz:g} Hz; solving again")
            return None
        if count < 1:
            progress(f"modes: {path} holds no elastic mode below "
                     f"{request.max_frequency_hz:g} Hz; solving to say so with the count")
            return None
    progress(f"modes: reusing {path} ({count} of its {held} elastic modes; inputs unchanged)")
    return restricted(stored, count)


def restricted(stored: StoredModes, count: int) -> StoredModes:
    """The rigid and the lowest ``count`` elastic modes of ``stored``, with the modes.json
    document of those modes (the Sylvester check of the whole solve covers them)."""
    basis = stored.basis.lowest(count)
    held, rigid = stored.basis.mode_count, basis.rigid_count
    doc = dict(stored.document)
    keep = rigid + count
    for name in ("eigenvalues_rad2_s2", "relative_residuals", "rigid_fractions"):
        doc[name] = doc[name][:keep]
    doc["elastic_frequencies_hz"] = doc["elastic_frequencies_hz"][:count]
    verification = json.loads(json.dumps(doc["verification"]))
    backward = verification["backward_error"]
    backward["per_mode"] = backward["per_mode"][:keep]
    backward["measured"] = max(backward["per_mode"])
    verification["rigid_content"]["measured"] = max(doc["rigid_fractions"][rigid:], default=0.0)
    doc.update(verification=verification, elastic_mode_count=count,
               max_relative_residual=max(doc["relative_residuals"]),
               max_backward_error=backward["measured"],
               repeated_eigenvalues=clusters(basis.eigenvalues[rigid:]),
               cached_elastic_mode_count=held)
    if count < held:
        ev = stored.basis.eigenvalues
        warning = cut_cluster_warning(ev[keep - 1], ev[keep], count)
        doc["warnings"] = [w for w in doc["warnings"] if "near-repeated group" not in w] + \
            ([warning] if warning else [])
    return replace(stored, basis=basis, document=doc)


def _read_intact(out: Path, manifest: dict[str, str] | None, name: str, what: str,
                 read: Callable[[Path], T], error: type[Exception], instead: str,
                 progress: Progress) -> T | None:
    """``read(out/name)`` if the file is there, matches the manifest and reads; else None,
    with a line saying why and what the command does ``instead``."""
    path = out / name
    if not path.is_file() or not _intact(out, manifest, (name,), progress, what):
        return None
    try:
        return read(path)
    except error as exc:
        progress(f"{what}: {path} cannot be used ({exc}); {instead}")
        return None


def cached_stress(body: BodyPlan, out: Path, manifest: dict[str, str] | None,
                  progress: Progress) -> StressNodes | None:
    """``out/stress_modes.h5`` if it was made on this study's mesh for the nodes its scene
    asks stresses at, intact; else None (with a line saying why it is formed again)."""
    path = out / "stress_modes.h5"
    nodes = _read_intact(out, manifest, path.name, "stress modes", read_stress_nodes,
                         StressNodesError, "forming them again", progress)
    if nodes is None:
        return None
    if nodes.key != body.keys.stress:
        progress(f"stress modes: {path} was made on another mesh or for other nodes "
                 "([scene.outputs] stress_groups, stress_times); forming them again")
        return None
    return nodes


def cached_reduced(body: BodyPlan, out: Path, manifest: dict[str, str] | None,
                   progress: Progress) -> ReducedModel | None:
    """``out/reduced.h5`` if it was made from this study's upstream tables, intact, else None
    (with a progress line saying why it is rebuilt)."""
    path = out / "reduced.h5"
    model = _read_intact(out, manifest, path.name, "reduced model", read_reduced,
                         ReducedModelError, "rebuilding it", progress)
    if model is None:
        return None
    if not model.checksummed:
        progress(f"reduced model: {path} has no content checksums (schema "
                 f"{model.schema_version}, an older gcms-fenicsx); rebuilding it")
        return None
    if not body.served_by(model.input_hash):
        other_law = body.svk and model.input_hash == body.digest(*REDUCED_MODEL_TABLES)
        why = ("was made without the SVK coefficients ([scene] elasticity changed)"
               if other_law else "was made from other inputs")
        progress(f"reduced model: {path} {why}; rebuilding it")
        return None
    return model
