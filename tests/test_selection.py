"""GCMS fields and their selection on small beams: the Rayleigh–Ritz identity, the
reference's square-beam example, invariance under rotation, conditioning."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx.mesh import CellType, create_box

from symmetric_mesh import symmetric_box
from gcms_fenicsx.app import pipeline
from gcms_fenicsx.fe import algebra
from gcms_fenicsx.fe import basis
from gcms_fenicsx.files import modal_basis
from gcms_fenicsx.reduction import selection
from gcms_fenicsx.config.material import Material
from gcms_fenicsx.config.modes import ModesConfig
from gcms_fenicsx.config.selection import SelectionConfig, parse_selection
from gcms_fenicsx.config.table import ConfigError

STEEL = Material()


def _reduced_eigenvalues(model, B, kept) -> np.ndarray:
    """Generalised eigenvalues of (Kr, Mr) on the kept fields; a singular Mr (no pruning) is
    restricted to its range, dropping only directions below 1e-14 of its largest eigenvalue."""
    Kr = basis.reduced_stiffness(model, B.fields[:, kept])
    Mr = modal_basis.reduced_mass(B.gram_mass[np.ix_(kept, kept)])
    w, V = np.linalg.eigh(Mr)
    T = V[:, w > 1e-14 * w.max()] / np.sqrt(w[w > 1e-14 * w.max()])
    return np.linalg.eigvalsh(T.T @ Kr @ T)


@pytest.fixture(scope="module")
def square():
    """Square beam on a symmetric mesh: its first bending pair, in whatever basis SLEPc picks."""
    mesh = symmetric_box(MPI.COMM_WORLD, [0, -0.025, -0.025], [1, 0.025, 0.025], [20, 1, 1])
    model = pipeline.assembly_stage(mesh, STEEL, degree=2).model
    modes = pipeline.modes_stage(model, ModesConfig(count=2))
    return model, modes, basis.field_basis(model, modes)


def test_reduced_mass_is_the_kronecker_gram(square):
    model, _, B = square
    Phi = basis.phi_dense(B.fields)
    np.testing.assert_allclose(modal_basis.reduced_mass(B.gram_mass), Phi.T @ algebra.mat_dense(model.M, Phi),
                               rtol=1e-12, atol=1e-12 * B.gram_mass.max())
    Kr = basis.reduced_stiffness(model, B.fields)
    np.testing.assert_allclose(Kr, Phi.T @ algebra.mat_dense(model.K, Phi), rtol=1e-10,
                               atol=1e-10 * np.abs(Kr).max())


def _cyclic_tridiagonal(size: int) -> PETSc.Mat:
    """Rows of three entries, (r − 1, r, r + 1) mod size: lengths like K's, no node triples."""
    rows = np.arange(size)
    cols = np.sort(np.stack([(rows - 1) % size, rows, (rows + 1) % size], axis=1), axis=1)
    A = PETSc.Mat().createAIJ((size, size), csr=(np.arange(0, 3 * size + 1, 3, dtype=np.int32),
                                                 cols.ravel().astype(np.int32),
                                                 np.ones(3 * size)), comm=PETSc.COMM_SELF)
    A.assemble()
    return A


@pytest.mark.parametrize("stand_in", ["scalar mass", "tridiagonal"])
def test_reduced_stiffness_needs_a_blocked_stiffness(square, stand_in):
    """Kr reads K's 3×3 node blocks; a matrix in K's place without them is refused, not
    misread: Ms (a third of the rows) or rows of three entries that are not node triples."""
    from dataclasses import replace

    model, _, B = square
    K = model.Ms if stand_in == "scalar mass" else _cyclic_tridiagonal(model.ndofs)
    with pytest.raises(ValueError, match="3×3 node blocks"):
        basis.reduced_stiffness(replace(model, K=K), B.fields)


def test_column_order_is_the_references(square):
    _, _, B = square
    names = B.column_names()
    assert names[:3] == ["1>x", "1>y", "1>z"]           # Φt, eq. (1)
    assert names[3:6] == ["X>x", "X>y", "X>z"]          # Φr, eq. (2): k outer, l inner
    assert names[12:15] == ["phi1_x>x", "phi1_x>y", "phi1_x>z"]  # Φf, eq. (3)


def test_rayleigh_ritz_identity_without_pruning():
    """Every eigenmode lies in span(Φ), so the lowest 6 + Nm eigenvalues of (Kr, Mr) are the
    full model's (docs/design.md §4)."""
    mesh = create_box(MPI.COMM_WORLD, [[0, -0.02, -0.03], [0.6, 0.02, 0.03]], [12, 2, 2],
                      CellType.tetrahedron)
    model = pipeline.assembly_stage(mesh, STEEL, degree=2).model
    modes = pipeline.modes_stage(model, ModesConfig(count=6))
    B = basis.field_basis(model, modes)
    lam = _reduced_eigenvalues(model, B, np.arange(B.field_count))
    assert np.all(np.abs(lam[:6]) < 1e-8 * modes.eigenvalues[6])
    np.testing.assert_allclose(lam[6:12], modes.elastic_eigenvalues, rtol=1e-8)


def test_square_beam_first_bending_pair(square):
    """Reference: of the 18 flexible GCMS modes of the first bending pair, 9 are independent.

    Here the pair comes in a diagonal basis, so φ1_y, φ1_z, φ2_y, φ2_z are all ±w(x)/√2 plus
    Poisson contraction ν·y·z·w''(x): proportional to |cos| = 1 − 4e-5. A tolerance of 1e-4
    drops three of them and keeps 9 flexible columns, as the reference counts, but the
    Poisson fields it drops carry lateral strain: without them the beam locks (λ of the
    pair +15 % and +85 %).
    The default 1e-6 drops only the one dependency left at 4e-7 (15 columns, error 1e-6).
    """
    model, modes, B = square
    loose = selection.select_fields(B.gram_mass, SelectionConfig(1e-4, 1e-4), B.names)
    assert 3 * (len(loose.kept) - 4) == 9
    assert {d["field"] for d in loose.dropped} == {"phi1_z", "phi2_y", "phi2_z"}
    assert all(d["stage"] == "cosine" and abs(d["cosine"]) > 1 - 1e-4 for d in loose.dropped)
    locked = _reduced_eigenvalues(model, B, loose.kept)[6:8] / modes.elastic_eigenvalues
    assert np.all(locked > 1.1), locked

    default = selection.select_fields(B.gram_mass, SelectionConfig(), B.names)
    assert 3 * (len(default.kept) - 4) == 15
    lam = _reduced_eigenvalues(model, B, default.kept)
    np.testing.assert_allclose(lam[6:8], modes.elastic_eigenvalues, rtol=1e-4)
    cond = selection.conditioning(B.gram_mass, B.gram_euclid, kept=default.kept)
    assert cond["cond_mr_after"] < 1e8 < cond["cond_mr_before"]
    assert cond["cond_phi_after"] < cond["cond_phi_before"]
    scipy.linalg.cholesky(modal_basis.reduced_mass(B.gram_mass[np.ix_(default.kept, default.kept)]))


def _rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def test_selection_is_invariant_under_rotation_and_translation_of_the_mesh(square):
    model, modes, B = square
    ref = selection.select_fields(B.gram_mass, SelectionConfig(), B.names)
    mesh = symmetric_box(MPI.COMM_WORLD, [0, -0.025, -0.025], [1, 0.025, 0.025], [20, 1, 1])
    mesh.geometry.x[:] = mesh.geometry.x @ _rotation(3).T + np.array([0.3, -2.0, 5.0])
    moved = pipeline.assembly_stage(mesh, STEEL, degree=2).model
    moved_modes = pipeline.modes_stage(moved, ModesConfig(count=2))
    moved_B = basis.field_basis(moved, moved_modes)
    sel = selection.select_fields(moved_B.gram_mass, SelectionConfig(), moved_B.names)
    assert len(sel.kept) == len(ref.kept)
    np.testing.assert_allclose(sel.singular_values, ref.singular_values, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(_reduced_eigenvalues(moved, moved_B, sel.kept)[6:10],
                               _reduced_eigenvalues(model, B, ref.kept)[6:10], rtol=1e-6)


@pytest.mark.parametrize("table, key", [
    ({"cosine_tolerance": -1e-3}, "cosine_tolerance"),
    ({"svd_tolerance": 0.9}, "svd_tolerance"),
    ({"svd_tolerance": "tight"}, "svd_tolerance"),
    ({"cosine_tol": 1e-3}, "cosine_tol"),
])
def test_bad_selection_table_names_the_key(table, key):
    with pytest.raises(ConfigError, match=rf"\[selection\] {key} ="):
        parse_selection(table)


def test_selection_is_invariant_under_a_mixed_basis_of_the_repeated_pair(square):
    """An eigensolver may return any orthonormal basis of a repeated eigenvalue's space.

    Counts and singular values are invariant; which field of the dependent group is dropped
    is not, so the reduced eigenvalues agree with the full ones to the pruning error (1.4e-6
    in this basis, 2.4e-6 in the mixed one), not to round-off."""
    from dataclasses import replace

    model, modes, B = square
    ref = selection.select_fields(B.gram_mass, SelectionConfig(), B.names)
    c, s = np.cos(0.7), np.sin(0.7)
    pair = modes.vectors[:, 6:8] @ np.array([[c, -s], [s, c]])
    mixed = replace(modes, vectors=np.hstack([modes.vectors[:, :6], pair]))
    mixed_B = basis.field_basis(model, mixed)
    sel = selection.select_fields(mixed_B.gram_mass, SelectionConfig(), mixed_B.names)
    assert len(sel.kept) == len(ref.kept)
    np.testing.assert_allclose(sel.singular_values, ref.singular_values, rtol=1e-6, atol=1e-9)
    mixed_lam = _reduced_eigenvalues(model, mixed_B, sel.kept)[6:8]
    ref_lam = _reduced_eigenvalues(model, B, ref.kept)[6:8]
    for lam in (mixed_lam, ref_lam):
        np.testing.assert_allclose(lam, modes.elastic_eigenvalues, rtol=1e-5)


def test_condition_numbers_do_not_depend_on_units(square):
    """The same body in mm-t-s instead of SI multiplies 1 by 1, X, Y, Z by 1e3 and the
    M-normalised mode fields by 1/√(1e-3) (mass unit t), and the mass Gram matrix by 1e-3 ·
    1e9 (ρ dV): the reported condition numbers must not move, while those of the raw Gram
    matrices change by orders of magnitude (9e13 against 4e15 in a user's probe). A
    singular Gram matrix is reported as 1/ε, a finite number (strict JSON has no Infinity)."""
    _, _, B = square
    nf = B.field_count
    scale = np.ones(nf)
    scale[1:4] = 1e3
    scale[4:] = 1e3 ** 1.5  # φ ~ 1/√(mass): 1/√(1e-3 t) per √kg
    units = np.outer(scale, scale)
    si = selection.conditioning(B.gram_mass, B.gram_euclid)
    mm = selection.conditioning(B.gram_mass * units * 1e6, B.gram_euclid * units)
    for key, value in si.items():
        # the smallest eigenvalue of a Gram matrix of condition c is computed to about ε c
        gram_cond = value ** 2 if key.startswith("cond_phi") else value
        assert mm[key] == pytest.approx(value, rel=10 * np.finfo(float).eps * gram_cond), key
    raw = [selection.condition_number(g) for g in (B.gram_mass, B.gram_mass * units * 1e6)]
    assert max(raw) > 5 * min(raw)  # 2e12 against 2e13
    singular = np.ones((3, 3))
    assert selection.condition_number(singular) == selection.COND_SINGULAR < np.inf
