"""One FMU instance addressed by variable name, for the masters and benchmarks (fmpy)."""

from __future__ import annotations

import shutil
from pathlib import Path


class NamedSlave:
    """An fmpy FMU2Slave with name-based access, instantiated and initialised with start values."""

    def __init__(self, path: Path, name: str, start_values: dict) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave, defaultCallbacks, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.dir = extract(str(path))
        self.fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.problems: list[str] = []  # the FMU's Discard, Error and Fatal messages, in order
        self._logger = fmi2CallbackLoggerTYPE(self._log)  # kept: the FMU holds the pointer
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = defaultCallbacks.allocateMemory
        callbacks.freeMemory = defaultCallbacks.freeMemory
        try:
            self.fmu.instantiate(callbacks=callbacks)
        except Exception:  # fmpy's bare Exception: the FMU's logged reason says why
            from .failures import not_instantiated

            shutil.rmtree(self.dir, ignore_errors=True)
            raise not_instantiated(path, self.problems) from None
        try:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            for key, value in start_values.items():
                self.set(key, value)
            self.fmu.exitInitializationMode()
        except BaseException:  # a refused start value: free the instance and its folder, then report
            self._free()
            raise

    def _log(self, environment: object, instance: object, status: int, category: object, message: bytes) -> None:
        """Keep the messages of status Discard (2) and above; print nothing (the master reports them)."""
        if status >= 2:
            self.problems.append((message or b"").decode(errors="replace"))

    def set(self, name: str, value: float | int | bool | str) -> None:
        """Set `name` through the setter of its declared type (a String parameter as text)."""
        typ = self.types[name]
        if typ == "Real":
            self.fmu.setReal([self.vr[name]], [float(value)])
        elif typ == "Boolean":
            self.fmu.setBoolean([self.vr[name]], [bool(value)])
        elif typ == "String":
            self.fmu.setString([self.vr[name]], [str(value)])
        else:
            self.fmu.setInteger([self.vr[name]], [int(value)])

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vr[n] for n in names])

    def close(self) -> None:
        self.fmu.terminate()
        self._free()

    def _free(self) -> None:
        self.fmu.freeInstance()  # frees the instance and unloads the library
        shutil.rmtree(self.dir, ignore_errors=True)
