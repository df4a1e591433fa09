"""The compiled step's small dense algebra: 3 × 3 matrices and (k × 3) field arrays written out
as loops (a BLAS call costs more than their arithmetic), the polar decomposition by Newton's
iteration, and an LU factorisation for the bordered system's capacitance matrix. Numba."""
from __future__ import annotations

import math

import llvmlite.binding as llvm
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import get_cython_function_address, intrinsic

JIT = dict(cache=True, nogil=True, error_model="numpy")
#: The step's thin parts, which Numba inlines into their caller (in its IR, before typing): no
#: call boundary, where Numba counts the arrays it passes (data, work arrays and law state:
#: some hundred a call). 46 coordinates of the default scene 10.1–11.2 → 9.6–9.9 µs a step,
#: the five-mode pendulum 13.4–14.2 → 11.4–13.2 (2026-12-05, alternating). Inlining the step
#: itself into its stretch too took the compile from 45 s to 3.5 min.
INLINE = dict(JIT, inline="always")
#: SciPy's BLAS dsymv, by a symbol name the compiled code refers to (resolved when a cached
#: kernel is loaded, as Numba's own BLAS calls are: no address is baked into the cache).
SYMMETRIC_PRODUCT = "gcms_fenicsx_dsymv"


def _register_symmetric_product() -> None:
    """Make SYMMETRIC_PRODUCT SciPy's dsymv for the code Numba compiles or loads. Without SciPy
    the kernel does not run (``stepping.kernel.numba_missing``), so there is nothing to do."""
    try:
        address = get_cython_function_address("scipy.linalg.cython_blas", "dsymv")
    except ImportError:
        return
    llvm.add_symbol(SYMMETRIC_PRODUCT, address)


_register_symmetric_product()
#: The polar decomposition's Newton iteration X ← ½ (X + X⁻ᵀ) stops when a step changes X by
#: at most this many ulps of its largest entry (it converges quadratically: 3–4 steps at
#: strains of 1e-2), and scales X by |det X|^(−1/3) while a step still changes it by more than
#: ``POLAR_SCALED`` (Higham, SIAM J. Sci. Stat. Comput. 7(4), 1986).
POLAR_ULPS = 4.0
POLAR_SCALED = 1e-2
POLAR_STEPS = 100
#: rotation.polar's bound: a map whose singular values spread over more than this is
#: degenerate (here from ‖U‖_F ‖U⁻¹‖_F, which bounds the spread within a factor 3).
POLAR_SPREAD = 1e12
EPS = 2.220446049250313e-16


@njit(**JIT)
def skew(w):
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 2] = -w[2], w[1], -w[0]
    S[1, 0], S[2, 0], S[2, 1] = w[2], -w[1], w[0]
    return S


@njit(**JIT)
def axial(Y):
    """rotation.axial: w(Y)."""
    return np.array([Y[2, 1] - Y[1, 2], Y[0, 2] - Y[2, 0], Y[1, 0] - Y[0, 1]])


@njit(**JIT)
def xe(a, k, j):
    """(a × e_k)_j = ε_jik a_i: a scalar, so the loops over fields allocate nothing."""
    if j == k:
        return 0.0
    i = 3 - j - k
    return a[i] if i == (j + 1) % 3 else -a[i]


@njit(**JIT)
def mat3(A, B, transpose_a=False):
    """A B (or Aᵀ B) of 3 × 3 matrices."""
    return mat3_into(A, B, transpose_a, np.empty((3, 3)))


@njit(**JIT)
def mat3_into(A, B, transpose_a, out):
    """A B (or Aᵀ B) of 3 × 3 matrices, into ``out``."""
    for i in range(3):
        for j in range(3):
            x = 0.0
            for k in range(3):
                x += (A[k, i] if transpose_a else A[i, k]) * B[k, j]
            out[i, j] = x
    return out


@njit(**JIT)
def mv3(M, x):
    """M x (3 × 3, 3)."""
    return np.array([M[0, 0] * x[0] + M[0, 1] * x[1] + M[0, 2] * x[2],
                     M[1, 0] * x[0] + M[1, 1] * x[1] + M[1, 2] * x[2],
                     M[2, 0] * x[0] + M[2, 1] * x[1] + M[2, 2] * x[2]])


@njit(**JIT)
def tmul(X, Y):
    """Xᵀ Y for X, Y (k × 3): 3 × 3."""
    return tmul_into(X, Y, np.empty((3, 3)))


@njit(**JIT)
def tmul_into(X, Y, out):
    """Xᵀ Y for X, Y (k × 3), into ``out`` (3 × 3). The nine sums are kept in scalars, not in
    ``out`` (which may alias X or Y, so a sum kept there is stored and loaded at every field:
    150 fields: 0.30 against 0.62 µs)."""
    o00 = o01 = o02 = o10 = o11 = o12 = o20 = o21 = o22 = 0.0
    for f in range(X.shape[0]):
        x0, x1, x2 = X[f, 0], X[f, 1], X[f, 2]
        y0, y1, y2 = Y[f, 0], Y[f, 1], Y[f, 2]
        o00 += x0 * y0
        o01 += x0 * y1
        o02 += x0 * y2
        o10 += x1 * y0
        o11 += x1 * y1
        o12 += x1 * y2
        o20 += x2 * y0
        o21 += x2 * y1
        o22 += x2 * y2
    out[0, 0], out[0, 1], out[0, 2] = o00, o01, o02
    out[1, 0], out[1, 1], out[1, 2] = o10, o11, o12
    out[2, 0], out[2, 1], out[2, 2] = o20, o21, o22
    return out


@njit(**JIT)
def mul(X, M):
    """X M for X (k × 3), M (3 × 3): k × 3."""
    return mul_into(X, M, np.empty((X.shape[0], 3)))


@njit(**INLINE)
def entries(M):
    """The nine entries of a 3 × 3 matrix, row by row, as scalars: a loop over fields that
    reads M keeps them so (M may alias the arrays it writes, so LLVM would load M again at
    every field; :func:`tmul_into`)."""
    return (M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2], M[2, 0], M[2, 1], M[2, 2])


@njit(**JIT)
def mul_into(X, M, out):
    """X M for X (k × 3), M (3 × 3), into ``out`` (k × 3)."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = entries(M)
    for f in range(X.shape[0]):
        x0, x1, x2 = X[f, 0], X[f, 1], X[f, 2]
        out[f, 0] = x0 * m00 + x1 * m10 + x2 * m20
        out[f, 1] = x0 * m01 + x1 * m11 + x2 * m21
        out[f, 2] = x0 * m02 + x1 * m12 + x2 * m22
    return out


@intrinsic
def _symmetric_product(typingctx, A, x, out):
    """out = A x for a symmetric A (n × n) by BLAS dsymv("L", n, 1, A, n, x, 1, 0, out, 1),
    which reads one triangle of A: the lower one of BLAS's column-major view, A's upper
    triangle row by row. OpenBLAS's lower kernel is the faster of the two (two 450 × 450
    products alternating on one core: 15.3 against 16.6 µs; in the 450-coordinate pendulum's
    step, with G's products between them: 161–167 against 175 µs a step). The arrays
    C-contiguous, n taken from x, so A must be n × n, out of length n and not x
    (:func:`product` checks)."""
    if not all(isinstance(t, types.Array) and t.layout == "C" and t.dtype == types.float64
               for t in (A, x, out)):
        return None

    def codegen(context, builder, signature, args):
        bytes_ = ir.IntType(8).as_pointer()
        i32, f64 = ir.IntType(32), ir.DoubleType()
        a, xv, yv = (context.make_array(t)(context, builder, v)
                     for t, v in zip(signature.args, args))
        n = builder.trunc(cgutils.unpack_tuple(builder, xv.shape, 1)[0], i32)

        def slot(value):
            return builder.bitcast(cgutils.alloca_once_value(builder, value), bytes_)

        size, unit = slot(n), slot(ir.Constant(i32, 1))
        dsymv = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [bytes_] * 10), SYMMETRIC_PRODUCT)
        builder.call(dsymv, [slot(ir.Constant(ir.IntType(8), ord("L"))), size,
                             slot(ir.Constant(f64, 1.0)), builder.bitcast(a.data, bytes_), size,
                             builder.bitcast(xv.data, bytes_), unit, slot(ir.Constant(f64, 0.0)),
                             builder.bitcast(yv.data, bytes_), unit])
        return context.get_dummy_value()

    return types.void(A, x, out), codegen


@njit(**JIT)
def product(A, x, out, symmetric):
    """out = A x; a ``symmetric`` A (``kernel_data.StepData``'s ``s0_symmetric``,
    ``stiffness_symmetric``, ``svk_symmetric``) through one triangle
    (half the memory a general product streams: at 450 coordinates the two matrices of a
    Newton iteration then stay in a core's cache)."""
    if symmetric:
        n = x.shape[0]
        if A.shape[0] != n or A.shape[1] != n or out.shape[0] != n or n == 0:
            raise ValueError("product: A must be n × n and out of length n > 0")
        _symmetric_product(A, x, out)
    else:
        np.dot(A, x, out)
    return out


@njit(**JIT)
def axpy(a, x, y):
    """y += a x. The loop runs on an unsigned index: LLVM vectorises it, not a loop over Numba's
    ``range`` (four rows of 189 entries: 98 against 377 ns)."""
    n = np.uintp(y.shape[0])
    j = np.uintp(0)
    while j < n:
        y[j] += a * x[j]
        j += np.uintp(1)


@njit(**JIT)
def gram_product(G, X, symmetric=False):
    """G X for G (nf × nf) and X (nf × k, k small): one BLAS product (at k = 3 it takes 0.3 µs
    at nf = 33, 5.1 µs at 150, against 0.8 and 7.0 for three matrix-vector products); a
    ``symmetric`` G through one triangle, by k products (:func:`product`)."""
    if not symmetric:
        return np.dot(G, np.ascontiguousarray(X))
    nf, k = X.shape
    XT = np.ascontiguousarray(X.T)
    column = np.empty(nf)
    out = np.empty((nf, k))
    for j in range(k):
        product(G, XT[j], column, symmetric)
        for f in range(nf):
            out[f, j] = column[f]
    return out


@njit(**JIT)
def remove(X, a, b):
    """X − a (bᵀ X) for X (nf × k, fields by rows): Π X with a = k1, b = g1/m, Πᵀ X with
    a = g1/m, b = k1 (``Body.projections``: Π = I − k1 g1ᵀ / m, applied as the rank-one update
    it is)."""
    k = X.shape[1]
    c = np.zeros(k)
    for f in range(X.shape[0]):
        for j in range(k):
            c[j] += b[f] * X[f, j]
    out = np.empty_like(X)
    for f in range(X.shape[0]):
        for j in range(k):
            out[f, j] = X[f, j] - a[f] * c[j]
    return out


@njit(**JIT)
def _inv3(A, out):
    """A⁻¹ of a 3 × 3 matrix into ``out``, by cofactors; det A."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c10 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c20 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c10 + A[0, 2] * c20
    r = 1.0 / det
    out[0, 0], out[1, 0], out[2, 0] = c00 * r, c10 * r, c20 * r
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) * r
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) * r
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) * r
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) * r
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) * r
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) * r
    return det


@njit(**JIT)
def polar(A, work):
    """rotation.polar, by Newton's iteration instead of an SVD: (R, U, S⁻¹, ok) with A = R U
    and S = tr U · I − U (``rotation.rotation_rate``); not ok for an inverted, degenerate or
    non-finite A (the NumPy step then says which). All in ``work`` (5 × 3 × 3, not holding A):
    the iteration's three buffers, swapped in place, U and S⁻¹; R, U and S⁻¹ are views of it,
    good until its next use (no array is allocated)."""
    X, Xi, Y = work[0], work[1], work[2]
    X[:, :] = A
    for i in range(3):
        for j in range(3):
            if not math.isfinite(A[i, j]):
                return X, X, X, False
    det = _inv3(X, Xi)
    if not det > 0.0:
        return X, X, X, False
    for _ in range(POLAR_STEPS):
        scale = abs(det) ** (-1.0 / 3.0)
        change = 0.0
        for i in range(3):
            for j in range(3):
                change = max(change, abs(0.5 * (scale * X[i, j] + Xi[j, i] / scale) - X[i, j]))
        if change <= POLAR_SCALED:          # unscaled near the rotation: quadratic convergence
            scale = 1.0
        change = 0.0
        size = 0.0
        for i in range(3):
            for j in range(3):
                y = 0.5 * (scale * X[i, j] + Xi[j, i] / scale)
                change = max(change, abs(y - X[i, j]))
                size = max(size, abs(y))
                Y[i, j] = y
        X, Y = Y, X
        if scale == 1.0 and change <= POLAR_ULPS * EPS * size:
            break
        det = _inv3(X, Xi)
    U = mat3_into(X, A, True, work[3])
    for i in range(3):
        for j in range(i + 1, 3):
            U[i, j] = U[j, i] = 0.5 * (U[i, j] + U[j, i])
    det_u = _inv3(U, Xi)
    squares, inverse_squares = 0.0, 0.0
    for i in range(3):
        for j in range(3):
            squares += U[i, j] * U[i, j]
            inverse_squares += Xi[i, j] * Xi[i, j]
    spread = math.sqrt(squares * inverse_squares)
    trace = U[0, 0] + U[1, 1] + U[2, 2]
    for i in range(3):
        for j in range(3):
            Y[i, j] = (trace if i == j else 0.0) - U[i, j]
    S_inv = work[4]
    _inv3(Y, S_inv)
    return X, U, S_inv, det_u > 0.0 and spread < POLAR_SPREAD


@njit(**JIT)
def lu_factor(A, piv):
    """A = P L U in place (partial pivoting): the pivots, into ``piv`` (k,)."""
    k = A.shape[0]
    for c in range(k):
        p = c
        big = abs(A[c, c])
        for i in range(c + 1, k):
            if abs(A[i, c]) > big:
                big, p = abs(A[i, c]), i
        piv[c] = p
        if p != c:
            for j in range(k):
                A[c, j], A[p, j] = A[p, j], A[c, j]
        inv = 1.0 / A[c, c]
        for i in range(c + 1, k):
            f = A[i, c] * inv
            A[i, c] = f
            if f != 0.0:
                for j in range(c + 1, k):
                    A[i, j] -= f * A[c, j]
    return piv


@njit(**JIT)
def lu_solve(LU, piv, x):
    """x ← A⁻¹ x in place, A's factors from :func:`lu_factor`."""
    k = LU.shape[0]
    for c in range(k):                 # P b: the rows were swapped whole, L's columns too
        p = piv[c]
        if p != c:
            x[c], x[p] = x[p], x[c]
    for c in range(k):
        for i in range(c + 1, k):
            x[i] -= LU[i, c] * x[c]
    for i in range(k - 1, -1, -1):
        acc = x[i]
        for j in range(i + 1, k):
            acc -= LU[i, j] * x[j]
        x[i] = acc / LU[i, i]
    return x
