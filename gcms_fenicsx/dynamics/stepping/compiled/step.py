"""The compiled generalized-α step (``integrator.GeneralizedAlpha.step``) and a stretch of them
with the recorder's accounts (``recorder.Recorder.step``). Numba. The package's docstring says
what differs from the NumPy step and when a step is handed over to it."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gcms_fenicsx.dynamics.stepping.compiled.algebra import INLINE, JIT, axpy
from gcms_fenicsx.dynamics.stepping.compiled.forcing import directions_at, external_force
from gcms_fenicsx.dynamics.stepping.compiled.laws import (corotated_energies, corotated_parts,
                                                          corotated_state,
                                                          elastic_frame, residual, rotor_state,
                                                          svk_state)
from gcms_fenicsx.dynamics.stepping.compiled.newton import (apply_A, field_frame_update,
                                                            frame_capacitance, prepare,
                                                            relinearise, rotor_frame_update,
                                                            solve)
from gcms_fenicsx.dynamics.stepping.compiled.unowned import unowned
from gcms_fenicsx.dynamics.stepping.kernel_data import COROTATED, ROTOR, SVK

#: Status of a stretch: it reached its last step, the recorder's block is full, or the next
#: step is handed over to the NumPy step.
DONE, BLOCK_FULL, HANDED_OVER = 0, 1, 2
#: The work arrays of a run's stretches, made once (:func:`work_arrays`): S₀⁻¹ r and the
#: correction (0), the solves' product (1), Δq (2), the residual (3), the units' products and
#: weights (4, 5), Mr q̈ − f_ext + Cᵀλ (6); empty arrays that type the laws' unused state
#: (7–10); the law's own work arrays (11); Mr Δq (12); Cᵀλ (13); f_ext and the loads' factors
#: (14, 15); the linearisation's R (a copy), then what types a step's a, pivots and kept rows
#: before they are made (16–19); the bordered system's right-hand side and solution (20); g
#: (21); Z, λ, Mr [q̇; q̈; a] and the policy at the step's start (22–25); Mr [q̇; q̈; a] (26);
#: the laws' 3 × 3 work matrices (SMALL: the polar decomposition's five, Qᵀ H, Q̇ᵀ H, a
#: stand-in for [ω]× (made anew with damping), Q_locᵀ P, and b as a row of the last); the
#: bordered system's a, capacitance matrix, G W, pivots (BORDERED, ``newton.prepare``) and the
#: rotor frame's rotation; the rotor law's frame, I (29), its plane's sums N and its phase (30,
#: 31); the linearisation's phase (32, a copy); the driven directions u(t) (33).
SMALL, BORDERED = 27, 28


@njit(**INLINE)
def _row_values(U, units_x, index, out):
    """C x = [u_i · (c_k(e) x)]_i, k = index[i], from the units' products ``units_x`` (3 nv,),
    into ``out``."""
    m = U.shape[0]
    for i in range(m):
        k = 3 * index[i]
        out[i] = U[i, 0] * units_x[k] + U[i, 1] * units_x[k + 1] + U[i, 2] * units_x[k + 2]
    return out


@njit(**INLINE)
def _add_rows_transposed(U, lam, units, index, w, product, y):
    """y += Cᵀ λ = Σ_i λ_i Σ_l u_il c_k(e_l), k = index[i] (``w``, ``product``: work)."""
    w[:] = 0.0
    for i in range(U.shape[0]):
        k = 3 * index[i]
        for l in range(3):
            w[k + l] += lam[i] * U[i, l]
    np.dot(w, units, product)
    for j in range(y.shape[0]):
        y[j] += product[j]


@njit(**INLINE)
def _mass_product(rotor, x, mass, gram, out):
    """Mr x: G ⊗ I3 on GCMS coordinates, Mp on rotor coordinates (into ``out``)."""
    if rotor:
        np.dot(mass, x, out)
    else:
        nf = gram.shape[0]
        np.dot(gram, x.reshape(nf, 3), out.reshape(nf, 3))
    return out


@njit(**JIT)
def _scratch(n, rows, m, loads, k):
    """The stretch's work arrays (module constants)."""
    return (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(rows), np.empty(rows),
            np.empty(n), np.empty((0, 3)), np.empty((0, 0)), np.empty(0), np.array([1.0, 0.0]),
            (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
             np.empty(n), np.empty(n), np.empty(n)), np.empty(n), np.empty(n), np.empty(n),
            np.empty(loads), np.eye(3), np.empty((m, 3)), np.empty(0, dtype=np.int64),
            np.empty((0, n)), np.empty(k), np.empty(m), np.empty((4, n)), np.empty(m),
            np.empty((3, n)), np.empty(3, dtype=np.int64), np.empty((3, n)),
            np.empty((10, 3, 3)),
            (np.empty((m, 3)), np.empty(k * k), np.empty(m * rows), np.empty(k, dtype=np.int64),
             np.empty((3, 3))),
            np.eye(3), np.empty(4), np.empty(2), np.empty(2), np.empty((m, 3)))


@njit(**INLINE)
def _law_state(d, q, v, scratch):
    """The running law at (q, q̇): (ok, R, phase, Tᵀ(∂V/∂q + f_d), V, ėᵀ D₀ ė, then what its
    change of frame needs: co-rotated (U, S⁻¹, Q_loc, e, ė, z), rotor (f, c, s, β, ρ)); the
    other laws' entries empty. The co-rotated V and ėᵀ D₀ ė are 0 here (``corotated_energies``)."""
    none3, none2, none1, still = scratch[7], scratch[8], scratch[9], scratch[10]
    if d.law == COROTATED:
        ok, R, Us, S_inv, gradient, local, e, rate, z = corotated_state(
            q, v, d.affine, d.unit, d.unit_dual, d.q0_projected, d.projected,
            d.mass_projected, d.damping, d.damping_alpha, d.damping_beta, scratch[11],
            scratch[SMALL], d.stiffness_symmetric)
        return (ok, R, still, gradient, 0.0, 0.0, Us, S_inv, local, e, rate, z,
                none1, none1, none1, 0.0, 1.0)
    if d.law == ROTOR:
        ok, phase, gradient, energy, dissipation, f, c, slope, beta, rho = rotor_state(
            q, v, d.plane_map, d.q0, d.stiffness, d.translation, d.weights, d.pairs, d.damping,
            d.rotor_damping, scratch[11], d.stiffness_symmetric, scratch[30], scratch[31])
        return (ok, scratch[29], phase, gradient, energy, dissipation, none2, none2, none3,
                none3, none3, none1, f, c, slope, beta, rho)
    ok, R, gradient, energy = svk_state(q, d.affine, d.unit, d.unit_dual, d.svk_reference,
                                        d.svk_quadratic, d.svk_rows, d.svk_cols, d.svk_scale,
                                        scratch[SMALL], d.svk_symmetric)
    return (ok, R, still, gradient, energy, 0.0, none2, none2, none3, none3, none3, none1,
            none1, none1, none1, 0.0, 1.0)


@njit(**JIT)
def _relinearised(d, state):
    """BorderedKKT._relinearise at a law state of :func:`_law_state`: the change-of-frame rows
    of the exact Newton matrix (``newton.relinearise``)."""
    _, _, _, _, _, _, Us, S_inv, local, e, rate, z, f, c, slope, beta, rho = state
    if d.law == ROTOR:
        Ac = apply_A(c.reshape(d.n, 1), d.stiffness, d.mass, d.gram, True, d.gamma_p,
                     d.damping_alpha, d.damping_beta, d.stiffness_symmetric).ravel()
        X, Y = rotor_frame_update(f, c, slope, beta, rho, d.turn, d.weights, Ac)
    else:
        P = corotated_parts(e, rate, z, d.projected, d.mass_projected, d.damping,
                            d.damping_alpha, d.damping_beta)[2]
        b, gradient = elastic_frame(local, P, d.affine, S_inv)
        X, Y = field_frame_update(Us, S_inv, local, P, b, gradient, d.affine, d.unit,
                                  d.unit_dual, d.projected, d.gram, d.gamma_p,
                                  d.damping_alpha, d.damping_beta, d.stiffness_symmetric)
    relinearise(d, X, Y, S_inv)


@njit(**INLINE)
def _inertia_and_rows(U, lam, q, mass_acc, f_ext, units, index, targets, y, w, products,
                      transposed, g_out):
    """(y, g): y = Mr q̈ − f_ext + Cᵀ λ (into ``y``) and g = C q − d, through the units (``w``,
    ``products``, ``transposed``: work arrays)."""
    for j in range(y.shape[0]):
        y[j] = mass_acc[j] - f_ext[j]
    m = U.shape[0]
    if not m:
        return y, g_out
    u = units.shape[0]
    _add_rows_transposed(U, lam, units, index, w[:u], transposed, y)
    units_q = products[:u]
    np.dot(units, q, units_q)
    g = _row_values(U, units_q, index, g_out)
    for i in range(m):
        g[i] -= targets[i]
    return y, g


@njit(**INLINE)
def _linearised(d, state, exact, relinearise, policy, U, kept_rows, work):
    """BorderedKKT.prepare at the law state ``state``: the rank-9 (rank-2) rows relinearised
    where asked (or never made; the rows they replace kept in ``kept_rows`` for a hand-over),
    then the bordered system's factors (in ``work``: ``newton.prepare``). (bordered, a, LU,
    pivots, kept_rows)."""
    m = d.m
    if exact and (relinearise or policy[2] == 0):
        if kept_rows.shape[0] == 0:
            kept_rows = np.concatenate((d.border_exact[m:], d.rows_exact[m:]))
        _relinearised(d, state)
        policy[2] = 1
    bordered = m > 0 or exact
    if not bordered:        # (no rows: empty views of the work arrays, nothing allocated)
        return bordered, work[0], work[1][:0].reshape(0, 0), work[3][:0], kept_rows
    R, phase, P = state[1], state[2], d.projectors
    world = R
    if d.law == ROTOR:          # P₀ + cos ψ P₁ + sin ψ P₂, written out: inlined into the step,
        world = work[4]         # the array expression would allocate each of its terms
        for i in range(3):
            for j in range(3):
                world[i, j] = P[0, i, j] + phase[0] * P[1, i, j] + phase[1] * P[2, i, j]
    a, lu, piv = prepare(exact, U, world, d.pad_exact if exact else d.pad_plain,
                         d.unit_capacitance, d.vector_index, d.rank, work)
    return bordered, a, lu, piv, kept_rows


@njit(**INLINE)
def _predicted(P, Z, Z0):
    """Z ← P Z0 (``alpha.step_matrices``) for the state Z = [q; q̇; q̈; a], or for its last
    three rows (Mr [q̇; q̈; a]: P's first column is zero below its first row), row by row on
    an unsigned index (vectorised, as ``algebra.axpy``)."""
    first = 4 - Z.shape[0]
    b, c, e = Z0[1 - first], Z0[2 - first], Z0[3 - first]
    a = Z0[0] if first == 0 else b
    n = np.uintp(Z.shape[1])
    for i in range(first, 4):
        p0, p1, p2, p3 = (P[i, 0] if first == 0 else 0.0), P[i, 1], P[i, 2], P[i, 3]
        z = Z[i - first]
        j = np.uintp(0)
        while j < n:
            z[j] = p0 * a[j] + p1 * b[j] + p2 * c[j] + p3 * e[j]
            j += np.uintp(1)


@njit(**JIT)
def _step(d, Z, lam, t1, policy, energies, mass_rates, momenta, scratch):
    """One step from Z (4 × n), λ to t1, in place (integrator.GeneralizedAlpha.step). Returns
    (converged, iterations, V, ėᵀ D₀ ė, f_ext, u(t1)), V and ėᵀ D₀ ė only if ``energies``;
    ``mass_rates`` is Mr [q̇; q̈; a] of Z, kept so (Mr q̈ alone unless ``momenta``). Not
    converged: Z, λ, Mr [q̇; q̈; a], the policy ([frame_terms, kept_steps, kept]) and the kept
    rank-9 rows as they were, for the NumPy step to take the step."""
    rotor = d.law == ROTOR
    start = _saved(Z, lam, mass_rates, policy,
                   (scratch[22], scratch[23], scratch[24], scratch[25]))
    kept_rows = scratch[19]
    _predicted(d.predictor, Z, start[0])
    if momenta:                  # else only Mr q̈ is kept, which the predictor leaves as it is
        _predicted(d.predictor, mass_rates, start[2])
    U = directions_at(t1, d.directions, d.drive_rows, d.drive_vectors, d.drive_params,
                      scratch[33])
    units = d.rows_all[:d.rows_all.shape[0] - d.rank]
    f_ext = external_force(t1, d.gravity, d.load_vectors, d.load_params, scratch[15],
                            scratch[14])
    corotated = d.law != SVK
    relin = d.exact_mode or policy[1] >= d.reuse_steps       # JacobianPolicy.start_step
    policy[1] = 0 if relin else policy[1] + 1
    exact = d.exact_mode or policy[0] == 1
    every = bordered = converged = False
    previous = delta = math.inf
    R_lin, phase_lin = scratch[16], scratch[32]
    a, lu, piv = scratch[17], scratch[8], scratch[18]
    # solve's work arrays alone: each array of a tuple passed costs a count call (``unowned``)
    solve_work = (scratch[0], scratch[1], scratch[2], scratch[4], scratch[5], scratch[9],
                  scratch[20])
    state = _law_state(d, Z[0], Z[1], scratch)
    iteration = 0
    while iteration < d.max_iterations:
        iteration += 1
        if iteration > 1:
            state = _law_state(d, Z[0], Z[1], scratch)
        ok, R, phase, gradient = state[0], state[1], state[2], state[3]
        if not ok:
            break
        y, g = _inertia_and_rows(U, lam, Z[0], mass_rates[1], f_ext, units, d.vector_index,
                                 d.targets, scratch[6], scratch[5], scratch[4], scratch[13],
                                 scratch[21])
        prepared = iteration == 1 or every
        upgrade = False
        while True:           # once, and again when a slow iteration upgrades the matrix
            if prepared:        # R and the phase are views of the law's work arrays: copied
                R_lin[:, :] = R
                phase_lin[:] = phase
                bordered, a, lu, piv, kept_rows = _linearised(d, state, exact,
                                                              relin or every, policy, U,
                                                              kept_rows, scratch[BORDERED])
            r = residual(rotor, d.pairs, y, gradient, R, phase, prepared, R_lin, phase_lin,
                         scratch[3])
            dq, dlam = solve(bordered, a, lu, piv, r, g, R_lin, phase_lin, rotor, d.pairs,
                             d.s0_inverse, d.s0_symmetric, d.rows_all, d.solves_all,
                             d.vector_index, d.rank, solve_work)
            mass_dq = _mass_product(rotor, dq, d.mass, d.gram, scratch[12])
            delta = math.sqrt(abs(dq @ mass_dq) / d.total_mass)
            if upgrade or every or not delta > d.upgrade_rate * previous or not corotated:
                break
            policy[0], policy[1] = 1, 0                  # JacobianPolicy.upgrade
            every = exact = prepared = upgrade = True
        if (not corotated and not every and delta > d.upgrade_rate * previous
                and delta > d.tangent_rate * previous) or not delta < math.inf:
            break                          # redone with the SVK tangent, or failed
        _update(d.update, dq, mass_dq, Z, mass_rates, momenta)
        lam += dlam
        tol = d.tolerance
        if delta <= tol or (delta * delta <= tol * (previous - delta)
                            and tol * (previous - delta) < math.inf):
            converged = True
            break
        previous = delta
    energy, dissipation = state[4], state[5]
    if converged and energies and d.law == COROTATED:
        energy, dissipation = corotated_energies(state[9], state[10], state[11], d.projected,
                                                 d.mass_projected, d.damping, d.damping_alpha,
                                                 d.damping_beta, scratch[13], d.stiffness_symmetric)
    if not converged:
        _restore(d, Z, lam, mass_rates, policy, start, kept_rows)
    return converged, iteration, energy, dissipation, f_ext, U


@njit(**INLINE)
def _update(u, dq, mass_dq, Z, mass_rates, momenta):
    """Z += u Δq and Mr [q̇; q̈; a] += u₁…₃ Mr Δq (Mr q̈ alone unless ``momenta``), row by
    row."""
    for i in range(4):
        axpy(u[i], dq, Z[i])
    for i in range(1, 4):
        if momenta or i == 2:
            axpy(u[i], mass_dq, mass_rates[i - 1])


@njit(**INLINE)
def _saved(Z, lam, mass_rates, policy, start):
    """Z, λ, Mr [q̇; q̈; a] and the policy at a step's start, copied into ``start`` (the
    stretch's work arrays 22–25)."""
    start[0][:, :] = Z
    start[1][:] = lam
    start[2][:, :] = mass_rates
    start[3][:] = policy
    return start


@njit(**JIT)
def _restore(d, Z, lam, mass_rates, policy, start, kept_rows):
    """A step handed over: everything it changed as it was before it."""
    Z[:, :] = start[0]
    lam[:] = start[1]
    mass_rates[:, :] = start[2]
    policy[:] = start[3]
    if kept_rows.shape[0]:
        k = d.rank
        d.border_exact[d.m:] = kept_rows[:k]
        d.rows_exact[d.m:] = kept_rows[k:]
        frame_capacitance(d)


@njit(**JIT)
def work_arrays(d):
    """The work arrays of a run's stretches, made once by their caller (``kernel``)."""
    return _scratch(d.n, d.rows_all.shape[0], d.m, d.load_params.shape[0],
                    d.pad_exact.shape[0])


@njit(**JIT)
def run_stretch(d, rec, Z, lam, t, index, stop, h, policy, last, scratch):
    """Steps index + 1 … stop from (t, Z, λ) at step ``index``, accounting for and recording
    each (recorder.Recorder.step / record) into ``rec``, ``scratch`` the run's
    :func:`work_arrays`. Returns (status, steps taken, the time reached); ``last`` (3,) gets
    the last step's Newton iterations and elastic energy, and adds the stretch's iterations to
    its third entry. Every array argument is the caller's for the whole call: the stretch
    reads them :func:`unowned.unowned`."""
    return _stretch(unowned(d), unowned(rec), unowned(Z), unowned(lam), t, index, stop, h,
                    unowned(policy), unowned(last), unowned(scratch))


@njit(**JIT)
def _stretch(d, rec, Z, lam, t, index, stop, h, policy, last, scratch):
    """:func:`run_stretch` on arrays without owners."""
    counters = rec.counters
    taken = 0
    if policy[2] and d.rank:
        frame_capacitance(d)        # the kept rows may have been set by the NumPy step
    # Mr [q̇; q̈; a], predicted and corrected as Z is (by every correction's Mr Δq): Mr q̈ for
    # the residual, and where the recorder's rows have room for it (the body's own
    # coordinates, not a rotor basis's) Mr q̇ for its momenta, so they need no product with G
    mass_rates, momenta = scratch[26], rec.qv.shape[1] == 3
    for i in range(3):
        if momenta or i == 1:
            _mass_product(d.law == ROTOR, Z[i + 1], d.mass, d.gram, mass_rates[i])
    while index < stop:
        t1 = t + h
        converged, iterations, energy, dissipation, f_ext, U = _step(d, Z, lam, t1, policy,
                                                                     rec.energy, mass_rates,
                                                                     momenta, scratch)
        if not converged:
            return HANDED_OVER, taken, t
        t, index = t1, index + 1
        taken += 1
        last[0], last[1] = iterations, energy
        last[2] += iterations
        v = Z[1]
        if rec.energy:
            load = 0.0                       # (f_ext − f_g) · q̇ and −λ · C q̇
            if rec.loads:
                for j in range(v.shape[0]):
                    load += (f_ext[j] - d.gravity[j]) * v[j]
            constraint = 0.0
            if d.m:
                units = d.rows_all[:d.rows_all.shape[0] - d.rank]
                units_v = np.dot(units, v, scratch[4][:units.shape[0]])
                constraint = -(lam @ _row_values(U, units_v, d.vector_index, scratch[21]))
            if counters[1]:
                hh = rec.half_step
                rec.work[0] += hh * (rec.power[0] + load)
                rec.work[1] += hh * (rec.power[1] + constraint)
                rec.work[2] += hh * (rec.power[2] + dissipation)
            rec.power[0], rec.power[1], rec.power[2] = load, constraint, dissipation
            counters[1] = 1
        if index == rec.last_step or index % rec.every == 0:
            k = counters[0]
            rec.qv[k, 0] = Z[0]
            rec.qv[k, 1] = Z[1]
            if momenta:
                rec.qv[k, 2] = mass_rates[0]
            if rec.multipliers.shape[1]:
                rec.multipliers[k] = lam
            row = rec.scalars[k]
            row[0], row[1] = t, iterations
            row[2] = energy if rec.energy else 0.0
            row[3], row[4], row[5] = rec.work[0], rec.work[1], rec.work[2]
            counters[0] = k + 1
            if k + 1 == rec.qv.shape[0]:
                return BLOCK_FULL, taken, t
    return DONE, taken, t
