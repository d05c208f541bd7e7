"""One sample through the FMU with fmpy: the part of a sweep that runs on a worker, without Dask.

A worker process extracts the FMU once and keeps one instance (`LoadedFmu`);
before each sample after the first it calls fmi2Reset, which makes pythonfmu
build a new slave object in the same process, so a reset instance computes
what a fresh one does, bit for bit (tests/test_sweep.py compares with a
direct `simulate_fmu`). The run itself is fmpy's `simulate_fmu` on that
instance: the same loop, input interpolation and recorder as a user's direct
run, hence the same numbers.

Nothing a sample does stops the sweep: an exception becomes a row with status
"error" and the message, completed with the FMU's own log messages (captured
through an fmpy logger callback: the FMU names the parameter it refused). An
fmi2Discard ends fmpy's loop early without an exception; a run that stops
before the stop time is an error too.

The FMU-only parameters (interface.FMU_ONLY_PARAMETERS) reach the FMU as in a
direct run: with `output.vtk_folder` set, each sample writes its field output
every `output.vtk_interval` into its own subfolder, VTK_FOLDER/SAMPLE_ID (on
the worker's file system; a relative folder is relative to the worker's
working directory), so that samples running at once do not overwrite each
other's frames. Without it `output.vtk_interval` writes nothing, as in the FMU.
"""

from __future__ import annotations

import math
import shutil
import time
from ctypes import byref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ...fmi.interface import scene_from_values
from ...physics.scene import Scene
from .figures import NEEDED, Figures, summarise
from .samples import Value, start_values

Status = Literal["ok", "error"]
OK: Status = "ok"
ERROR: Status = "error"
_WARNING = 1  # fmi2Warning: log messages at this status or worse go into an error row's message
VTK_FOLDER = "output.vtk_folder"


@dataclass(frozen=True)
class SampleTask:
    """What a worker needs to run one sample (plain data: it travels to the worker pickled)."""

    sample_id: str
    values: dict[str, Value] = field(hash=False)
    torque: np.ndarray | None = field(hash=False, compare=False)
    stop_time: float
    step: float
    outputs: tuple[str, ...]


@dataclass(frozen=True)
class SampleResult:
    """A finished sample: its status, the message of a failure, the wall time of the run, its figures
    (an open-loop sample's Figures, a loop sample's metrics by name: loop_run.py) and its time series
    (time and the requested outputs; None when the run produced none)."""

    sample_id: str
    status: Status
    message: str = ""
    wall_time: float = math.nan
    figures: Figures | dict[str, float] = field(default_factory=Figures)
    series: np.ndarray | None = field(default=None, compare=False)


class LoadedFmu:
    """An FMU extracted once with one instance that every sample reuses (fmi2Reset between samples).

    The instance logs through our callback with debug logging on, so that a discarded step's message
    (pythonfmu passes non-error messages only with logging on) reaches the error row.
    """

    def __init__(self, path: Path) -> None:
        from fmpy import extract, read_model_description

        self.md = read_model_description(str(path))
        self.dir = extract(str(path))
        self.messages: list[tuple[int, str]] = []
        self._callbacks = _callbacks(self._log)  # kept referenced: the FMU calls it
        self._instance: Any = None
        self._used = False

    def _log(self, component: object, name: bytes, status: int, category: bytes, message: bytes) -> None:
        self.messages.append((int(status), message.decode("utf-8", errors="replace")))

    def instance(self) -> Any:
        """The instance, fresh or reset; an instance that refuses fmi2Reset is freed and made anew."""
        from fmpy.fmi1 import FMICallException
        from fmpy.fmi2 import FMU2Slave

        self.messages.clear()
        if self._instance is not None and self._used:
            try:
                self._instance.reset()
            except FMICallException:
                self._instance.freeInstance()
                self._instance = None
        if self._instance is None:
            fresh = FMU2Slave(
                guid=self.md.guid,
                unzipDirectory=self.dir,
                modelIdentifier=self.md.coSimulation.modelIdentifier,
                instanceName="sweep",
            )
            fresh.instantiate(callbacks=self._callbacks, loggingOn=True)  # kept only once instantiated:
            self._instance = fresh  # a refused one has no component, and the next sample tries again
        self._used = True
        return self._instance

    def close(self) -> None:
        """Free the instance (fmpy also unloads the library) and delete the extraction."""
        if self._instance is not None:
            self._instance.freeInstance()
            self._instance = None
        shutil.rmtree(self.dir, ignore_errors=True)


def _callbacks(logger: Any) -> Any:
    """fmi2CallbackFunctions whose logger is `logger`, behind fmpy's proxy that formats the message."""
    from fmpy.fmi1 import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )
    from fmpy.logging import addLoggerProxy

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    return callbacks


def scene_of(values: dict[str, Value]) -> Scene:
    """The scene a sample's values describe (the FMU's defaults for the rest), for the swing energy."""
    return scene_from_values(values)


def fmu_start_values(task: SampleTask) -> dict[str, Value]:
    """The sample's start values for the FMU, its field output folder made its own (see the module's docstring)."""
    values = start_values(task.values)
    folder = str(values.get(VTK_FOLDER, "")).strip()
    if folder:
        values[VTK_FOLDER] = str(Path(folder) / task.sample_id)
    return values


def _logged(messages: list[tuple[int, str]]) -> str:
    return "; ".join(text for status, text in messages if status >= _WARNING)


def simulate(loaded: LoadedFmu, task: SampleTask) -> np.ndarray:
    """fmpy's simulate_fmu on the loaded FMU's instance: the recorded outputs (NEEDED and task.outputs)."""
    from fmpy import simulate_fmu

    return simulate_fmu(
        loaded.dir,
        model_description=loaded.md,
        fmu_instance=loaded.instance(),
        start_values=fmu_start_values(task),
        input=task.torque,
        output=list(dict.fromkeys(task.outputs + NEEDED)),
        stop_time=task.stop_time,
        output_interval=task.step,
    )


def run_sample(loaded: LoadedFmu, task: SampleTask) -> SampleResult:
    """Run one sample; never raises (a failure is a result with status error and the reason)."""
    start = time.perf_counter()
    try:
        series = simulate(loaded, task)
    except Exception as exc:  # the FMU refused something, or fmpy did: the row says what
        logged = _logged(loaded.messages)
        message = f"{exc} {logged}".strip()
        return SampleResult(task.sample_id, ERROR, message, time.perf_counter() - start)
    wall_time = time.perf_counter() - start
    kept = series[["time", *task.outputs]]
    end = float(series["time"][-1])
    if not math.isclose(end, task.stop_time, rel_tol=1e-9, abs_tol=1e-12):
        message = f"the run stopped at t = {end!r} s before the stop time {task.stop_time!r} s: "
        return SampleResult(task.sample_id, ERROR, message + _logged(loaded.messages), wall_time, series=kept)
    try:
        figures = summarise(series, scene_of(task.values))
    except Exception as exc:  # e.g. an unreadable scene value; the run itself is kept
        return SampleResult(task.sample_id, ERROR, f"summary figures: {exc}", wall_time, series=kept)
    return SampleResult(task.sample_id, OK, "", wall_time, figures, kept)
