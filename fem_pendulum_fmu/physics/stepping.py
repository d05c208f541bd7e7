"""Adaptive internal time stepping shared by every fidelity.

The rule, in words (it is what `solver.max_step` and `solver.tolerance` mean):

* free flight: steps of `max_step`;
* approaching the wall: the step is cut so that it ends where the gap closes
  (aimed with the current gap rate), and a step that still ends deeper than
  `dmax / n` is rejected and re-aimed by regula falsi, so contact onset is
  located, never stepped over;
* in contact: `n` steps per estimated contact duration T, as many as the
  contact's timing error needs (`StepControl.contact_steps`). The midpoint
  rule lengthens a contact by (pi/n)^2 / 12 of T, which delays the rebound
  by T (pi/n)^2 / 12; that delay is held to `tol` times `max_step`, the
  free-flight step, so n = ceil(pi sqrt(T / (12 tol max_step))). Never fewer
  than `MIN_STEPS_PER_CONTACT` (16), so the force pulse stays sampled within
  half a percent of its peak (1 - cos(pi / 32)) and the elastic modes it
  drives see its shape; never more than `ceil(pi / sqrt(12 tol))` (29 at
  tol = 1e-3), the rule that holds the relative error of T itself to `tol`,
  which a contact as long as a free-flight step needs anyway. At the default
  tolerance and step a steel contact (T about 0.34 ms) takes 16 steps. A
  model whose contact needs more keeps the phase rule throughout
  (`StepControl.timing_rule` False: the reduced model on soft bodies, the FE
  model against the meshed wall; their reasons are where they choose it);
* with `StepControl.even_contact_steps` (the FE model, whose factorised
  Jacobian serves one step size: fem/newton.py), the steps in contact
  divide the time left in the advance equally, and a step keeps the last
  one's size while that is no longer than the contact's step and at least
  `STEP_KEPT` of it. The contact's step, re-estimated at every step from
  the vibrating body's closest point, can jump by 20 to 50 % from one step
  to the next on the rubber scene; taken as it comes, nearly every step of
  a soft contact would refactorise the Jacobian;
* a held contact takes free-flight steps again, with no onset location: one
  whose hold exceeds `HELD_CONTACTS` estimated contact durations and whose
  force is no more than `HELD_FORCE` times what the torque and gravity can
  press with, (|T| + m g d |sin theta|) / D at the head centre's depth D.
  The hold grows by the time in contact and shrinks by `HOLD_DECAY` of the
  time out of it (never below 0), a step that enters or leaves contact split
  where its end gaps, interpolated linearly, cross zero. A stiff impact is
  over within one duration and then flies off; a soft body's long
  impact carries forces far above the load; both stay resolved. A head that
  stays, or lifts off only briefly (an elastic head's rod vibrating under
  the load), is kept there by the load, and the undamped normal vibration
  about the loaded equilibrium is not resolved. The discrete gradient keeps the
  energy balance exact whatever the step, and over time the contact impulse
  equals the load's (momentum balance), so the mean contact force, impulse
  over time, stays the load's reaction; what is given up is the phase of that
  vibration, so the sampled `contact_force` is a sample of an aliased
  vibration (docs/notes/robustness.md, case 4). The hold is the outputs'
  `contact_hold`, which every model's state carries, so a restored state
  steps as the original did;
* a step whose nonlinear solve fails is rejected and halved; below
  `min_step` the advance fails with StepFailed and the caller keeps the state
  it had;
* the last step lands exactly on the requested time; a remainder shorter than
  `min_step` is merged into the step before it, so round-off never leaves a
  vanishing step;
* `max_substeps` (solver.max_substeps, 0 = no limit) caps the accepted steps
  of one advance: an advance that would need more fails with StepFailed
  (state kept), so a master learns of a stall at once and can retry with a
  shorter communication step.

A torque that follows a polynomial over the advance (physics/torque.py) reaches
each step, trial steps of the onset location included, as its exact mean over
that step; the held-contact test uses its largest |T| over the advance. A
constant torque is passed on as it is.

Models supply the single energy-consistent step and the contact scales; the
step control decides the step sizes. It also tallies the contact over the
accepted steps of an advance: the largest contact force at their ends and the
impulse, the sum of the scheme's own contact force times the step, so that an
impact shorter than a communication step is still seen.

The compiled core runs these rules for every fidelity (core/stepping.c, over a
model in C or, through physics/compiled_advance.py, in Python); this module
holds their settings and constants (`StepControl`, which the core is handed
with the constants below) and an advance's result (`AdvanceResult`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Generic, Protocol, TypeVar

import numpy as np

from .protocol import Outputs, StepFailed

if TYPE_CHECKING:
    from .scene import Scene

X = TypeVar("X")


class Steppable(Protocol[X]):
    def step(self, x: X, dt: float, torque: float) -> X | None:
        """One energy-consistent step of size dt; None if the nonlinear solve failed."""

    def gap_and_rate(self, x: X) -> tuple[float, float]:
        """Minimum signed gap (m, negative = penetration) and its time derivative (m/s)."""

    def contact_scales(self, x: X) -> tuple[float, float]:
        """(estimated contact duration in s, estimated largest penetration in m) for
        the current approach or contact; (inf, 0) when no contact is in view."""

    def contact_force(self, x: X) -> float:
        """Magnitude of the resultant contact force on the pendulum at x (N)."""

    def contact_impulse(self, x0: X, x1: X, dt: float) -> np.ndarray:
        """The contact impulse (N.s, a 2-vector: force on the pendulum) of the step x0 -> x1 of size dt,
        as the scheme applies it: the contact force of its momentum update times dt."""


MIN_STEPS_PER_CONTACT = 16  # the fewest steps per contact duration (the module's docstring says why)
HELD_CONTACTS = 3.0  # a contact held this many estimated contact durations is held, not an impact
HELD_FORCE = 10.0  # ... if its force is below this many times the load's (the resting heads vibrate to 6.6 times)
STEP_KEPT = 0.8  # even contact steps: a size is kept while no longer than the contact's step and this share of it
HOLD_DECAY = 0.2  # out of contact the hold shrinks at this share of the time: an impact's hold is gone after a flight
# of five contact durations; a head that chatters on the wall (in contact a sixth of the time or more) keeps it


@dataclass(frozen=True)
class StepControl:
    max_step: float = 2e-3
    tolerance: float = 1e-3
    min_step: float = 1e-9
    max_onset_iterations: int = 8
    max_substeps: int = 0  # accepted steps allowed per advance; 0 = no limit
    timing_rule: bool = True  # steps per contact from the rebound's delay; False: the phase rule's throughout
    even_contact_steps: bool = False  # in contact, equal steps kept from step to step (the module's docstring)

    @classmethod
    def for_scene(cls, scene: Scene, timing_rule: bool = True, even_contact_steps: bool = False) -> StepControl:
        """The step control a scene's solver.* parameters describe (every fidelity uses this)."""
        solver = scene.solver
        return cls(
            solver.max_step,
            solver.tolerance,
            max_substeps=solver.max_substeps,
            timing_rule=timing_rule,
            even_contact_steps=even_contact_steps,
        )

    @property
    def steps_per_contact(self) -> int:
        """The most steps a contact takes: the phase rule's, which bounds (pi/n)^2 / 12 by the tolerance."""
        return max(8, math.ceil(math.pi / math.sqrt(12.0 * self.tolerance)))

    def contact_steps(self, t_contact: float) -> int:
        """Steps for a contact of estimated duration t_contact: its rebound delayed by no more than
        tolerance * max_step (see the module's docstring), within MIN_STEPS_PER_CONTACT and the phase rule's."""
        most = self.steps_per_contact
        if not self.timing_rule or not t_contact < math.inf:
            return most  # no contact in view: the count divides an infinite duration and a zero depth
        needed = math.ceil(math.pi * math.sqrt(t_contact / (12.0 * self.tolerance * self.max_step)))
        return min(most, max(MIN_STEPS_PER_CONTACT, needed))


@dataclass
class ContactTally:
    """Contact over the accepted steps of one advance: the largest force at their ends, the impulse,
    and the contact's hold (from before the advance on; see the module's docstring)."""

    force_max: float = 0.0
    impulse_x: float = 0.0
    impulse_y: float = 0.0
    hold: float = 0.0
    force_now: float = 0.0  # the contact force at the last step's end (at the advance's start: the outputs')

    def add(self, model: Steppable[X], x0: X, x1: X, dt: float, gap0: float) -> None:
        """Count an accepted step from x0 (gap gap0) to x1. A step with no point in contact at either
        end has no contact force, so it adds nothing (and costs one gap, which the stepper reuses)."""
        gap1 = model.gap_and_rate(x1)[0]
        self.hold = _hold_after(self.hold, gap0, gap1, dt)
        self.force_now = 0.0
        if gap0 >= 0.0 and gap1 >= 0.0:
            return
        jx, jy = model.contact_impulse(x0, x1, dt)
        self.impulse_x += float(jx)
        self.impulse_y += float(jy)
        if gap1 < 0.0:
            self.force_now = model.contact_force(x1)
            self.force_max = max(self.force_max, self.force_now)

    @property
    def impulse(self) -> np.ndarray:
        return np.array([self.impulse_x, self.impulse_y])


@dataclass
class AdvanceResult(Generic[X]):
    state: X
    substeps: int
    rejected: int
    min_gap: float  # smallest gap seen at the internal steps of this advance (contacts between communication points)
    contact: ContactTally = field(default_factory=ContactTally)
    stopped_at: float | None = None  # where `stop` ended the advance before its end

    def end_time(self, t_end: float) -> float:
        return t_end if self.stopped_at is None else self.stopped_at

    def finish(self, outputs: Outputs) -> float:
        """`finish_advance` with this advance's smallest gap and contact tally."""
        c = self.contact
        return finish_advance(outputs, self.min_gap, c.force_max, math.hypot(c.impulse_x, c.impulse_y), c.hold)


def smallest_step_failed(min_step: float, t: float) -> StepFailed:
    """The failure of an advance whose step failed at every size down to min_step, at t."""
    return StepFailed(f"the nonlinear solve failed down to the smallest step {min_step:g} s at t = {t:.9g} s")


def check_substeps(control: StepControl, substeps: int, t: float, t_end: float) -> None:
    """StepFailed once an advance has taken solver.max_substeps accepted steps short of its end."""
    if control.max_substeps and substeps >= control.max_substeps and t < t_end:
        raise StepFailed(
            f"the advance to t = {t_end:.9g} s needs more than solver.max_substeps = "
            f"{control.max_substeps} internal steps (stopped at t = {t:.9g} s); "
            "retry with a shorter communication step",
            shorter_step_helps=True,
        )


def finish_advance(outputs: Outputs, min_gap: float, force_max: float, impulse: float, hold: float) -> float:
    """The end of every fidelity's advance, the shared stepper's (AdvanceResult.finish) and the rigid
    model's free-flight step alike: the outputs at its end get the advance's smallest gap (`min_gap`
    from its internal steps, or the end's gap if smaller), its largest contact force, the magnitude
    of its contact impulse and the contact's hold; returns that smallest gap."""
    gap = outputs.gap
    outputs.gap_min = min_gap = min_gap if min_gap < gap else gap
    outputs.contact_force_max = force_max
    outputs.contact_impulse = impulse
    outputs.contact_hold = hold
    return min_gap


def _hold_after(hold: float, gap0: float, gap1: float, dt: float) -> float:
    """The hold after a step from gap0 to gap1 (the seed schemes' step control; the core's is stepping.c's):
    plus its time in contact, minus HOLD_DECAY of its time outside, the crossing of a step that enters or
    leaves contact placed by the gaps (linearly)."""
    if gap0 < 0.0 and gap1 < 0.0:
        return hold + dt
    if gap0 >= 0.0 and gap1 >= 0.0:  # out of contact throughout: shrunk by HOLD_DECAY of dt, never below 0
        decayed = hold - HOLD_DECAY * dt
        return decayed if decayed > 0.0 else 0.0
    inside = dt * (gap1 / (gap1 - gap0) if gap1 < 0.0 else gap0 / (gap0 - gap1))
    return max(hold + inside - HOLD_DECAY * (dt - inside), 0.0)
