"""The generalized-α step compiled by Numba: a stretch of steps in one call (docs/design.md §8.5,
docs/compiled-step.md). The modules: ``algebra`` (3 × 3 and field-array loops, the polar
decomposition, LU), ``laws`` (frames and elastic laws), ``newton`` (the bordered Newton system),
``forcing`` (drives' directions and external forces in time), ``step`` (the step and the
stretch) and ``unowned`` (the stretch's arrays read without reference counts). Nothing here is
imported unless the kernel runs (``stepping.kernel``): the package imports Numba.


This is the NumPy step of ``integrator.GeneralizedAlpha.step`` written out for Numba, on the
arrays of ``kernel_data.StepData``: the predictor, the elastic law's force (co-rotated on
GCMS or rotor coordinates: ``corotated.elastic_state``, ``rotor.rotor_state``; Saint
Venant–Kirchhoff: ``svk.SVKLaw.state``), damping (``damping.DampingForce``,
``rotor.RotorDamping``), joints and drives (``joints.Constraints.directions_at``), loads
(``loads.ExternalForces``), the bordered Newton solve and its rank-9 / rank-2 change of frame
(``kkt.BorderedKKT``, ``corotated.local_frame_update``, ``rotor.rotor_frame_update``), the
Jacobian policy (``jacobian.JacobianPolicy``), the update, and the recorder's work integrals
and raw rows (``recorder.Recorder.step``). Each function names the one it mirrors; the
formulas and their derivations are there. The NumPy step is the reference: the tests run both
on the same scenes (equal to round-off, equal Newton iterations).

What differs from the NumPy step is how, not what — the same formulas in an order that costs
less arithmetic, so the two agree to round-off:

- the co-rotated law makes one product with (Πᵀ ⊗ I3) Kr per iteration, of e + β ė (D₀ =
  α Mr + β Kr, so the elastic and damping forces are (Πᵀ ⊗ I3) Kr (e + β ė) + α (Πᵀ G ⊗ I3) ė);
  the energy and the dissipation, which need the two apart, take one product more per step,
  only when the run records energies;
- Π = I − k1 g1ᵀ/m is applied as the rank-one update it is, Mr = G ⊗ I3 through G, and
  Mr [q̇; q̈; a] is predicted as Z is and kept up to date by the corrections' Mr Δq (which the
  increment's norm needs anyway): Mr q̈ for the residual and, where the recorder's rows are
  the body's own coordinates, Mr q̇ for its momenta, with no product with G;
- the polar decomposition is Newton's iteration X ← ½ (X + X⁻ᵀ), not an SVD (R, U and
  S⁻¹ = (tr U · I − U)⁻¹ are what the step uses, and they do not depend on how they are found);
- the constraint rows are never formed: in the frame R, row i is Σ_l a_il c_i(e_l) with
  a_i = Rᵀ u_i(t), so the bordered solve applies the 3m units c_i(e_l) and their solves
  S₀⁻¹ c_i(e_l)ᵀ, and the capacitance matrix follows from their products, made once per run
  (and the change-of-frame rows' once per relinearisation), in O(m²) per step;
- the change-of-frame term's columns Wᵀ = Hₓ S⁻¹ᵀ and U₂ are constant up to S⁻¹, so S₀⁻¹ times
  them is made once per run, and a relinearisation solves three columns instead of nine;
  its products with Kr are made with (Πᵀ ⊗ I3) Kr, which gives the same B and Ĉᵀ A Ĉ;
- S₀⁻¹, (Πᵀ ⊗ I3) Kr (the rotor's K̃) and the SVK coefficients, symmetric matrices (made
  exactly so where they are formed), are applied through one triangle where they are large
  (``kernel_data.SYMMETRIC_FROM``; ``algebra.product``).

A step the kernel does not finish — it would be redone with the SVK tangent, or it fails (a
body inverted, Newton not converging, a state no longer finite) — is left as it was before
it, with status ``HANDED_OVER``, and the NumPy step takes it (``kernel``).
"""
