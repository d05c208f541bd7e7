"""The fixed-step master of the controller loop: controller, drive and pendulum FMU.

At each communication point t_k the master reads the pendulum's outputs, gives the controller
those and the set-point at t_k, takes the demand it answers for the step [t_k, t_k + h] (a
controller FMU is stepped over that interval first: controller, then pendulum, Gauss-Seidel),
limits it to the drive's torque, adds the disturbance at t_k and holds the sum on the pendulum's
torque input while the pendulum steps. So the torque over a step is the controller's law applied
to what was measured at its start: a sample-and-hold of one step, no further delay. A step the
pendulum discards is retried in two halves with the same torque (the controller is not asked
again); a run that cannot go on ends there, with the reason in `LoopRun.stopped`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..coupling import Rates, limited, output_rates, set_input_rates
from ..named_slave import NamedSlave
from ..run_progress import RunProgress
from .controllers import Controller, Measurements
from .hold import HoldChoice, hold_order_of, loop_hold
from .series import COLUMNS
from .signals import Signal

# the pendulum outputs read at every point: the first six are table columns at the point, the last
# three the step summaries (both_halves reads them at the end)
STEP_SUMMARIES = ("gap_min", "contact_force_max", "contact_impulse")
OUTPUTS = ("theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work", *STEP_SUMMARIES)
# the pendulum's start values unless a run gives others: hanging at rest, touching the wall
DEFAULT_START_VALUES = {"theta0": 0.0}


@dataclass(frozen=True, slots=True)
class Polynomial:
    """A signal over a step from its start: value + rates[0] s + rates[1] s^2 / 2 (no rates: held)."""

    value: float
    rates: Rates = field(default_factory=list)

    def shifted(self, s: float) -> Polynomial:
        """The same polynomial seen from s seconds into the step."""
        r = [*self.rates, 0.0, 0.0]
        value = self.value + r[0] * s + 0.5 * r[1] * s * s
        return Polynomial(value, [r[0] + r[1] * s, r[1]][: len(self.rates)])


class SensedRates:
    """The time derivatives (orders 1 to `order`) of the pendulum outputs a controller reads, from the
    pendulum FMU's output derivatives; none for the per-step summaries, which have none."""

    def __init__(self, pendulum: NamedSlave, reads: tuple[str, ...], order: int) -> None:
        self.pendulum, self.order = pendulum, order
        self.names = reads
        self.smooth = [n for n in reads if n not in STEP_SUMMARIES]
        self._vrs = [pendulum.vr[n] for n in self.smooth]

    def __call__(self) -> list[Rates]:
        found = dict(zip(self.smooth, output_rates(self.pendulum.fmu, self._vrs, self.order), strict=True))
        return [found.get(n, []) for n in self.names]


def drive(demand: float, limit: float) -> float:
    """The drive delivers the demanded torque up to its limit."""
    return max(-limit, min(limit, demand))


def both_halves(first: list[float], outputs: list[float]) -> list[float]:
    """The outputs after a step taken in two halves, its STEP_SUMMARIES (at the end of `outputs`) made
    those of the whole step: the smaller gap_min, the larger force, the sum of the impulses."""
    n = len(OUTPUTS) - len(STEP_SUMMARIES)
    (gap0, force0, impulse0), (gap1, force1, impulse1) = first, outputs[n : len(OUTPUTS)]
    return [*outputs[:n], min(gap0, gap1), max(force0, force1), impulse0 + impulse1, *outputs[len(OUTPUTS) :]]


@dataclass(frozen=True)
class LoopInputs:
    """Everything a loop run is given besides its controller (plain data, checked by the caller)."""

    fmu: Path
    setpoint: Signal
    disturbance: Signal = field(default_factory=lambda: Signal("constant", "torque"))
    stop_time: float = 2.0
    step: float = 1e-3
    start_values: Mapping[str, float | int | bool | str] = field(default_factory=dict)
    drive_limit: float = 15.0
    progress: bool = True
    hold: HoldChoice = "auto"  # the hold order (hold.py): "auto", the highest both FMUs declare


@dataclass
class LoopRun:
    """The loop's table (columns of series.py), and why it ended before its stop time (None: it ran
    to the end); `problems` are the pendulum FMU's Discard and Error messages."""

    table: np.ndarray
    stopped: str | None = None
    problems: list[str] = field(default_factory=list)


def run_loop(inputs: LoopInputs, controller: Controller) -> LoopRun:
    """Co-simulate the controller and the pendulum FMU from t = 0 to the stop time (module docstring);
    the controller is closed at the end, also when the pendulum cannot be instantiated."""
    try:
        pendulum = NamedSlave(inputs.fmu, "pendulum", {**DEFAULT_START_VALUES, **inputs.start_values})
    except BaseException:
        controller.close()
        raise
    try:
        return run_loop_on(pendulum, inputs, controller)
    finally:
        pendulum.close()
        controller.close()


def run_loop_on(pendulum: NamedSlave, inputs: LoopInputs, controller: Controller) -> LoopRun:
    """`run_loop` on a pendulum instance already initialised with the run's start values (so
    inputs.fmu and inputs.start_values are not read), closing neither it nor the controller: a
    sweep's worker reuses both for its next sample (masters/sweep/loop_run.py)."""
    names = OUTPUTS + tuple(n for n in controller.reads() if n not in OUTPUTS)
    picks = [names.index(n) for n in controller.reads()]
    vrs = [pendulum.vr[n] for n in names]
    order = loop_hold(inputs.hold, hold_order_of(pendulum.md), controller.hold, controller.description)
    sensed = SensedRates(pendulum, controller.reads(), order)
    n = int(round(inputs.stop_time / inputs.step))
    bar = RunProgress(n, enabled=inputs.progress)
    rows: list[tuple[float, ...]] = []
    stopped = None
    try:
        reading = pendulum.fmu.getReal(vrs)
        applied = (0.0, 0.0, 0.0)  # demand, disturbance, torque at the start of the step that ended at t
        for k in range(n + 1):
            t = k * inputs.step
            rows.append(_row(t, inputs.setpoint(t), reading, applied))
            if k == n:
                break
            m = Measurements(t, reading[0], reading[1], reading[2], reading[3], rows[-1][1], applied[2])
            stopped, demand = _ask(controller, m, inputs, [reading[i] for i in picks], sensed)
            if stopped is not None:
                break
            torque = _torque(demand, controller.demand_rates(order) if order else [], t, inputs, order)
            applied = (demand, inputs.disturbance(t), torque.value)
            stopped, reading = _step_pendulum(pendulum, vrs, t, inputs, torque)
            if stopped is not None:
                break
            bar.step()
    finally:
        bar.close()
    table = np.array(rows, dtype=[(c, float) for c in COLUMNS])
    return LoopRun(table, stopped, list(pendulum.problems))


def _row(t: float, setpoint: float, reading: list[float], applied: tuple[float, float, float]) -> tuple[float, ...]:
    """A table row in the order of series.COLUMNS."""
    return (t, setpoint, *reading[:6], *applied, *reading[6:9])


def _ask(
    controller: Controller, m: Measurements, inputs: LoopInputs, extra: list[float], sensed: SensedRates
) -> tuple[str | None, float]:
    """The controller's demand, given the measurements and, with a hold order, their derivatives;
    or why the loop must stop (a controller FMU that failed)."""
    from fmpy.fmi1 import FMICallException

    try:
        rates = sensed() if sensed.order else []
        setpoint = inputs.setpoint.rates(m.time, sensed.order) if sensed.order else []
        return None, controller.demand(m, inputs.step, extra, rates, setpoint)
    except FMICallException as exc:
        return f"the controller {controller.description} stopped at t = {m.time:.6g} s: {exc}", math.nan


def _torque(demand: float, rates: Rates, t: float, inputs: LoopInputs, order: int) -> Polynomial:
    """The torque over the step from t: the demand (and its derivatives) through the drive, plus the
    disturbance (and its derivatives, with a hold order)."""
    value, kept = limited(demand, rates, inputs.drive_limit, inputs.step)
    disturbance = inputs.disturbance
    extra = disturbance.rates(t, order) if order else []
    return Polynomial(value + disturbance(t), [a + b for a, b in zip(kept, extra, strict=True)])


def _step_pendulum(
    pendulum: NamedSlave, vrs: list[int], t: float, inputs: LoopInputs, torque: Polynomial
) -> tuple[str | None, list[float]]:
    """Step the pendulum over [t, t + step] with `torque`, in two halves if the whole step is
    discarded (its state is then unchanged); the outputs after it, or why it could not go on."""
    from fmpy.fmi1 import FMICallException

    h = inputs.step
    try:
        _give(pendulum, torque)
        pendulum.fmu.doStep(t, h)
        return None, pendulum.fmu.getReal(vrs)
    except FMICallException:
        pass
    try:
        _give(pendulum, torque)
        pendulum.fmu.doStep(t, h / 2)
        first = pendulum.get(*STEP_SUMMARIES)
        _give(pendulum, torque.shifted(h / 2))
        pendulum.fmu.doStep(t + h / 2, h / 2)
    except FMICallException:
        said = pendulum.problems[-1] if pendulum.problems else "the FMU gave no message"
        return f"the pendulum FMU stopped at t = {t:.6g} s of {inputs.stop_time:g} s: {said}", []
    return None, both_halves(first, pendulum.fmu.getReal(vrs))


def _give(pendulum: NamedSlave, torque: Polynomial) -> None:
    """Set the torque input, and its derivatives with a hold order (the FMU clears them at a doStep)."""
    pendulum.set("torque", torque.value)
    set_input_rates(pendulum.fmu, [pendulum.vr["torque"]], [torque.rates])
