"""fmi2Get/Set of the slave's variables, each value reference checked, refusals reported to the binary.

The FMU's binary checks every value reference, type and causality before
calling these (shim/variables.c); without it (pythonfmu's binary: Windows)
pythonfmu would raise (fmi2Fatal) on an unknown value reference, a variable
of another type or setting an output, so these answer fmi2Error with a log
message instead and change nothing. A list of value references is checked
once and remembered: the outputs a master reads every step are then read
with one attrgetter, the torque set without re-checking.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from typing import Any

from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Status
from pythonfmu.variables import Boolean, Integer, Real, ScalarVariable, String

from ..physics.protocol import Outputs
from .fmi_logging import ErrorReport
from .interface import OUTPUT_FIELDS

_CACHE = 64  # value-reference lists whose validation get_real / set_real remember, per instance


class CheckedVariableAccess(Fmi2Slave):
    """An Fmi2Slave whose outputs are the fields of `self.outputs` (interface.OUTPUT_FIELDS)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.outputs: Outputs | None = None
        self._report = ErrorReport(self.resources)
        # validated lists: get_real's attrgetter of outputs (None: not all outputs, pythonfmu's loop) and
        # whether the list has one reference; set_real's setters
        self._real_readers: dict[tuple[int, ...], tuple[Callable[[Outputs], Any] | None, bool]] = {}
        self._real_setters: dict[tuple[int, ...], tuple[Callable[[Any], None], ...]] = {}

    def initial_outputs(self) -> Outputs | None:
        """The outputs to read while `outputs` is None (None: zeros); a slave that can say them before its
        model exists overrides this."""
        return None

    def _error(self, msg: str) -> None:
        """Make the FMI call in progress answer fmi2Error and log `msg` with status error (see shim/)."""
        if not self._report.report(msg):
            self.log(msg, Fmi2Status.error)

    def forget_value_references(self) -> None:
        """Drop the remembered lists and close the error report's library handle (release())."""
        self._real_readers.clear()
        self._real_setters.clear()
        self._report.close()

    def _variables(
        self, vrs: list[int], kind: type[ScalarVariable], call: str, setting: bool = False
    ) -> list[int] | None:
        """The variables for `vrs`, or None after flagging an error naming the first bad reference."""
        for vr in vrs:
            var = self.vars.get(vr)
            if not isinstance(var, kind):
                what = "no variable of this FMU" if var is None else f"{var.name}, not of type {kind.__name__}"
                self._error(
                    f"{call} refused: value reference {vr} is {what} (value references are 0 to "
                    f"{len(self.vars) - 1}, see modelDescription.xml); nothing was changed"
                )
                return None
            if setting and var.setter is None:
                self._error(
                    f"{call} refused: {var.name} (value reference {vr}) is an {var.causality.name} and "
                    "cannot be set; nothing was changed"
                )
                return None
        return vrs

    def get_real(self, vrs: list[int]) -> list[float]:
        key = tuple(vrs)
        reader = self._real_readers.get(key)  # one lookup: the key's hash is not cached
        if reader is None:
            if self._variables(vrs, Real, "fmi2GetReal") is None:
                return [0.0] * len(vrs)
            reader = self._remember_reader(key)
        read, single = reader
        if read is None:
            return super().get_real(vrs)
        outputs = self.outputs if self.outputs is not None else self.initial_outputs()
        if outputs is None:
            return [0.0] * len(vrs)
        return [float(read(outputs))] if single else list(map(float, read(outputs)))

    def _remember_reader(self, key: tuple[int, ...]) -> tuple[Callable[[Outputs], Any] | None, bool]:
        """Remember and return the reader of a validated list of Real value references: an attrgetter
        of the Outputs fields when all are outputs (what a master reads every step), else None; and
        whether the list has one reference."""
        if len(self._real_readers) >= _CACHE:
            self._real_readers.clear()
        names = [self.vars[vr].name for vr in key]
        read = None
        if names and all(name in OUTPUT_FIELDS for name in names):
            read = operator.attrgetter(*(OUTPUT_FIELDS[n] for n in names))
        reader = self._real_readers[key] = (read, len(names) == 1)
        return reader

    def get_integer(self, vrs: list[int]) -> list[int]:
        if self._variables(vrs, Integer, "fmi2GetInteger") is None:
            return [0] * len(vrs)
        return super().get_integer(vrs)

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        if self._variables(vrs, Boolean, "fmi2GetBoolean") is None:
            return [False] * len(vrs)
        return super().get_boolean(vrs)

    def get_string(self, vrs: list[int]) -> list[str]:
        if self._variables(vrs, String, "fmi2GetString") is None:
            return [""] * len(vrs)
        return super().get_string(vrs)

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        key = tuple(vrs)
        setters = self._real_setters.get(key)
        if setters is None:
            if self._variables(vrs, Real, "fmi2SetReal", setting=True) is None:
                return
            if len(self._real_setters) >= _CACHE:
                self._real_setters.clear()
            setters = self._real_setters[key] = tuple(self.vars[vr].setter for vr in key)  # checked: not None
        if len(setters) == 1 == len(values):  # the torque, every step: without zip's keyword parsing
            setters[0](values[0])
            return
        for setter, value in zip(setters, values, strict=False):  # as pythonfmu: the host passes equal lengths
            setter(value)

    def set_integer(self, vrs: list[int], values: list[int]) -> None:
        if self._variables(vrs, Integer, "fmi2SetInteger", setting=True) is not None:
            super().set_integer(vrs, values)

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        if self._variables(vrs, Boolean, "fmi2SetBoolean", setting=True) is not None:
            super().set_boolean(vrs, values)

    def set_string(self, vrs: list[int], values: list[str]) -> None:
        if self._variables(vrs, String, "fmi2SetString", setting=True) is not None:
            super().set_string(vrs, values)
