"""An advance run by the compiled core's step control (core/stepping.c) instead of stepping.advance.

The core takes the step control, the torque and the advance's start as plain structs, steps a model's
state (a float64 array) in place, and reports what stepping.AdvanceResult holds. This module fills the
structs, turns the core's status into the same StepFailed as stepping.py's, and calls a Python `stop`
(protocol.StopAt) from the core through the one callback the binding declares (femp_python_stop).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from .core import ffi, lib, pointer
from .protocol import Outputs, StopAt
from .stepping import AdvanceResult, ContactTally, StepControl, check_substeps, smallest_step_failed
from .torque import TorqueProfile

# advance(x, control, torque, advance, stop callback, its context) -> status: a femp_*_advance of the core
CoreAdvance = Callable[[Any, Any, Any, Any, Any, Any], int]


class _Stop:
    """The Python `stop` of one advance, and the exception it raised (the core sees a stop, the caller the error)."""

    def __init__(self, stop: StopAt):
        self.stop = stop
        self.error: BaseException | None = None


@ffi.def_extern()
def femp_python_stop(context: Any, t: float, gap_before: float, gap_after: float) -> int:
    """The core's femp_stop_fn for a Python stop: 1 ends the advance (also where the stop raised)."""
    box: _Stop = ffi.from_handle(context)
    try:
        return int(bool(box.stop(t, gap_before, gap_after)))
    except BaseException as exc:  # kept for the caller: nothing may unwind through C
        box.error = exc
        return 1


def control_struct(control: StepControl) -> Any:
    """struct femp_step_control of a StepControl."""
    c = ffi.new("struct femp_step_control *")
    c.max_step, c.tolerance, c.min_step = control.max_step, control.tolerance, control.min_step
    c.max_onset_iterations, c.max_substeps = control.max_onset_iterations, control.max_substeps
    c.timing_rule, c.even_contact_steps = int(control.timing_rule), int(control.even_contact_steps)
    return c


def compiled_advance(
    run: CoreAdvance,
    x: np.ndarray,
    control: Any,
    t: float,
    t_end: float,
    torque: float | TorqueProfile,
    start: Outputs,
    load: tuple[float, float],
    stop: StopAt | None = None,
) -> AdvanceResult[np.ndarray]:
    """Advance the state x (a copy is stepped) from t to t_end by `run`; `start` the outputs at t (the
    contact's hold and force, the angle, the gap), `load` (m g d, the head centre's depth) for the held-contact
    test. Raises StepFailed as stepping.advance does, the state then unchanged."""
    profile = torque if isinstance(torque, TorqueProfile) else TorqueProfile(float(torque))
    T = ffi.new("struct femp_torque *", (profile.value, profile.rate, profile.curvature))
    a = ffi.new("struct femp_advance *")
    a.t_start, a.t_end, a.hold, a.force_now = t, t_end, start.contact_hold, start.contact_force
    a.theta, (a.gravity_moment, a.head_centre_depth), a.gap_start = start.theta, load, start.gap
    stepped = np.array(x, dtype=np.float64)
    box = None if stop is None else _Stop(stop)
    handle = ffi.NULL if box is None else ffi.new_handle(box)
    callback = ffi.NULL if box is None else lib.femp_python_stop
    status = run(pointer(stepped), control, T, a, callback, handle)
    if box is not None and box.error is not None:
        raise box.error
    if status == lib.FEMP_ADVANCE_FAILED:
        raise smallest_step_failed(control.min_step, a.t_reached)
    if status == lib.FEMP_ADVANCE_TOO_MANY_STEPS:
        check_substeps(StepControl(max_substeps=control.max_substeps), a.substeps, a.t_reached, t_end)
    tally = ContactTally(a.force_max, a.impulse_x, a.impulse_y, a.hold, a.force_now)
    stopped = a.t_reached if status == lib.FEMP_ADVANCE_STOPPED else None
    return AdvanceResult(stepped, a.substeps, a.rejected, a.min_gap, tally, stopped)
