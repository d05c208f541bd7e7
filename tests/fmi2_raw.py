"""FMI 2.0 calls into an FMU through fmpy, raw: every call returns its status, every log message is kept.

fmpy's FMU2Slave loads the FMU's binary and gives each fmi2 function its ctypes signature; its Python
wrappers raise FMICallException for any status above fmi2Warning and so hide which status it was. The
classes here call the typed ctypes functions (`FMU2Slave._functions`) directly. One `Fmu` loads the
library once; every `Instance` made from it is a component of that library with its own logger.

Used by tests/test_fmi2_contract.py, in child processes (an FMU that crashes takes only the child down).
"""

from __future__ import annotations

import shutil
from ctypes import (
    POINTER,
    byref,
    c_char,
    c_char_p,
    c_double,
    c_int,
    c_size_t,
    c_uint,
    c_void_p,
    cast,
    create_string_buffer,
)
from dataclasses import dataclass
from pathlib import Path

from fmpy import extract, fmi2, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.logging import addLoggerProxy

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")
# fmi2StatusKind
DO_STEP_STATUS, PENDING_STATUS, LAST_SUCCESSFUL_TIME, TERMINATED = range(4)
# the four states the FMUs can be in (docs/reference/fmi2.md; the names of the standard's section 4.2.4)
STATES = ("instantiated", "initializationMode", "stepComplete", "terminated")
FILL = 0xAB  # what a host buffer holds before the FMU writes into it


@dataclass(frozen=True)
class Message:
    status: int
    category: str
    text: str


class Fmu:
    """An FMU archive extracted once, its model description, and its binary loaded through fmpy."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.md = read_model_description(str(self.path))
        self.var = {v.name: v for v in self.md.modelVariables}
        self.guid = self.md.guid
        self.dir = extract(str(self.path))
        self.uri = (Path(self.dir) / "resources").as_uri()
        self.loader = FMU2Slave(
            guid=self.guid,
            unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="loader",
        )
        self.f = self.loader._functions  # the typed ctypes functions, by FMI name

    def vr(self, *names: str) -> list[int]:
        return [self.var[n].valueReference for n in names]

    def names_of_type(self, kind: str) -> list[str]:
        """Variables whose FMI get/set functions are those of `kind` (Enumeration is Integer)."""
        return [v.name for v in self.md.modelVariables if (v.type if v.type != "Enumeration" else "Integer") == kind]

    def close(self) -> None:
        """Unload the library (as fmpy's freeInstance does) and delete the extraction folder."""
        self.loader.freeLibrary()
        shutil.rmtree(self.dir, ignore_errors=True)


def _reals(values) -> object:
    return (c_double * max(1, len(values)))(*values)


def _vrs(vrs) -> object:
    return (c_uint * max(1, len(vrs)))(*vrs)


class Instance:
    """One fmi2Component of `fmu`; `c` is None when fmi2Instantiate returned NULL."""

    def __init__(
        self,
        fmu: Fmu,
        name: str | None = "inst",
        guid: str | None = None,
        fmu_type: int = fmi2.fmi2CoSimulation,
        logging_on: bool = True,
    ) -> None:
        self.fmu = fmu
        self.f = fmu.f
        self.messages: list[Message] = []

        def logger(environment, instance, status, category, message):
            self.messages.append(Message(status, (category or b"").decode(), (message or b"").decode()))

        self._logger = fmi2.fmi2CallbackLoggerTYPE(logger)  # kept: C holds the pointer
        self.callbacks = fmi2.fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2.defaultCallbacks.allocateMemory
        self.callbacks.freeMemory = fmi2.defaultCallbacks.freeMemory
        addLoggerProxy(byref(self.callbacks))
        self.c = self.f["fmi2Instantiate"](
            None if name is None else name.encode(),
            fmu_type,
            (fmu.guid if guid is None else guid).encode(),
            fmu.uri.encode(),
            byref(self.callbacks),
            fmi2.fmi2False,
            fmi2.fmi2True if logging_on else fmi2.fmi2False,
        )

    # ---------------------------------------------------------------- messages
    def mark(self) -> int:
        """A position in the log: `since(mark)` gives the messages logged after it."""
        return len(self.messages)

    def since(self, mark: int) -> list[str]:
        return [m.text for m in self.messages[mark:]]

    # -------------------------------------------------------------- life cycle
    def setup(self, start: float = 0.0) -> int:
        return self.f["fmi2SetupExperiment"](self.c, fmi2.fmi2False, 0.0, start, fmi2.fmi2False, 0.0)

    def enter(self) -> int:
        return self.f["fmi2EnterInitializationMode"](self.c)

    def exit(self) -> int:
        return self.f["fmi2ExitInitializationMode"](self.c)

    def terminate(self) -> int:
        return self.f["fmi2Terminate"](self.c)

    def reset(self) -> int:
        return self.f["fmi2Reset"](self.c)

    def free(self) -> None:
        self.f["fmi2FreeInstance"](self.c)
        self.c = None

    def debug_logging(self, on: bool = True, categories: tuple[str, ...] = ()) -> int:
        """fmi2SetDebugLogging; no categories: all of them."""
        names = (c_char_p * max(1, len(categories)))(*[c.encode() for c in categories])
        return self.f["fmi2SetDebugLogging"](
            self.c, fmi2.fmi2True if on else fmi2.fmi2False, len(categories), names if categories else None
        )

    def do_step(self, t: float, h: float) -> int:
        return self.f["fmi2DoStep"](self.c, t, h, fmi2.fmi2True)

    def cancel_step(self) -> int:
        return self.f["fmi2CancelStep"](self.c)

    # --------------------------------------------------------------- variables
    def get(self, kind: str, vrs: list[int]) -> tuple[int, list]:
        """fmi2Get<kind> (Real, Integer, Boolean, String): the status and the values read."""
        ctype = {"Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}[kind]
        values = (ctype * max(1, len(vrs)))()
        status = self.f[f"fmi2Get{kind}"](self.c, _vrs(vrs), len(vrs), values)
        out = list(values)[: len(vrs)]
        if kind == "String":
            out = [None if v is None else v.decode() for v in out]
        elif kind == "Boolean":
            out = [bool(v) for v in out]
        return status, out

    def set(self, kind: str, vrs: list[int], values: list) -> int:
        if kind == "Real":
            buffer = _reals([float(v) for v in values])
        elif kind in ("Integer", "Boolean"):
            buffer = (c_int * max(1, len(values)))(*[int(v) for v in values])
        else:
            buffer = (c_char_p * max(1, len(values)))(*[str(v).encode() for v in values])
        return self.f[f"fmi2Set{kind}"](self.c, _vrs(vrs), len(vrs), buffer)

    def kind_of(self, name: str) -> str:
        kind = self.fmu.var[name].type
        return "Integer" if kind == "Enumeration" else kind

    def get_named(self, *names: str) -> tuple[int, list]:
        """Values of variables of one type, by name."""
        return self.get(self.kind_of(names[0]), self.fmu.vr(*names))

    def set_named(self, **values) -> int:
        """Set variables by name (names with dots through a dict: set_named(**{"model.fidelity": 2})),
        one call per variable; the worst status."""
        worst = OK
        for name, value in values.items():
            worst = max(worst, self.set(self.kind_of(name), self.fmu.vr(name), [value]))
        return worst

    def snapshot(self) -> tuple[int, dict[str, str]]:
        """Every variable's value (Reals as float.hex, so that equal means bit-identical), one get per type;
        the worst status."""
        worst, values = OK, {}
        for kind in ("Real", "Integer", "Boolean", "String"):
            names = self.fmu.names_of_type(kind)
            if not names:
                continue
            status, got = self.get(kind, self.fmu.vr(*names))
            worst = max(worst, status)
            for name, value in zip(names, got, strict=True):
                values[name] = value.hex() if kind == "Real" else repr(value)
        return worst, values

    # ------------------------------------------------------------- derivatives
    def directional_derivative(self, unknown: list[int], known: list[int]) -> int:
        seed, out = _reals([1.0] * len(known)), _reals([0.0] * len(unknown))
        return self.f["fmi2GetDirectionalDerivative"](
            self.c, _vrs(unknown), len(unknown), _vrs(known), len(known), seed, out
        )

    def set_input_derivatives(self, vrs: list[int], value: float = 0.0, order: int = 1) -> int:
        """fmi2SetRealInputDerivatives of `order` of each of `vrs` to `value` (0: the run does not change)."""
        orders = (c_int * len(vrs))(*[order] * len(vrs))
        return self.f["fmi2SetRealInputDerivatives"](self.c, _vrs(vrs), len(vrs), orders, _reals([value] * len(vrs)))

    def get_output_derivatives(self, vrs: list[int], order: int = 1) -> tuple[int, list[float]]:
        """fmi2GetRealOutputDerivatives of `order` of each of `vrs`: the status and the values."""
        orders = (c_int * len(vrs))(*[order] * len(vrs))
        values = _reals([0.0] * len(vrs))
        status = self.f["fmi2GetRealOutputDerivatives"](self.c, _vrs(vrs), len(vrs), orders, values)
        return status, list(values)[: len(vrs)]

    # ------------------------------------------------------------------- status
    def status(self, kind: str, which: int, null: bool = False) -> tuple[int, object]:
        """fmi2Get<kind>Status (kind "" for fmi2GetStatus): the status and the value read (NULL value
        pointer with null=True)."""
        ctype = {"": c_int, "Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}[kind]
        value = ctype()
        status = self.f[f"fmi2Get{kind}Status"](self.c, which, None if null else byref(value))
        return status, value.value

    # -------------------------------------------------------------- FMU states
    def get_state(self, into: c_void_p | None = None) -> tuple[int, c_void_p]:
        """fmi2GetFMUstate into `into` (a new handle if None): the status and the handle."""
        state = c_void_p() if into is None else into
        return self.f["fmi2GetFMUstate"](self.c, byref(state)), state

    def set_state(self, state: c_void_p | int | None) -> int:
        return self.f["fmi2SetFMUstate"](self.c, state if isinstance(state, c_void_p) else c_void_p(state))

    def free_state(self, state: c_void_p) -> int:
        """fmi2FreeFMUstate(c, &state): `state` reads NULL afterwards if the FMU freed it."""
        return self.f["fmi2FreeFMUstate"](self.c, byref(state))

    def free_state_at(self, address: int | None) -> int:
        """fmi2FreeFMUstate with `address` as the fmi2FMUstate* argument (a host that passes a state
        where its address is due, or NULL)."""
        return self.f["fmi2FreeFMUstate"](self.c, cast(c_void_p(address), POINTER(c_void_p)) if address else None)

    def state_size(self, state: c_void_p | int) -> tuple[int, int]:
        n = c_size_t(0)
        status = self.f["fmi2SerializedFMUstateSize"](
            self.c, state if isinstance(state, c_void_p) else c_void_p(state), byref(n)
        )
        return status, n.value

    def serialize(self, state: c_void_p | int, size: int, capacity: int | None = None) -> tuple[int, bytes]:
        """fmi2SerializeFMUstate into a buffer of `capacity` bytes (default `size`) filled with FILL, told
        its size is `size`: the status and the whole buffer afterwards."""
        capacity = size if capacity is None else capacity
        buffer = create_string_buffer(bytes([FILL]) * max(1, capacity), max(1, capacity))
        status = self.f["fmi2SerializeFMUstate"](
            self.c, state if isinstance(state, c_void_p) else c_void_p(state), buffer, size
        )
        return status, buffer.raw[:capacity]

    def serialized(self, state: c_void_p) -> bytes:
        """The state's bytes (asserting both calls answer fmi2OK)."""
        status, n = self.state_size(state)
        assert status == OK, (status, self.messages[-3:])
        status, data = self.serialize(state, n)
        assert status == OK, (status, self.messages[-3:])
        return data

    def deserialize(self, data: bytes, size: int | None = None, into: c_void_p | None = None) -> tuple[int, c_void_p]:
        """fmi2DeSerializeFMUstate of `data` (told its size is `size`, default len(data)) into `into`."""
        state = c_void_p() if into is None else into
        buffer = (c_char * max(1, len(data))).from_buffer_copy(data.ljust(1, b"\0"))
        status = self.f["fmi2DeSerializeFMUstate"](self.c, buffer, len(data) if size is None else size, byref(state))
        return status, state


def version(fmu: Fmu) -> tuple[str, str]:
    """fmi2GetTypesPlatform and fmi2GetVersion (no instance needed)."""
    return fmu.f["fmi2GetTypesPlatform"]().decode(), fmu.f["fmi2GetVersion"]().decode()
