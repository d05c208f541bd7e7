"""`closed_loop`: the controller loop of masters/control/ as one call a test suite makes."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..masters.control.controllers import FunctionController, Measurements, controller_fmu
from ..masters.control.hold import fmu_hold_order, loop_hold, parse_hold
from ..masters.control.loop import LoopInputs, run_loop
from ..masters.control.metrics import Metrics
from ..masters.control.signals import Signal, as_signal
from ..masters.failures import IncompleteRun, UsageError, check_fmu, check_start_values, check_times
from .fmus import default_fmu

ControllerLike = Path | str | Callable[[float, Measurements], float]


@dataclass
class LoopResult:
    """A loop run: `series`, a pandas DataFrame with the columns of masters/control/series.py, one
    row per communication point; `metrics`, metric name to value (masters/control/metrics.py
    Metrics: also `.times`, when the metrics that happen at an instant happened, `.units`,
    `.impact_times` and `.missing`, why a metric was not measured); what the controller was."""

    series: Any
    metrics: Metrics
    controller: str = ""

    def check(self, **bounds: float) -> LoopResult:
        """assert_loop(self, **bounds) (masters/control/checks.py); self, to chain."""
        from ..masters.control.checks import assert_loop

        __tracebackhide__ = True  # pytest shows the failed checks, not this method's source
        assert_loop(self, **bounds)
        return self


def closed_loop(
    controller: ControllerLike,
    setpoint: object = 0.0,
    stop_time: float = 1.0,
    step: float = 1e-3,
    pendulum: Mapping[str, object] | None = None,
    fidelity: str | None = None,
    disturbance: object = 0.0,
    fmu: Path | str | None = None,
    connect: Sequence[str] = (),
    controller_parameters: Mapping[str, object] | None = None,
    drive_limit: float = 15.0,
    hold: int | str = "auto",
) -> LoopResult:
    """Run `controller` in the loop with the pendulum FMU and return the series and its metrics.

    controller: a Python callable `(t, measurements) -> torque` (N.m; Measurements in
        masters/control/controllers.py), the path of an FMI 2.0 controller FMU (wired by `connect`,
        FROM=TO items as `fem-pendulum control --connect`, or by name), or "pid" for the project's PID FMU.
    setpoint, disturbance: a number, a callable of t, or the text of --setpoint / --disturbance
        (masters/control/signals.py); angles in rad, torques in N.m.
    pendulum: start values of the pendulum FMU's parameters, as --set; fidelity: rigid, reduced, fem or auto.
    fmu: the pendulum FMU; default dist/FemPendulum.fmu, built on first use.
    hold: 0, 1, 2 or "auto", how the torque and the controller's inputs vary over a step
        (masters/control/hold.py): auto takes the highest order both FMUs declare; a function: 0.
    Raises UsageError for bad arguments and IncompleteRun when the pendulum stops before stop_time.
    """
    check_times(stop_time, step)
    if not (math.isfinite(drive_limit) and drive_limit > 0):
        raise UsageError(f"drive_limit {drive_limit!r} is not allowed: it must be a finite torque > 0 (N.m)")
    target = as_signal(setpoint, "angle", "setpoint")
    load = as_signal(disturbance, "torque", "disturbance")
    fmu_path = check_fmu(Path(fmu), "fmu") if fmu is not None else default_fmu("FemPendulum.fmu")
    values = pendulum_values(pendulum or {}, fidelity)
    order = parse_hold(hold, "hold")
    law = _controller(controller, fmu_path, connect, controller_parameters or {})
    try:
        loop_hold(order, fmu_hold_order(fmu_path), law.hold, law.description)
    except UsageError:
        law.close()
        raise
    inputs = LoopInputs(fmu_path, target, load, stop_time, step, values, drive_limit, progress=False, hold=order)
    run = run_loop(inputs, law)
    if run.stopped is not None:
        raise IncompleteRun(run.stopped)
    return _result(run.table, step, drive_limit, target, law.description)


def pendulum_values(pendulum: Mapping[str, object], fidelity: str | None) -> dict:
    """The pendulum's start values from a mapping (as --set) and a fidelity name, checked."""
    from ..masters.open_loop import parse_start_values

    items = {"theta0": 0.0, **pendulum}
    if fidelity is not None:
        items["model.fidelity"] = fidelity
    values = parse_start_values([f"{name}={value}" for name, value in items.items()], option="pendulum")
    check_start_values(values)
    return values


def _controller(controller: ControllerLike, fmu: Path, connect: Sequence[str], parameters: Mapping[str, object]) -> Any:
    """A FunctionController, or the controller FMU opened with its wiring and parameters."""
    if callable(controller):
        if connect or parameters:
            raise UsageError("connect and controller_parameters apply to a controller FMU, not to a function")
        return FunctionController(controller)
    path = default_fmu("PidController.fmu", fmu.parent) if str(controller) == "pid" else Path(controller)
    if not path.is_file():
        raise UsageError(f"controller {str(path)!r} is not an FMU file, a callable or 'pid'")
    return controller_fmu(path, connect, parameters).open()


def _result(table: Any, step: float, drive_limit: float, setpoint: Signal, description: str) -> LoopResult:
    """The LoopResult of a loop's table: the DataFrame and the metrics."""
    import pandas as pd

    from ..masters.control.metrics import loop_metrics

    series = pd.DataFrame(table)
    return LoopResult(
        series, loop_metrics(series, step_size=step, drive_limit=drive_limit, setpoint=setpoint), description
    )
