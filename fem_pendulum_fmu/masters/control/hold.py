"""The hold order of the controller loop: how the torque and the controller's inputs vary over a step.

With order 0 the loop holds every value over a communication step (sample and hold). With order 1 or
2 it also passes time derivatives across the connection (masters/coupling.py), so the controller's
inputs and the pendulum's torque follow a ramp or a parabola over the step; docs/notes/coupling.md measures
what that buys. An FMU takes part only as far as it declares: canInterpolateInputs and
maxOutputDerivativeOrder in its modelDescription; a Python function controller gives no derivatives
(order 0). "auto" is the highest order both sides declare, at most 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from ..coupling import HOLD_ORDERS
from ..failures import UsageError

HoldChoice = int | Literal["auto"]
HOLD_CHOICES = ("auto", "0", "1", "2")


def fmu_hold_order(path: Path) -> int:
    """hold_order_of the FMU at `path`."""
    from fmpy import read_model_description

    return hold_order_of(read_model_description(str(path)))


def hold_order_of(description: Any) -> int:
    """The highest hold order an FMI 2.0 co-simulation FMU (fmpy's ModelDescription) declares it can
    take part in: its maxOutputDerivativeOrder (at most 2) when it can also interpolate its inputs,
    else 0."""
    cosim = description.coSimulation
    if cosim is None or not cosim.canInterpolateInputs:
        return 0
    return min(int(cosim.maxOutputDerivativeOrder or 0), max(HOLD_ORDERS))


def parse_hold(text: object, option: str = "--hold") -> HoldChoice:
    """'auto' or a hold order 0, 1, 2 from text or a number; UsageError naming the value otherwise."""
    word = str(text).strip().lower()
    if word not in HOLD_CHOICES or isinstance(text, bool):
        raise UsageError(f"{option} {text!r} is not allowed: choose one of auto, 0 (hold), 1 (ramps), 2 (parabolas)")
    return "auto" if word == "auto" else int(word)


def loop_hold(requested: HoldChoice, pendulum: int, controller: int, controller_name: str) -> int:
    """The hold order the loop runs with: `requested`, checked against what the pendulum FMU and the
    controller declare (`fmu_hold_order`; a function controller: 0); "auto", the highest both take."""
    possible = min(pendulum, controller)
    if requested == "auto":
        return possible
    if requested > possible:
        declared = "canInterpolateInputs and maxOutputDerivativeOrder of its modelDescription"
        if pendulum < requested:
            who = f"the pendulum FMU takes {pendulum} at most ({declared})"
        elif controller_name.endswith(".fmu"):
            who = f"{controller_name} takes {controller} at most ({declared})"
        else:
            who = f"the function {controller_name} gives values, not their derivatives (order 0)"
        raise UsageError(f"hold order {requested} is not possible: {who}; use {possible} or auto")
    return requested
