"""The FMI 2.0 co-simulation slave: glue between the FMU's binary and a model, no physics.

Variables are registered from the template (interface.py), so the
modelDescription and the slave cannot drift. The FMU's binary (shim/) calls
the methods of pythonfmu's Fmi2Slave interface and turns any exception into
fmi2Error, but the slave still raises nothing a host can cause: refused input
is reported to the binary (fmi_logging.ErrorReport), which makes that FMI call
answer fmi2Error and logs the message; the state is left unchanged. The model
checks doStep's torque and step (physics/protocol.py: a ValueError, state
unchanged), which the slave answers the same way; a step the model cannot
complete (StepFailed) answers fmi2Discard. The FMU's entry script subclasses
`PendulumSlave` (see femp_slave_entry.py).

Input derivatives of the torque (fmi2SetRealInputDerivatives) make the next doStep's torque a
polynomial (physics/torque.py) and are cleared by that doStep once it succeeds; output derivatives
(fmi2GetRealOutputDerivatives) are the model's (PendulumModel.output_derivatives), asked for once per
communication point and input. docs/reference/fmi2.md, "Input interpolation and output derivatives".
"""

from __future__ import annotations

import functools
import math
import time
import weakref
from collections.abc import Callable
from typing import Any

from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Status, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

from ..physics.fidelity import PendulumModel, StepFailed, create
from ..physics.protocol import NO_SHORTER_STEP, SUMMARY_OUTPUTS, OutputDerivatives, Outputs, StopAt
from ..physics.torque import Torque, TorqueProfile
from . import interface as fmi_interface
from .fmi_logging import LOG, FmiLogHandler, route_to, routed, unroute
from .fmi_names import FMI2_NAMES
from .fmu_state import FmuState
from .interface import OUTPUT_FIELDS, scene_from_values
from .variable_access import CheckedVariableAccess
from .vtk_output import VtkSeries

_PY_TYPES = {"Real": Real, "Integer": Integer, "Enumeration": Integer, "Boolean": Boolean, "String": String}
_TIME_TOL = 1e-9
NO_RATES = (0.0, 0.0)  # the torque's first and second time derivative when the master gave none


class PendulumSlave(CheckedVariableAccess):
    """The pendulum's slave: parameters and the torque in, the outputs of the model it builds out."""

    author = "fem_pendulum_fmu developers"
    description = "Nonlinear FE pendulum hitting a wall"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.interface = fmi_interface.load(self.resources)
        self.values: dict[str, Any] = {}
        self.torque = 0.0
        self.torque_rates = NO_RATES  # d/dt and d2/dt2 of the torque at the communication point, for the next doStep
        self._derivatives: tuple[tuple, OutputDerivatives] | None = None  # the last answer, and what it was for
        self.model: PendulumModel | None = None
        self.init_error: str | None = None
        self.broken: str | None = None  # set when the model raised something it does not promise
        # the last doStep was discarded and a shorter one from this state cannot succeed: the binary
        # answers fmi2Terminated = true, so that a master ends the run (or restores an earlier state)
        self.cannot_continue = False
        # (t, h, torque, its derivatives) of the last discarded doStep
        self._discarded: tuple[float, float, float, tuple[float, float]] | None = None
        self.initialised = False  # a model is built (at exitInitializationMode, or from a restored state)
        self.initialising = False  # in initializationMode: the outputs are those of the parameters set
        # the model the outputs read in initializationMode come from, and the parameter values it was built with
        self._preview: tuple[tuple, PendulumModel] | None = None
        self.stepping = False  # exitInitializationMode succeeded: parameters are fixed from now on
        self.terminated = False
        self.time = self.interface.start_time
        self.init_seconds = math.nan
        self.vtk: VtkSeries | None = None  # the field output, when output.vtk_folder is set
        # the log reaches this instance through a weak proxy, as the accessors do (_register)
        self._handler = FmiLogHandler(functools.partial(type(self).log, weakref.proxy(self)))
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
        self.register_variable(_PY_TYPES[var.type](name, **kwargs), nested=False)
        registered = list(self.vars.keys())[-1]
        if registered != var.value_reference:
            raise RuntimeError(f"value reference of {name} is {registered}, the template says {var.value_reference}")

    # ------------------------------------------------------- getters and setters
    def _get_parameter(self, name: str) -> Any:
        return self.values[name]  # looked up at each call: restoring an FMU state replaces self.values

    def _get_torque(self) -> float:
        return self.torque

    def _get_output(self, field: str) -> Any:
        outputs = self.outputs if self.outputs is not None else self.initial_outputs()
        return getattr(outputs, field) if outputs is not None else 0

    def _set_parameter(self, name: str, value: Any) -> None:
        if self.stepping or (self.initialised and value != self.values[name]):
            self._error(
                f"parameter {name} cannot be set after initialisation (value {value!r} ignored; "
                f"it stays {self.values[name]!r})"
            )
            return
        self.values[name] = value

    def _set_torque(self, value: float) -> None:
        self.torque = float(value)  # the model checks it at doStep, which then answers fmi2Error
        # its derivatives stay: a master may set them before or after the value (docs/reference/fmi2.md)

    # -------------------------------------------------------------- life cycle
    def enter_initialization_mode(self) -> None:
        self.initialising = True

    def initial_outputs(self) -> Outputs | None:
        """In initializationMode, before a model exists: the outputs at the start of the model the
        parameters set so far describe (the InitialUnknowns of the modelDescription), built at the first
        read and again after a parameter changed; exitInitializationMode takes that model. Invalid
        parameters: None after reporting them (the read answers fmi2Error)."""
        if not self.initialising or self.model is not None:
            return None
        key = tuple(sorted(self.values.items()))
        if self._preview is None or self._preview[0] != key:
            with routed(self._handler):
                try:
                    model = create(scene_from_values(self.values, self.interface))
                except (ValueError, KeyError) as exc:
                    self._error(f"the outputs in initializationMode need valid parameters: {exc}")
                    return None
            self._preview = (key, model)
        model = self._preview[1]
        model.time = self.time
        return model.outputs()

    def output_model(self) -> PendulumModel | None:
        """The model the outputs are read from: the running one, or in initializationMode the one the
        parameters set so far describe (initial_outputs builds it); None when there is none."""
        if self.model is not None:
            return self.model
        if self.initial_outputs() is None or self._preview is None:
            return None
        return self._preview[1]

    def setup_experiment(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        # an instance started from an FMU state keeps the state's time (reached through pythonfmu's binary only,
        # which has no state machine: the FMU's own is in stepComplete then, shim/state_machine.h)
        if self.model is None:
            self.time = float(start_time)

    @property
    def communication_time(self) -> float:
        """The FMU's time, which the binary (shim/) reads after the calls that may set it."""
        return self.model.time if self.model is not None else self.time

    def exit_initialization_mode(self) -> None:
        self.init_error = None  # whatever an earlier, refused Exit found
        if self.model is not None:  # started from an FMU state (as setup_experiment says)
            self.stepping, self.initialising = True, False
            return
        t0 = time.perf_counter()
        preview, self._preview = self._preview, None
        with routed(self._handler):
            try:
                if preview is not None and preview[0] == tuple(sorted(self.values.items())):
                    model = preview[1]  # built for the outputs read in initializationMode, never advanced
                else:
                    model = create(scene_from_values(self.values, self.interface))
            except (ValueError, KeyError) as exc:
                self.init_error = f"invalid parameters: {exc}"
                self._error(f"{self.init_error} (correct them and call {self.fmi.exit_initialization_mode} again)")
                return
            model.time = self.time
            self.model, self.outputs, self.initialised = model, model.outputs(), True
            self._start_field_output()
            if self.init_error is not None:  # the field output's folder: back to before the call
                self.model, self.outputs, self.initialised = None, None, False
                return
            self.stepping, self.initialising = True, False
            self.init_seconds = time.perf_counter() - t0
            LOG.debug("initialised %s in %.3f s", type(model).__name__, self.init_seconds)

    def _step_refusal(self, current_time: float) -> str | None:
        """Why a doStep from current_time is refused, or None. The binary checks the communication
        point too; the check here is for pythonfmu's binary (Windows). The model checks the rest."""
        if self.init_error is not None:
            return self.init_error
        if self.model is None or self.terminated:
            return "the FMU is " + ("terminated" if self.terminated else "not initialised")
        if self.broken is not None:
            return f"{self.broken}; restore an FMU state to go on"
        mismatch = abs(current_time - self.model.time)  # the cheap test first: the tolerance is >= _TIME_TOL
        if mismatch > _TIME_TOL and mismatch > _TIME_TOL * max(1.0, abs(current_time)):
            return f"communication point {current_time!r} does not match the FMU's time {self.model.time!r}"
        return None

    def do_step(self, current_time: float, step_size: float, stop: StopAt | None = None) -> bool:
        """The step from current_time; `stop` (the FMI 3.0 slave's, fmi/slave3.py) may end it early."""
        model, refusal = self.model, self._step_refusal(current_time)  # locals: this runs at every step
        if refusal is not None or model is None:
            self._error(f"doStep refused: {refusal}")
            return False
        route_to(self._handler)  # as routed(), without a generator's cost at every step
        self.cannot_continue = False
        try:
            t_end = current_time + step_size
            # the FMI 2.0 FMU calls advance as before stop existed
            self.outputs = (
                model.advance(t_end, self.step_torque())
                if stop is None
                else model.advance(t_end, self.step_torque(), stop)
            )
            self._discarded, self.torque_rates, self._derivatives = None, NO_RATES, None
            if self.vtk is not None and self.vtk.due(model.time):
                self._write_frame()
        except StepFailed as exc:
            self.log(self._discard(current_time, step_size, exc), Fmi2Status.discard)
            return False
        except ValueError as exc:  # a bad torque or step: the model promises its state is unchanged
            self._error(f"doStep refused: {exc}")
            return False
        except Exception as exc:  # keep the host alive whatever happens in the model
            # nothing promises the model's state is intact: refuse to go on until an FMU state is restored
            self.broken = f"the model failed at t = {current_time!r} ({type(exc).__name__}: {exc})"
            self._error(f"doStep failed: {self.broken}; restore an FMU state to go on")
            return False
        finally:
            unroute()
        return True

    def _discard(self, t: float, h: float, exc: StepFailed) -> str:
        """Set `cannot_continue` for a discarded doStep and say why it was discarded: true when no
        shorter step can help, or when the same step (time, size, torque) was just discarded: the model
        is deterministic, so a master that repeats it unchanged would repeat the Discard for ever."""
        step = (t, h, self.torque, self.torque_rates)
        repeated, self._discarded = self._discarded == step, step
        self.cannot_continue = repeated or not exc.shorter_step_helps
        advice, end = "", f"end the run ({self.fmi.terminated} is true)"
        if repeated:
            advice = f"; the same step was discarded before: {end}, or take a shorter one"
        elif self.cannot_continue:
            advice = f"; {NO_SHORTER_STEP}: {end}, or restore an earlier FMU state or change the input"
        return f"doStep discarded at t = {t!r}, state kept: {exc}{advice}"

    def terminate(self) -> None:
        self.terminated = True

    # ---------------------------------------------------- input and output derivatives
    def step_torque(self) -> Torque:
        """The torque of the next doStep: the input's value, a polynomial once derivatives are set."""
        if self.torque_rates == NO_RATES:
            return self.torque
        return TorqueProfile(self.torque, *self.torque_rates)

    def set_real_input_derivatives(self, vrs: list[int], orders: list[int], values: list[float]) -> None:
        """fmi2SetRealInputDerivatives of the torque, orders 1 and 2 (the binary checks the references,
        orders and values first; refused here too, for a caller without it)."""
        rates = list(self.torque_rates)
        for vr, order, value in zip(vrs, orders, values, strict=True):
            var = self.vars.get(vr)
            if var is None or var.causality != Fmi2Causality.input or order not in (1, 2) or not math.isfinite(value):
                what = "no variable" if var is None else var.name
                self._error(
                    f"{FMI2_NAMES.set_real_input_derivatives} refused: order {order!r} of value reference {vr} "
                    f"({what}) = {value!r}; only the torque's derivatives of order 1 and 2, finite, can be set"
                )
                return
            rates[order - 1] = float(value)
        self.torque_rates, self._derivatives = (rates[0], rates[1]), None

    def get_real_output_derivatives(self, vrs: list[int], orders: list[int]) -> list[float]:
        """fmi2GetRealOutputDerivatives: the model's derivatives of the continuous outputs at its time, with
        the torque as the next doStep would take it; a per-step summary has none (fmi2Error, saying why)."""
        fields: list[str] = []
        for vr in vrs:
            var = self.vars.get(vr)
            field = OUTPUT_FIELDS.get(var.name) if var is not None else None
            reason = "it is not an output" if field is None else SUMMARY_OUTPUTS.get(field)
            if field is None or reason is not None:
                name = var.name if var is not None else f"value reference {vr}"
                self._error(f"{self.fmi.get_output_derivatives} refused: {name} has no time derivative: {reason}")
                return [0.0] * len(vrs)
            fields.append(field)
        derivatives = self._output_derivatives()
        if derivatives is None:
            return [0.0] * len(vrs)
        return [derivatives.of(field, order) for field, order in zip(fields, orders, strict=True)]

    def _output_derivatives(self) -> OutputDerivatives | None:
        """The model's output derivatives for the current state and torque (remembered until either
        changes); None after reporting why there are none."""
        model = self.model
        if model is None or self.broken is not None:
            self._error(f"{self.fmi.get_output_derivatives} refused: {self.broken or 'the FMU has no model'}")
            return None
        key = (model.time, self.torque, self.torque_rates)
        if self._derivatives is not None and self._derivatives[0] == key:
            return self._derivatives[1]
        torque = TorqueProfile(self.torque, *self.torque_rates)
        if torque.problems():  # the derivatives are those under the torque the next doStep would take
            self._error(f"{self.fmi.get_output_derivatives} refused: {'; '.join(torque.problems())}")
            return None
        with routed(self._handler):
            try:
                found = model.output_derivatives(torque)
            except (StepFailed, ValueError) as exc:  # a probe step of the model could not be taken
                self._error(f"{self.fmi.get_output_derivatives} failed at t = {model.time!r}, state kept: {exc}")
                return None
        self._derivatives = (key, found)
        return found

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

    # ---------------------------------------------------------------- FMU state
    def _get_fmu_state(self) -> FmuState:
        model = self.model.get_state() if self.model is not None else None
        # a state taken before initialisation brings its start time
        return FmuState(
            model, self.torque, dict(self.values), self.initialised, self.communication_time, self.torque_rates
        )

    def _set_fmu_state(self, state: FmuState) -> None:
        """Restore a state of this FMU; anything else is refused (fmi2Error, state unchanged), never
        raised (pythonfmu's binary, on Windows, makes an exception fmi2Fatal). Into an instance not yet
        initialised, the state's parameters (replacing those set) build the model, and the instance steps on
        from it without initialisation (the binary puts it in stepComplete: shim/state_machine.h,
        FMU_STATE_RESTORES)."""
        problem = state.mismatch(self.values, self.model is not None)
        model = self.model
        if problem is None and state.model is not None:
            try:
                if model is None:
                    with routed(self._handler):
                        model = create(scene_from_values(state.values, self.interface))
                model.set_state(state.model.copy())
            except Exception as exc:  # invalid parameters, a state of another fidelity or mesh
                problem = f"{type(exc).__name__}: {exc}"
        if problem is not None:
            self._error(f"FMU state not restored, the state is unchanged: {problem}")
            return
        if self.model is None:
            self.values = dict(state.values)
        if state.model is not None and model is not None:  # model is None only if state.model is
            if self.model is None:  # initialised now, whatever an initialisation begun had found
                self.initialised, self.time = True, model.time
                self.initialising, self.init_error, self._preview = False, None, None
            self.model, self.outputs, self.broken, self.cannot_continue = model, model.outputs(), None, False
            self._discarded = None
        if state.model is None and self.model is None:
            self.time = state.time
        self.torque, self.torque_rates, self._derivatives = state.torque, state.torque_rates, None

    @staticmethod
    def _fmu_state_to_bytes(state: FmuState) -> bytes:
        return state.to_bytes()

    def _fmu_state_from_bytes(self, data: bytes) -> FmuState | None:
        """The state the bytes hold, checked against this instance (the FMU's binary has already checked
        its own header: format, version, GUID); None after reporting why they are refused."""
        try:
            state = FmuState.from_bytes(data)
        except ValueError as exc:
            problem: str | None = str(exc)
        else:
            problem = state.mismatch(self.values, self.model is not None)
        if problem is not None:
            self._error(f"{self.fmi.deserialize_fmu_state} refused, nothing was changed: {problem}")
            return None
        return state

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
        self._preview = None
        self.vtk = None
        self.forget_value_references()
