"""An fmpy FMU3Slave of the FMI 3.0 pendulum FMU addressed by variable name, for tests/test_fmu3*.py.

Used in child processes (tests/in_child.py): one FMU library per process, so that what one test loads
cannot help or hurt the next.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import in_child
from fmpy import extract, read_model_description
from fmpy.fmi3 import FMU3Slave


def child(module: str, function: str, *args: Any) -> Any:
    """What `function` of the test module `module` returned in a fresh interpreter (tests/in_child.py)."""
    run = subprocess.run(in_child.command(module, function, *args), capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return in_child.result(run.stdout)


class Instance3:
    """The FMI 3.0 FMU instantiated, its parameters set in initializationMode, in stepMode at t = 0.

    Log messages are collected as (status, message); `intermediate` is the host's intermediate-update
    callback (fmpy's signature), `events` how often an event was handled."""

    def __init__(
        self,
        fmu: str | Path,
        name: str = "pendulum3",
        early_return: bool = False,
        event_mode: bool = False,
        intermediate: Callable[..., None] | None = None,
        logging: bool = False,
        **start: Any,
    ) -> None:
        self.md = read_model_description(str(fmu))
        self.var = {v.name: v for v in self.md.modelVariables}
        self.dir = extract(str(fmu))
        self.messages: list[tuple[int, str]] = []
        self.event_mode = event_mode

        def log(env, status, category, message):
            self.messages.append((int(status), message.decode()))

        self.fmu = FMU3Slave(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            instanceName=name,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
        )
        self.fmu.instantiate(
            loggingOn=logging,
            eventModeUsed=event_mode,
            earlyReturnAllowed=early_return,
            logMessage=log,
            intermediateUpdate=intermediate,
        )
        self.fmu.enterInitializationMode(startTime=0.0)
        for key, value in start.items():
            self.set(key, value)
        self.fmu.exitInitializationMode()
        if event_mode:
            self.fmu.updateDiscreteStates()
            self.fmu.enterStepMode()
        self.t = 0.0
        self.events = 0

    def vr(self, name: str) -> int:
        return self.var[name].valueReference

    def set(self, name: str, value: Any) -> None:
        v = self.var[name]
        setter = {
            "Float64": self.fmu.setFloat64,
            "Int32": self.fmu.setInt32,
            "Enumeration": self.fmu.setInt64,
            "Boolean": self.fmu.setBoolean,
            "String": self.fmu.setString,
        }[v.type]
        setter([v.valueReference], [value])

    def get(self, *names: str) -> list[float]:
        return list(self.fmu.getFloat64([self.vr(n) for n in names]))

    def step(self, h: float, torque: float = 0.0) -> tuple[bool, bool, float]:
        """One doStep from the FMU's time (after handling an event it reported, in event mode):
        (eventHandlingNeeded, earlyReturn, lastSuccessfulTime)."""
        self.set("torque", torque)
        event, _terminate, early, last = self.fmu.doStep(self.t, h)
        self.t = last
        if event and self.event_mode:
            self.fmu.enterEventMode()
            self.fmu.updateDiscreteStates()
            self.fmu.enterStepMode()
            self.events += 1
        return bool(event), bool(early), float(last)

    def close(self) -> None:
        """Terminate, free the instance and delete the extraction folder."""
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)
