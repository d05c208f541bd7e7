"""fmi2Get/Set of the slave's variables, each value reference checked, refusals reported to the binary.

The FMU's binary checks every value reference, type and causality before
calling these (shim/variables.c); without it (pythonfmu's binary: Windows)
pythonfmu would raise (fmi2Fatal) on an unknown value reference, a variable
of another type or setting an output, so these answer fmi2Error with a log
message instead and change nothing. A list of value references is checked
once and remembered: the outputs a master reads every step are then read
with one attrgetter, the torque set without re-checking. The messages name
the calls and types as `fmi` names them (fmi_names.py): FMI 2.0's, or FMI
3.0's in the slave the FMI 3.0 slave holds (slave3.py).
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
from .fmi_names import FMI2_NAMES, FmiNames
from .interface import OUTPUT_FIELDS

_CACHE = 64  # value-reference lists whose validation get_real / set_real remember, per instance


class CheckedVariableAccess(Fmi2Slave):
    """An Fmi2Slave whose outputs are the fields of `self.outputs` (interface.OUTPUT_FIELDS)."""

    fmi: FmiNames = FMI2_NAMES  # the names its messages give FMI's functions and statuses (FMI 3.0's: slave3.py)

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
        """Make the FMI call in progress answer an error (fmi2Error, fmi3Error) and log `msg` with status error
        (see shim/)."""
        if not self._report.report(msg):
            self.log(msg, Fmi2Status.error)

    def forget_value_references(self) -> None:
        """Drop the remembered lists and close the error report's library handle (release())."""
        self._real_readers.clear()
        self._real_setters.clear()
        self._report.close()

    def _variables(
        self, vrs: list[int], kind: type[ScalarVariable], call: str, setting: bool = False, type_name: str = ""
    ) -> list[int] | None:
        """The variables for `vrs`, or None after flagging an error naming the first bad reference (and the type
        `call` takes: `type_name`, else the FMI version's name of `kind`)."""
        for vr in vrs:
            var = self.vars.get(vr)
            if not isinstance(var, kind):
                wanted = type_name or self.fmi.type_name(kind.__name__)
                what = "no variable of this FMU" if var is None else f"{var.name}, not of type {wanted}"
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
            if self._variables(vrs, Real, self.fmi.get_real) is None:
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

    def get_integer(self, vrs: list[int], enumeration: bool = False) -> list[int]:
        """Integers and Enumerations (pythonfmu's Integer), read by the call of an enumeration when `enumeration`
        (FMI 3.0's fmi3GetInt64), for messages."""
        call, wanted = self._integer_call(False, enumeration)
        if self._variables(vrs, Integer, call, type_name=wanted) is None:
            return [0] * len(vrs)
        return super().get_integer(vrs)

    def _integer_call(self, setting: bool, enumeration: bool) -> tuple[str, str]:
        """The call that reads or sets Integers, or Enumerations, and the type it takes, as `fmi` names them."""
        fmi = self.fmi
        if enumeration:
            return (fmi.set_enumeration if setting else fmi.get_enumeration), fmi.enumeration_type
        return (fmi.set_integer if setting else fmi.get_integer), fmi.type_name("Integer")

    def get_boolean(self, vrs: list[int]) -> list[bool]:
        if self._variables(vrs, Boolean, self.fmi.get_boolean) is None:
            return [False] * len(vrs)
        return super().get_boolean(vrs)

    def get_string(self, vrs: list[int]) -> list[str]:
        if self._variables(vrs, String, self.fmi.get_string) is None:
            return [""] * len(vrs)
        return super().get_string(vrs)

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        key = tuple(vrs)
        setters = self._real_setters.get(key)
        if setters is None:
            if self._variables(vrs, Real, self.fmi.set_real, setting=True) is None:
                return
            if len(self._real_setters) >= _CACHE:
                self._real_setters.clear()
            setters = self._real_setters[key] = tuple(self.vars[vr].setter for vr in key)  # checked: not None
        if len(setters) == 1 == len(values):  # the torque, every step: without zip's keyword parsing
            setters[0](values[0])
            return
        for setter, value in zip(setters, values, strict=False):  # as pythonfmu: the host passes equal lengths
            setter(value)

    def set_integer(self, vrs: list[int], values: list[int], enumeration: bool = False) -> None:
        """Integers and Enumerations, set by the call of an enumeration when `enumeration` (see get_integer)."""
        call, wanted = self._integer_call(True, enumeration)
        if self._variables(vrs, Integer, call, setting=True, type_name=wanted) is not None:
            super().set_integer(vrs, values)

    def set_boolean(self, vrs: list[int], values: list[bool]) -> None:
        if self._variables(vrs, Boolean, self.fmi.set_boolean, setting=True) is not None:
            super().set_boolean(vrs, values)

    def set_string(self, vrs: list[int], values: list[str]) -> None:
        if self._variables(vrs, String, self.fmi.set_string, setting=True) is not None:
            super().set_string(vrs, values)
