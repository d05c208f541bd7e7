"""Advances on the compiled core's step control (core/stepping.c), whose rules stepping.py states.

The core takes the step control, the torque and the advance's start as plain structs, steps a model's
state in place and reports what stepping.AdvanceResult holds. `compiled_advance` runs a fidelity whose
model is C (rigid, reduced: a float64 state array); `advance` runs a model whose step and contact
geometry are Python (stepping.Steppable: the FE model, and the Python forms the core is tested against)
through the binding's callbacks, the state array holding an index into this advance's states. Both turn the
core's status into stepping.py's StepFailed, the model's state unchanged, and call a Python `stop`
(protocol.StopAt) back. Nothing may unwind through C: an exception in a callback is kept, the callbacks
that follow return at once, and it is raised when the core returns.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any, Generic

import numpy as np

from . import stepping
from .core import ffi, lib, pointer
from .mass_properties import gravity_moment
from .protocol import Outputs, StopAt
from .stepping import AdvanceResult, ContactTally, StepControl, Steppable, X, check_substeps, smallest_step_failed
from .torque import Torque, TorqueProfile

# advance(x, control, torque, advance, stop callback, its context) -> status: a femp_*_advance of the core
CoreAdvance = Callable[[Any, Any, Any, Any, Any, Any], int]
NO_LOAD = (0.0, math.inf)  # (m g d, the head centre's depth) of a model without a scene: no load on the wall


class _Callbacks:
    """What the core's callbacks of one advance reach through their handle: `stop`, a Python model and its
    states (indices in the core's state arrays), and the first exception any of them raised."""

    def __init__(self, stop: StopAt | None, model: Steppable[Any] | None = None, x: Any = None):
        self.stop, self.model, self.states = stop, model, [x]
        self.error: BaseException | None = None

    def state(self, at: Any) -> Any:
        return self.states[int(at[0])]

    def keep(self, x: Any, at: Any) -> None:
        at[0] = len(self.states)
        self.states.append(x)


def _guarded(failed: Any) -> Callable:
    """A callback's body run only while no callback of its advance has raised; an exception is kept and
    `failed` returned."""

    def wrap(body: Callable) -> Callable:
        @functools.wraps(body)
        def callback(context: Any, *args: Any) -> Any:
            run: _Callbacks = ffi.from_handle(context)
            if run.error is not None:
                return failed
            try:
                return body(run, *args)
            except BaseException as exc:  # kept for the caller: nothing may unwind through C
                run.error = exc
                return failed

        return callback

    return wrap


@ffi.def_extern()
@_guarded(1)
def femp_python_stop(run: _Callbacks, t: float, gap_before: float, gap_after: float) -> int:
    assert run.stop is not None
    return int(bool(run.stop(t, gap_before, gap_after)))


@ffi.def_extern()
@_guarded(0)
def femp_python_step(run: _Callbacks, x0: Any, dt: float, torque: float, x1: Any) -> int:
    assert run.model is not None
    stepped = run.model.step(run.state(x0), dt, torque)
    if stepped is None:
        return 0
    run.keep(stepped, x1)
    return 1


@ffi.def_extern()
@_guarded(None)
def femp_python_gap_and_rate(run: _Callbacks, x: Any, gap: Any, rate: Any) -> None:
    assert run.model is not None
    gap[0], rate[0] = run.model.gap_and_rate(run.state(x))


@ffi.def_extern()
@_guarded(None)
def femp_python_contact_scales(run: _Callbacks, x: Any, t_contact: Any, d_max: Any) -> None:
    assert run.model is not None
    t_contact[0], d_max[0] = run.model.contact_scales(run.state(x))


@ffi.def_extern()
@_guarded(0.0)
def femp_python_contact_force(run: _Callbacks, x: Any) -> float:
    assert run.model is not None
    return float(run.model.contact_force(run.state(x)))


@ffi.def_extern()
@_guarded(None)
def femp_python_contact_impulse(run: _Callbacks, x0: Any, x1: Any, dt: float, j: Any) -> None:
    assert run.model is not None
    j[0], j[1] = (float(v) for v in run.model.contact_impulse(run.state(x0), run.state(x1), dt))


def control_struct(control: StepControl) -> Any:
    """struct femp_step_control of a StepControl, with the rules' constants of stepping.py."""
    c = ffi.new("struct femp_step_control *")
    c.max_step, c.tolerance, c.min_step = control.max_step, control.tolerance, control.min_step
    c.max_onset_iterations, c.max_substeps = control.max_onset_iterations, control.max_substeps
    c.timing_rule, c.even_contact_steps = int(control.timing_rule), int(control.even_contact_steps)
    c.min_steps_per_contact, c.held_contacts = stepping.MIN_STEPS_PER_CONTACT, stepping.HELD_CONTACTS
    c.held_force, c.step_kept, c.hold_decay = stepping.HELD_FORCE, stepping.STEP_KEPT, stepping.HOLD_DECAY
    return c


class CoreRun:
    """The structs and the state array of one model's advances on the core, made once: an advance fills them
    (the torque, the start, the state) and calls the core's advance `run` of that model (a fidelity in C:
    rigid, reduced; or a Python model through the binding's callbacks)."""

    def __init__(self, run: CoreAdvance, control: StepControl, size: int):
        self._run, self.control = run, control_struct(control)
        self._min_step, self._max_substeps = control.min_step, control.max_substeps
        self._T, self._a = ffi.new("struct femp_torque *"), ffi.new("struct femp_advance *")
        self._x = np.zeros(size)
        self._at = pointer(self._x)

    def __call__(
        self,
        x: Any,
        t: float,
        t_end: float,
        torque: Torque,
        start: Outputs,
        load: tuple[float, float],
        callbacks: _Callbacks,
    ) -> tuple[np.ndarray, Any, int]:
        """Step x (copied in) from t to t_end; (the stepped state, the advance struct, the status), raising
        StepFailed where the core failed and what a callback raised."""
        T, a = self._T, self._a
        if isinstance(torque, TorqueProfile):
            T.value, T.rate, T.curvature = torque.value, torque.rate, torque.curvature
        else:
            T.value, T.rate, T.curvature = torque, 0.0, 0.0
        a.t_start, a.t_end, a.hold, a.force_now = t, t_end, start.contact_hold, start.contact_force
        a.theta, (a.gravity_moment, a.head_centre_depth), a.gap_start = start.theta, load, start.gap
        self._x[:] = x
        if callbacks.stop is None and callbacks.model is None:  # no callback: no handle to make
            stop, handle = ffi.NULL, ffi.NULL
        else:
            stop = ffi.NULL if callbacks.stop is None else lib.femp_python_stop
            handle = ffi.new_handle(callbacks)
        status = self._run(self._at, self.control, T, a, stop, handle)
        if callbacks.error is not None:
            raise callbacks.error
        if status == lib.FEMP_ADVANCE_FAILED:
            raise smallest_step_failed(self._min_step, a.t_reached)
        if status == lib.FEMP_ADVANCE_TOO_MANY_STEPS:
            check_substeps(StepControl(max_substeps=self._max_substeps), a.substeps, a.t_reached, t_end)
        return self._x.copy(), a, status

    def advance(
        self,
        x: Any,
        t: float,
        t_end: float,
        torque: Torque,
        start: Outputs,
        load: tuple[float, float],
        stop: StopAt | None = None,
    ) -> AdvanceResult[np.ndarray]:
        """Advance the state x (its numbers) of a model in C from t to t_end; `start` the outputs at t (the contact's
        hold and force, the angle, the gap), `load` (m g d, the head centre's depth) for the held-contact
        test."""
        stepped, a, status = self(x, t, t_end, torque, start, load, _Callbacks(stop))
        return _result(stepped, a, status)


def _result(state: X, a: Any, status: int) -> AdvanceResult[X]:
    tally = ContactTally(a.force_max, a.impulse_x, a.impulse_y, a.hold, a.force_now)
    stopped = a.t_reached if status == lib.FEMP_ADVANCE_STOPPED else None
    return AdvanceResult(state, a.substeps, a.rejected, a.min_gap, tally, stopped)


class _PythonModel(Generic[X]):
    """A Python model as the core's struct femp_steppable: its functions the binding's callbacks."""

    def __init__(self, callbacks: _Callbacks):
        s = self.struct = ffi.new("struct femp_steppable *")
        self._handle = s.self = ffi.new_handle(callbacks)
        s.size, s.step, s.gap_and_rate = 1, lib.femp_python_step, lib.femp_python_gap_and_rate
        s.contact_scales, s.contact_force = lib.femp_python_contact_scales, lib.femp_python_contact_force
        s.contact_impulse = lib.femp_python_contact_impulse


def advance(
    model: Steppable[X],
    x: X,
    t: float,
    t_end: float,
    torque: Torque,
    control: StepControl,
    stop: StopAt | None = None,
) -> AdvanceResult[X]:
    """Integrate a Python model's state x from t to t_end on the core's step control; raises StepFailed if a
    step cannot be completed. The contact's hold and force and the angle at t are the model's outputs' (none
    for a model without outputs), the held-contact test's load its scene's."""
    callbacks = _Callbacks(stop, model, x)
    steppable = _PythonModel[X](callbacks)

    def run(at: Any, c: Any, T: Any, a: Any, stop_fn: Any, handle: Any) -> int:
        return int(lib.femp_advance(steppable.struct, c, T, at, a, stop_fn, handle))

    outputs, scene = getattr(model, "outputs", None), getattr(model, "scene", None)
    start = outputs() if callable(outputs) else Outputs(gap=math.inf)
    # no load without a scene and outputs: (0 + |T|) / inf
    load = (_gravity_moment(scene), scene.geometry.head_centre_depth) if scene and callable(outputs) else NO_LOAD
    stepped, a, status = CoreRun(run, control, 1)((0.0,), t, t_end, torque, start, load, callbacks)
    return _result(callbacks.states[int(stepped[0])], a, status)


@functools.lru_cache(maxsize=16)
def _gravity_moment(scene: Any) -> float:
    return gravity_moment(scene)
