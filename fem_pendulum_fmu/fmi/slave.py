"""The FMI 2.0 co-simulation slave: glue between the FMU's binary and a model, no physics.

Variables are registered from the template (interface.py), so the
modelDescription and the slave cannot drift. The FMU's binary (shim/) calls
the methods of pythonfmu's Fmi2Slave interface and turns any exception into
fmi2Error, but the slave still raises nothing a host can cause: refused input
is reported to the binary (fem_pendulum_report_error, through ctypes), which
makes that FMI call answer fmi2Error and logs the message; the state is left
unchanged. A step the model cannot complete answers fmi2Discard. The FMU's
entry script subclasses `PendulumSlave` (see femp_slave_entry.py).
"""

from __future__ import annotations

import functools
import io
import json
import logging
import math
import operator
import time
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, ScalarVariable, String

from ..physics.fidelity import PendulumModel, StepFailed, create
from ..physics.protocol import ModelState, Outputs
from ..physics.scene import Scene
from . import interface as fmi_interface
from .vtk_output import VtkSeries

LOG = logging.getLogger("fem_pendulum_fmu")

# FMI output name -> models.base.Outputs field
OUTPUT_FIELDS = {
    "theta": "theta",
    "omega": "omega",
    "gap": "gap",
    "contact_force": "contact_force",
    "energy.kinetic": "kinetic",
    "energy.potential": "potential",
    "energy.strain": "strain",
    "energy.contact": "contact",
    "energy.total": "total",
    "energy.torque_work": "torque_work",
    "stress.von_mises_max": "von_mises_max",
    "solver.substeps": "substeps",
    "gap_min": "min_gap",
    "contact_force_max": "contact_force_max",
    "contact_impulse": "contact_impulse",
}
# Integer aliases of enumerations for masters that cannot set enumerations (libcosim)
ENUM_ALIASES = {"wall.kind_index": "wall.kind", "model.fidelity_index": "model.fidelity"}
# parameters of the FMU's field output, not of the physics (scene() leaves them out)
OUTPUT_PARAMETERS = ("output.vtk_folder", "output.vtk_interval")
_PY_TYPES = {"Real": Real, "Integer": Integer, "Enumeration": Integer, "Boolean": Boolean, "String": String}
_TIME_TOL = 1e-9
_READER_CACHE = 64  # value-reference lists whose validation get_real / set_real remember, per instance


def _error_reporter(resources: str | None) -> tuple[int, Callable[[bytes], Any]] | None:
    """fem_pendulum_report_error of the FMU's binary (binaries/linux64/FemPendulum.so), if present, with
    the handle of the library opened to find it (the slave closes it in release()).

    The binary (shim/) turns the call during which the slave reports an error into
    fmi2Error and logs the message whether or not debug logging is on; without it
    (pythonfmu's binary: Windows) the message is only queued. Each instance looks it up
    for itself, at its first report: a table kept per resources folder grew by an entry
    and kept a deleted library loaded for every run of fmpy's simulate_fmu, which
    extracts the FMU into a new folder each time."""
    if not resources:
        return None
    import ctypes
    from pathlib import Path

    binary = Path(resources).parent / "binaries" / "linux64" / "FemPendulum.so"
    if not binary.is_file():
        return None
    try:
        library = ctypes.CDLL(str(binary))
    except OSError:
        return None
    try:
        report = library.fem_pendulum_report_error
    except AttributeError:  # another binary (pythonfmu's alone): nothing to report to
        _close_library(library._handle)
        return None
    report.argtypes = [ctypes.c_char_p]
    return library._handle, report


def _close_library(handle: int) -> None:
    """dlclose a library opened by ctypes (which never closes one itself); the host's own handle keeps it loaded."""
    import _ctypes

    _ctypes.dlclose(handle)


class _FmiLogHandler(logging.Handler):
    """Forwards the package's Python log records to one instance's FMI logger.

    It holds the instance weakly: the instance holds its handler, and a cycle would leave a freed
    instance (and its model) to the garbage collector instead of freeing it at once."""

    def __init__(self, slave: PendulumSlave) -> None:
        super().__init__(logging.DEBUG)
        self.slave = weakref.ref(slave)

    def emit(self, record: logging.LogRecord) -> None:
        slave = self.slave()
        if slave is None:
            return
        if record.levelno >= logging.ERROR:
            status = Fmi2Status.error
        elif record.levelno >= logging.WARNING:
            status = Fmi2Status.warning
        else:
            status = Fmi2Status.ok
        slave.log(record.getMessage(), status, None if status != Fmi2Status.ok else "logAll")


class _LogRouter(logging.Handler):
    """The package logger's one handler: forwards each record to the instance whose call is running
    (the innermost, `active[-1]`), so that a doStep only pushes and pops itself instead of adding and
    removing a handler (half a microsecond less per step). Outside calls it does what the logging
    module does for a logger without handlers: warnings and worse go to logging.lastResort, unless
    some other handler up the hierarchy takes them."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.active: list[PendulumSlave] = []

    def emit(self, record: logging.LogRecord) -> None:
        if self.active:
            self.active[-1]._handler.emit(record)
        elif not self._others_handle() and logging.lastResort is not None:
            if record.levelno >= logging.lastResort.level:
                logging.lastResort.handle(record)

    def _others_handle(self) -> bool:
        logger: logging.Logger | None = LOG
        while logger is not None:
            if any(h is not self for h in logger.handlers):
                return True
            logger = logger.parent if logger.propagate else None
        return False


_ROUTER = _LogRouter()


class PendulumSlave(Fmi2Slave):
    author = "fem_pendulum_fmu developers"
    description = "Nonlinear FE pendulum hitting a wall"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.interface = fmi_interface.load(self.resources)
        self.values: dict[str, Any] = {}
        self.torque = 0.0
        self.model: PendulumModel | None = None
        self.outputs: Outputs | None = None
        self.init_error: str | None = None
        self.broken: str | None = None  # set when the model raised something other than StepFailed
        self.initialised = False  # a model is built (at exitInitializationMode, or from a restored state)
        self.stepping = False  # exitInitializationMode succeeded: parameters are fixed from now on
        self.terminated = False
        self.time = self.interface.start_time
        self.init_seconds = math.nan
        self.vtk: VtkSeries | None = None  # the field output, when output.vtk_folder is set
        self._handler = _FmiLogHandler(self)
        # value-reference lists already validated, for the per-step calls: get_real of outputs reads
        # them with one attrgetter (None: not all outputs, pythonfmu's loop), set_real skips re-checking
        self._real_readers: dict[tuple[int, ...], tuple[Callable[[Outputs], Any] | None, bool]] = {}
        self._real_setters: dict[tuple[int, ...], tuple[Callable[[Any], None], ...]] = {}
        for var in self.interface.variables:
            self._register(var)

    # ------------------------------------------------------------ registration
    def _register(self, var: fmi_interface.Variable) -> None:
        name = var.name
        getter: Callable[[], Any]
        setter: Callable[[Any], None] | None
        # the accessors reach this instance through a weak proxy: bound methods, which self.vars keeps,
        # would make cycles that leave a freed instance and its model to the garbage collector's full
        # pass (tests/test_fmu_memory.py); the proxy costs the torque's setter 45 ns a call
        me: Any = weakref.proxy(self)  # typeshed calls it a CallableProxyType, not a PendulumSlave
        kind = type(self)
        if var.causality == "parameter":
            self.values[name] = var.start
            getter = functools.partial(kind._get_parameter, me, name)
            setter = functools.partial(kind._set_parameter, me, name)
        elif var.causality == "input":
            self.torque = float(var.start or 0.0)
            getter = functools.partial(kind._get_torque, me)
            setter = functools.partial(kind._set_torque, me)
        else:
            getter = functools.partial(kind._get_output, me, OUTPUT_FIELDS[name])
            setter = None
        cls = _PY_TYPES[var.type]
        kwargs = dict(
            causality=Fmi2Causality[var.causality],
            variability=Fmi2Variability[var.variability],
            description=var.description,
            getter=getter,
            setter=setter,
        )
        if var.causality == "parameter":
            kwargs["initial"] = Fmi2Initial.exact
        if var.start is not None:
            kwargs["start"] = var.start
        self.register_variable(cls(name, **kwargs), nested=False)
        registered = list(self.vars.keys())[-1]
        if registered != var.value_reference:
            raise RuntimeError(f"value reference of {name} is {registered}, the template says {var.value_reference}")

    # ------------------------------------------------------- getters and setters
    def _get_parameter(self, name: str) -> Any:
        return self.values[name]  # looked up at each call: restoring an FMU state replaces self.values

    def _get_torque(self) -> float:
        return self.torque

    def _get_output(self, field: str) -> Any:
        return getattr(self.outputs, field) if self.outputs is not None else 0

    def _set_parameter(self, name: str, value: Any) -> None:
        if self.stepping or (self.initialised and value != self.values[name]):
            self._error(
                f"parameter {name} cannot be set after initialisation (value {value!r} ignored; "
                f"it stays {self.values[name]!r})"
            )
            return
        self.values[name] = value

    def _set_torque(self, value: float) -> None:
        self.torque = float(value)  # checked at doStep, which then answers fmi2Error and keeps the state

    def _error(self, msg: str) -> None:
        """Make the FMI call in progress answer fmi2Error and log `msg` with status error (see shim/)."""
        reporter = self._reporter
        if reporter is not None:
            reporter[1](msg.encode("utf-8", "replace"))
        else:
            self.log(msg, Fmi2Status.error)

    @functools.cached_property
    def _reporter(self) -> tuple[int, Callable[[bytes], Any]] | None:
        """The binary's error report and its library handle (_error_reporter), looked up at the first report."""
        return _error_reporter(self.resources)

    # ------------------------------------------------- guarded variable access
    # The FMU's binary checks every value reference, type and causality before calling these
    # (shim/variables.c); without it (pythonfmu's binary: Windows) pythonfmu would raise (fmi2Fatal)
    # on an unknown value reference, a variable of another type or setting an output, so these
    # answer fmi2Error with a log message instead and change nothing.
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
        outputs = self.outputs
        if outputs is None:
            return [0.0] * len(vrs)
        return [float(read(outputs))] if single else list(map(float, read(outputs)))

    def _remember_reader(self, key: tuple[int, ...]) -> tuple[Callable[[Outputs], Any] | None, bool]:
        """Remember and return the reader of a validated list of Real value references: an attrgetter
        of the Outputs fields when all are outputs (what a master reads every step), else None; and
        whether the list has one reference."""
        if len(self._real_readers) >= _READER_CACHE:
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
            if len(self._real_setters) >= _READER_CACHE:
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

    # -------------------------------------------------------------- life cycle
    def scene(self, parameters: dict[str, Any] | None = None) -> Scene:
        """The scene the parameter values (this instance's, or `parameters`) describe, enumerations by item name."""
        parameters = self.values if parameters is None else parameters
        values = {}
        for var in self.interface.of_causality("parameter"):
            if var.name in ENUM_ALIASES or var.name in OUTPUT_PARAMETERS:
                continue
            value = parameters[var.name]
            if var.items:
                value = var.item_name(value)
            elif var.type == "Real":
                value = float(value)
            elif var.type == "Integer":
                value = int(value)
            elif var.type == "Boolean":
                value = bool(value)
            values[var.name] = value
        for alias, target in ENUM_ALIASES.items():
            index = int(parameters[alias])
            if index != 0:
                values[target] = self.interface.by_name(target).item_name(index)
        return Scene().with_values(values)

    def setup_experiment(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        if self.model is None:  # an instance started from an FMU state keeps the state's time
            self.time = float(start_time)

    @property
    def communication_time(self) -> float:
        """The FMU's time, which the binary (shim/) reads after the calls that may set it."""
        return self.model.time if self.model is not None else self.time

    def exit_initialization_mode(self) -> None:
        self.init_error = None  # whatever an earlier, refused Exit found
        if self.model is not None:  # started from an FMU state (fmi2SetFMUstate after fmi2Instantiate)
            self.stepping = True
            return
        t0 = time.perf_counter()
        with self._logging():
            try:
                model = create(self.scene())
            except (ValueError, KeyError) as exc:
                self.init_error = f"invalid parameters: {exc}"
                self._error(self.init_error + " (correct them and call fmi2ExitInitializationMode again)")
                return
            model.time = self.time
            self.model, self.outputs, self.initialised = model, model.outputs(), True
            self._start_field_output()
            if self.init_error is not None:  # the field output's folder: back to before the call
                self.model, self.outputs, self.initialised = None, None, False
                return
            self.stepping = True
            self.init_seconds = time.perf_counter() - t0
            LOG.debug("initialised %s in %.3f s", type(model).__name__, self.init_seconds)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.init_error is not None:
            self._error(f"doStep refused: {self.init_error}")
            return False
        model, torque = self.model, self.torque  # locals: this runs at every step
        if model is None or self.terminated:
            self._error("doStep refused: the FMU is " + ("terminated" if self.terminated else "not initialised"))
            return False
        if self.broken is not None:
            self._error(f"doStep refused: {self.broken}; restore an FMU state to go on")
            return False
        if not (math.isfinite(step_size) and step_size > 0):
            self._error(f"doStep refused: communication step size {step_size!r} must be a finite number > 0")
            return False
        mismatch = abs(current_time - model.time)  # the cheap test first: the tolerance is >= _TIME_TOL
        if mismatch > _TIME_TOL and mismatch > _TIME_TOL * max(1.0, abs(current_time)):
            self._error(
                f"doStep refused: communication point {current_time!r} does not match the FMU's time {model.time!r}"
            )
            return False
        if not math.isfinite(torque):
            self._error(f"doStep refused: torque = {torque!r} is not allowed, it must be a finite number (N.m)")
            return False
        self._route_log()  # as _logging(), without a generator's cost at every step
        try:
            self.outputs = model.advance(current_time + step_size, torque)
            if self.vtk is not None and self.vtk.due(model.time):
                self._write_frame()
        except StepFailed as exc:
            self.log(f"doStep discarded at t = {current_time!r}, state kept: {exc}", Fmi2Status.discard)
            return False
        except Exception as exc:  # keep the host alive whatever happens in the model
            # unlike StepFailed, nothing promises the model's state is intact: refuse to go on
            # from it until the master restores an FMU state
            self.broken = f"the model failed at t = {current_time!r} ({type(exc).__name__}: {exc})"
            self._error(f"doStep failed: {self.broken}; restore an FMU state to go on")
            return False
        finally:
            _ROUTER.active.pop()
        return True

    # ------------------------------------------------------------ field output
    def _start_field_output(self) -> None:
        """Create the field output's folder and write the frame at the start time, if output.vtk_folder is
        set. A folder that cannot be created or written (or a bad interval) is an error of
        exitInitializationMode with a message; doStep then refuses, as for invalid parameters."""
        folder = str(self.values["output.vtk_folder"]).strip()
        if not folder or self.model is None:
            return
        try:
            self.vtk = VtkSeries(folder, float(self.values["output.vtk_interval"]))
            self.vtk.write(self.model.time, self.model.fields())
        except (OSError, ValueError) as exc:
            self.vtk = None
            self.init_error = f"output.vtk_folder = {folder!r}: cannot write the field output there ({exc})"
            if isinstance(exc, ValueError):
                self.init_error = f"invalid parameters: {exc}"
            self._error(self.init_error)

    def _write_frame(self) -> None:
        """Write a frame of the field output; a failure (disk full, folder removed) is logged as a warning
        and ends the field output, the simulation goes on."""
        if self.vtk is None or self.model is None:
            return
        try:
            self.vtk.write(self.model.time, self.model.fields())
        except Exception as exc:  # the host and the simulation outlive a failed frame
            self.log(
                f"field output stopped at t = {self.model.time!r}: cannot write to {str(self.vtk.folder)!r} "
                f"({type(exc).__name__}: {exc})",
                Fmi2Status.warning,
            )
            self.vtk = None

    def terminate(self) -> None:
        self.terminated = True

    @contextmanager
    def _logging(self) -> Iterator[None]:
        """Route the package's log records to this instance's FMI logger while it runs the model."""
        self._route_log()
        try:
            yield
        finally:
            _ROUTER.active.pop()

    def _route_log(self) -> None:
        """Route the package's records to this instance (the caller pops it from _ROUTER.active)."""
        if _ROUTER not in LOG.handlers:
            LOG.addHandler(_ROUTER)
        if LOG.level == logging.NOTSET or LOG.level > logging.DEBUG:
            LOG.setLevel(logging.DEBUG)
        _ROUTER.active.append(self)

    # ---------------------------------------------------------------- FMU state
    def _get_fmu_state(self) -> dict[str, Any]:
        return {
            "model": self.model.get_state() if self.model is not None else None,
            "torque": self.torque,
            "values": dict(self.values),
            "initialised": self.initialised,
            "time": self.communication_time,  # a state taken before initialisation brings its start time
        }

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        """Restore a state of this FMU; anything else is refused (fmi2Error, state unchanged), never
        raised (pythonfmu's binary, on Windows, makes an exception fmi2Fatal). Into an initialised
        instance only a state taken with the same parameters; into one not yet initialised any state
        of this FMU, whose parameters then build the model (the initialisation calls that follow keep
        it)."""
        problem = self._state_mismatch(state)
        model = self.model
        if problem is None and state["model"] is not None:
            try:
                if model is None:
                    with self._logging():
                        model = create(self.scene(state["values"]))
                model.set_state(state["model"].copy())
            except Exception as exc:  # invalid parameters, a state of another fidelity or mesh
                problem = f"{type(exc).__name__}: {exc}"
        if problem is not None:
            self._error(f"FMU state not restored, the state is unchanged: {problem}")
            return
        if self.model is None:
            self.values = dict(state["values"])
        if state["model"] is not None and model is not None:  # model is None only if state["model"] is
            if self.model is None:
                self.initialised, self.time = True, model.time
            self.model, self.outputs, self.broken = model, model.outputs(), None
        if state["model"] is None and self.model is None:
            self.time = float(state["time"])
        self.torque = float(state["torque"])

    def _state_mismatch(self, state: dict[str, Any]) -> str | None:
        """Why `state` cannot be restored in this instance, or None."""
        if set(state["values"]) != set(self.values):
            return "it is not a state of this FMU (its parameters have other names)"
        if state["model"] is None and self.model is not None:
            return "it was taken before initialisation and this instance is initialised"
        if self.model is None:
            return None
        for name, value in state["values"].items():
            if self.values.get(name) != value:
                return f"it was taken with parameter {name} = {value!r}, this instance has {self.values.get(name)!r}"
        return None

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any]) -> bytes:
        head = {key: state[key] for key in ("torque", "values", "initialised", "time")}
        model = state["model"].to_bytes() if state["model"] is not None else b""
        buf = io.BytesIO()
        np.savez(
            buf,
            head=np.frombuffer(json.dumps(head).encode(), dtype=np.uint8),
            model=np.frombuffer(model, dtype=np.uint8),
        )
        return buf.getvalue()

    def _fmu_state_from_bytes(self, data: bytes) -> dict[str, Any] | None:
        """The state the bytes hold, checked against this instance (the FMU's binary has already checked
        its own header: format, version, GUID); None after reporting why they are refused."""
        try:
            with np.load(io.BytesIO(bytes(data)), allow_pickle=False) as npz:
                head = json.loads(npz["head"].tobytes().decode())
                model = npz["model"].tobytes()
            head["model"] = ModelState.from_bytes(model) if model else None
            problem = _state_shape_problem(head) or self._state_mismatch(head)
        except Exception as exc:
            problem = f"the bytes are not a serialised state of this FMU ({type(exc).__name__}: {exc})"
        if problem is not None:
            self._error(f"fmi2DeSerializeFMUstate refused, nothing was changed: {problem}")
            return None
        return head

    # ------------------------------------------------------------------ release
    def release(self) -> None:
        """Let go at once of what this instance holds: the model (its NGSolve mesh, spaces, matrices and
        factorisations), its outputs, the field output, the remembered value-reference lists, and the
        library handle of the binary's error report. The FMU's binary calls this at fmi2FreeInstance and
        fmi2Reset, then drops the instance; the model goes even if something else still holds the
        instance (tests/test_fmu_memory.py). Afterwards doStep refuses, as before initialisation. Raises
        nothing."""
        self.model = None
        self.outputs = None
        self.vtk = None
        self._real_readers.clear()
        self._real_setters.clear()
        reporter = self.__dict__.pop("_reporter", None)
        if reporter is not None:
            try:
                _close_library(reporter[0])
            except OSError as exc:  # dlclose refused: the handle stays open, nothing else is lost
                LOG.debug("release: the binary's library handle was not closed (%s)", exc)


def _state_shape_problem(head: Any) -> str | None:
    """Why a decoded state head is not one this slave writes (keys and types), or None."""
    if not isinstance(head, dict) or set(head) != {"torque", "values", "initialised", "time", "model"}:
        return "its contents are not those of a state of this FMU"
    if not isinstance(head["values"], dict) or not all(isinstance(head[k], (int, float)) for k in ("torque", "time")):
        return "its parameter values, torque or time are malformed"
    return None
