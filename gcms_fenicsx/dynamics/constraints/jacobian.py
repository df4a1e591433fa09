"""When the Newton matrix of a step is re-linearised: ``[scene.solver] jacobian`` and what the
run has learnt about the body (docs/design.md §6).

- "rotated" (default): T S₀ Tᵀ alone — linear convergence at a rate set by the neglected
  change-of-frame terms. Once a step has needed them (a slow step, below), every later step
  starts with the rank-9 term as well, kept in the body frame and re-linearised every
  ``LOCAL_REUSE_STEPS`` steps: near-Newton convergence at the cost of a rotation.
- "exact": T S₀ Tᵀ + X Y from the first iteration of every step.
- "assembled": the same exact matrix, assembled and factorised at every iteration (the
  baseline; ``kkt.AssembledKKT``).

In every mode, a correction that is not smaller than ``UPGRADE_RATE`` times the previous
one is recomputed with the matrix re-linearised at the current iterate (R, and the rank-9
term where the elastic model allows), and the rest of that step is full Newton: a step with
a large, fast change of frame converges quadratically instead of slowly or not at all. An
elastic law with an exact tangent of its own (``svk``) is handled by the integrator instead:
its slow steps are redone with that tangent (``TANGENT_RATE``).
"""
from __future__ import annotations

from typing import NamedTuple

#: A Newton correction that does not shrink by this factor switches the rest of the step to
#: full Newton (with the rank-9 term). A re-linearisation costs about three iterations, so
#: it pays only where the plain iteration is slow or diverges (under strong stiffness-
#: proportional damping the rate exceeds 1).
UPGRADE_RATE = 0.6
#: The rank-9 term, kept in the body frame, is re-linearised after this many steps: the
#: local state it depends on changes slowly compared with the step.
LOCAL_REUSE_STEPS = 10

#: A law with an exact tangent (``svk``) switches to it (``integrator``) when a correction
#: shrinks by less than this factor: a tangent costs about twelve of its residuals (2.5 ms
#: against 0.2 ms at 47 fields), so a slow but converging iteration is cheaper than it. The flexible pendulum
#: (Nm = 10 with attachment modes, 1000 steps): 1.7 s with this switch, 3.5 s with the
#: tangent in every step after the first that needed it.
TANGENT_RATE = 0.9


class Linearisation(NamedTuple):
    """How one step's Newton matrix is formed."""

    exact: bool            # with the rank-9 change-of-frame term
    relinearise: bool      # the kept rank-9 term recomputed at this step's state
    every_iteration: bool  # re-linearised at every iterate (full Newton)


#: Every linearisation, made once: a step picks one instead of building it.
_LINEARISATIONS = {(e, r, i): Linearisation(e, r, i)
                   for e in (False, True) for r in (False, True) for i in (False, True)}


class JacobianPolicy:
    """The run's policy: the mode and, for "rotated", whether steps now start with the kept
    rank-9 term and how many steps ago it was re-linearised. ``corotated``: the elastic model
    has that term (another model's Newton matrix is T S₀ Tᵀ alone)."""

    def __init__(self, mode: str, corotated: bool) -> None:
        self.mode, self.corotated = mode, corotated
        self.frame_terms = False
        self.kept_steps = 0

    def start_step(self) -> Linearisation:
        """The linearisation a new step starts with."""
        if self.mode == "assembled":
            return _LINEARISATIONS[True, True, True]
        relinearise = self.mode == "exact" or self.kept_steps >= LOCAL_REUSE_STEPS
        self.kept_steps = 0 if relinearise else self.kept_steps + 1
        return _LINEARISATIONS[self.mode != "rotated" or self.frame_terms, relinearise, False]

    def upgrade(self, current: Linearisation) -> Linearisation:
        """Full Newton for the rest of a slow step; a "rotated" run keeps the rank-9 term for
        the steps that follow."""
        self.frame_terms = self.frame_terms or self.corotated
        self.kept_steps = 0
        return _LINEARISATIONS[current.exact or self.corotated, True, True]
