"""The seed tutorial's step-size rules, kept so that benchmarks can run its schemes on our model.

`solver.scheme` selects them (fem fidelity only):

* newmark_fixed: every step is `max_step` (the last one of an advance lands on t_end);
* newmark_gap_rule: the seed's rule from the gap at the step's start: 1e-4 s
  under 1 mm, 5e-4 s under 5 mm, 1e-3 s under 1 cm, else `max_step`.

Nothing locates contact onset and nothing relates the step to the contact's
duration: that is what the comparison is about. The trapezoidal rule balances
the forces at the step's end, so a torque that follows a polynomial
(physics/torque.py) reaches each step as its value at the step's end. A step whose nonlinear solve
fails is retried at half the size, down to `min_step` (StepFailed below it).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

from ..protocol import StepFailed, StopAt
from ..stepping import AdvanceResult, ContactTally, StepControl, Steppable, X, check_substeps
from ..torque import Torque, as_profile

# an advance's step control: stepping.advance, or this module's rules of one scheme (`stepper`)
Stepper = Callable[[Steppable[X], X, float, float, Torque, StepControl, StopAt | None], AdvanceResult[X]]

GAP_RULE = ((1e-3, 1e-4), (5e-3, 5e-4), (1e-2, 1e-3))  # (gap below, step), the seed's thresholds


def gap_rule_step(gap: float, base: float) -> float:
    """The seed's step for a given gap (m); `base` beyond 1 cm."""
    for below, dt in GAP_RULE:
        if gap < below:
            return dt
    return base


def stepper(scheme: str) -> Stepper:
    """The advance of a seed scheme (newmark_fixed or newmark_gap_rule), called as stepping.advance is."""
    return functools.partial(advance, scheme=scheme)


def advance(
    model: Steppable[X],
    x: X,
    t: float,
    t_end: float,
    torque: Torque,
    control: StepControl,
    stop: StopAt | None = None,
    *,
    scheme: str,
) -> AdvanceResult[X]:
    """Integrate from t to t_end with the seed's step sizes; raises StepFailed like stepping.advance.
    The seed's schemes, kept for comparison, never stop early: `stop` is not asked."""
    profile, t_start = as_profile(torque), t
    substeps = rejected = 0
    min_gap = math.inf
    halvings = 0
    contact = ContactTally()
    while t_end - t > 0.0:
        remaining = t_end - t
        gap = model.gap_and_rate(x)[0]
        min_gap = min(min_gap, gap)
        dt = control.max_step if scheme == "newmark_fixed" else gap_rule_step(gap, control.max_step)
        dt = dt / 2.0**halvings
        if remaining - dt < control.min_step:
            dt = remaining
        x_new = model.step(x, dt, profile.at(t + dt - t_start))
        if x_new is None:
            rejected += 1
            halvings += 1
            if dt / 2.0 < control.min_step:
                raise StepFailed(
                    f"the nonlinear solve failed down to the smallest step {control.min_step:g} s at t = {t:.9g} s"
                )
            continue
        halvings = max(halvings - 1, 0)
        contact.add(model, x, x_new, dt, gap)
        x = x_new
        t = t_end if dt >= remaining else t + dt
        substeps += 1
        check_substeps(control, substeps, t, t_end)
    min_gap = min(min_gap, model.gap_and_rate(x)[0])
    return AdvanceResult(x, substeps, rejected, min_gap, contact)
