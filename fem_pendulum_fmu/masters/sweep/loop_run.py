"""One loop sample on a worker: the controller loop of `fem-pendulum control` (masters/control/loop.py)
on instances of the two FMUs that the worker keeps, and the loop's metrics as its summary figures.

Each worker process extracts and instantiates the pendulum FMU and the controller FMU once
(`LoadedLoop`); every later sample resets both (fmi2Reset, as run.LoadedFmu does for open-loop
samples), initialises them with its start values as masters/named_slave.py does, and runs
`run_loop_on`, the loop of `closed_loop` and `fem-pendulum control` itself, on them. A reset
pythonfmu instance builds a new slave object, so a sample computes what a fresh run computes
(tests/test_sweep_control.py compares each sample's metrics and table with `closed_loop`'s). Against
fresh instances per sample, that saves an extraction and an instantiation of both FMUs: about 70 ms
(pendulum, rigid) and 45 ms (the PID FMU) per sample, measured on a loaded 2-core machine (to be
measured again on a quiet one), next to about 0.3 s for a rigid sample of 0.3 s.

Nothing a sample does stops the sweep: bad pendulum values (the FMU's own checks, run here first so
that the row names them), an FMU that refuses a value or a step, an exception, all become a result
with status error and the reason; a loop that ends before its stop time (LoopRun.stopped, what
`fem-pendulum control` reports as incomplete) keeps its table up to there and no metrics.
"""

from __future__ import annotations

import math
import shutil
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...fmi.interface import scene_from_values
from ...physics.scene import problems
from ..control.connections import Wiring
from ..control.controllers import FmuController
from ..control.hold import HoldChoice
from ..control.loop import LoopInputs, LoopRun, run_loop_on
from ..control.metrics import METRIC_NAMES, loop_metrics
from ..control.signals import Signal
from ..named_slave import NamedSlave
from .loop_samples import controller_values, pendulum_values, signal_of
from .run import ERROR, OK, SampleResult
from .samples import Sample, Value, start_values


@dataclass(frozen=True)
class LoopTask:
    """What a worker needs to run one loop sample (plain data: it travels to the worker pickled).

    pendulum: the pendulum's start values as the FMU takes them (enumerations by number, theta0 set).
    controller: the controller's parameters, by its own names.
    outputs: the columns of the loop's table (masters/control/series.py) kept in the series, after time.
    """

    sample_id: str
    pendulum: dict[str, Value] = field(hash=False)
    controller: dict[str, float | int | bool] = field(hash=False)
    setpoint: Signal = field(hash=False, compare=False)
    disturbance: Signal = field(hash=False, compare=False)
    wiring: Wiring
    stop_time: float
    step: float
    drive_limit: float
    outputs: tuple[str, ...]
    hold: HoldChoice = "auto"


def loop_task(
    sample: Sample,
    wiring: Wiring,
    stop_time: float,
    step: float,
    drive_limit: float,
    outputs: tuple[str, ...],
    hold: HoldChoice = "auto",
) -> LoopTask:
    """The task of a loop sample (its signals read here, on the client: a CSV file need not reach the workers)."""
    values = sample.values
    return LoopTask(
        sample.sample_id,
        start_values(pendulum_values(values)),
        controller_values(values),
        signal_of("setpoint", str(values["setpoint"])),
        signal_of("disturbance", str(values["disturbance"])),
        wiring,
        stop_time,
        step,
        drive_limit,
        outputs,
        hold,
    )


class LoadedLoop:
    """The pendulum FMU and the controller FMU of a worker's loop samples, one instance of each,
    reset for every sample after the first; an instance that refuses fmi2Reset is made anew."""

    def __init__(self, fmu: Path, controller: Path) -> None:
        self.paths = {"pendulum": fmu, "controller": controller}
        self._slaves: dict[str, NamedSlave] = {}

    def initialised(self, which: str, values: Mapping[str, Value]) -> NamedSlave:
        """The instance `which` (pendulum or controller) initialised with `values` (start values)."""
        from fmpy.fmi1 import FMICallException

        slave = self._slaves.get(which)
        if slave is not None:
            try:
                slave.fmu.reset()
            except FMICallException:
                self._free(which)
                slave = None
        if slave is None:
            slave = NamedSlave(self.paths[which], which, dict(values))
            self._slaves[which] = slave
            return slave
        slave.problems.clear()
        slave.fmu.setupExperiment(startTime=0.0)  # then as NamedSlave.__init__
        slave.fmu.enterInitializationMode()
        for name, value in values.items():
            slave.set(name, value)  # no String values: loop_samples refuses them
        slave.fmu.exitInitializationMode()
        return slave

    def run(self, task: LoopTask) -> LoopRun:
        """The loop of one sample, on the kept instances (the controller first, as `closed_loop` opens them)."""
        controller_slave = self.initialised("controller", task.controller)
        controller = FmuController(self.paths["controller"], task.wiring, task.controller, slave=controller_slave)
        pendulum = self.initialised("pendulum", task.pendulum)
        inputs = LoopInputs(
            self.paths["pendulum"],
            task.setpoint,
            task.disturbance,
            task.stop_time,
            task.step,
            task.pendulum,
            task.drive_limit,
            progress=False,
            hold=task.hold,
        )
        return run_loop_on(pendulum, inputs, controller)

    def problems(self) -> str:
        """What the instances logged at Discard or worse since their last initialisation."""
        return "; ".join(text for slave in self._slaves.values() for text in slave.problems)

    def _free(self, which: str) -> None:
        slave = self._slaves.pop(which)
        slave.fmu.freeInstance()  # also unloads the library; no fmi2Terminate: the instance may be in error
        shutil.rmtree(slave.dir, ignore_errors=True)

    def close(self) -> None:
        """Free both instances and delete their extractions."""
        for which in list(self._slaves):
            self._free(which)


def pendulum_problems(values: Mapping[str, Any]) -> str:
    """The FMU's own checks of the pendulum's parameters (as its fmi2ExitInitializationMode runs
    them), "" when they pass."""
    try:
        found = problems(scene_from_values(values))
    except ValueError as exc:
        return str(exc)
    return "; ".join(found)


def metric_figures(run: LoopRun, task: LoopTask) -> dict[str, float]:
    """The loop's metrics (masters/control/metrics.py), one per METRIC_NAMES, NaN where one was not
    measured (a step metric without a step set-point), as `closed_loop` computes them."""
    import pandas as pd

    metrics = loop_metrics(
        pd.DataFrame(run.table), step_size=task.step, drive_limit=task.drive_limit, setpoint=task.setpoint
    )
    return {name: metrics.values.get(name, math.nan) for name in METRIC_NAMES}


def run_loop_sample(loaded: LoadedLoop, task: LoopTask) -> SampleResult:
    """Run one loop sample; never raises (a failure is a result with status error and the reason)."""
    start = time.perf_counter()
    invalid = pendulum_problems(task.pendulum)
    if invalid:
        return SampleResult(task.sample_id, ERROR, f"invalid parameters: {invalid}", time.perf_counter() - start)
    try:
        run = loaded.run(task)
    except Exception as exc:  # an FMU refused a value, or the loop failed: the row says what
        message = f"{exc} {loaded.problems()}".strip()
        return SampleResult(task.sample_id, ERROR, message, time.perf_counter() - start)
    wall_time = time.perf_counter() - start
    kept: np.ndarray = run.table[["time", *task.outputs]]
    if run.stopped is not None:
        return SampleResult(task.sample_id, ERROR, run.stopped, wall_time, series=kept)
    try:
        figures = metric_figures(run, task)
    except Exception as exc:  # the run itself is kept
        return SampleResult(task.sample_id, ERROR, f"loop metrics: {exc}", wall_time, series=kept)
    return SampleResult(task.sample_id, OK, "", wall_time, figures, kept)
