"""Entry script of the PidController FMU: self-contained (unique module name, no package import),
so that it never shadows the pendulum FMU's bundled package in a shared interpreter.

The controller samples its error e = setpoint - measurement at each doStep's communication point t
and answers the torque demand for the step that begins there (a controller-first master applies it
over the plant's next doStep):

    u = Kp e(t) + Ki I(t + h) + Kd e'(t),   saturated at +-u_max, the integral held while saturated.

With input derivatives (fmi2SetRealInputDerivatives, orders 1 and 2, cleared by the step) the inputs
are polynomials over the step: e'(t) is theirs and I grows by the polynomial's exact integral.
Without, the inputs are held over the step (I grows by e(t) h) and e'(t) is the backward difference
of the last two samples over the time between them, the previous step's size; a previous step
shorter than MIN_SAMPLE_INTERVAL (a master's round-off remainder) keeps the last estimate, so no
vanishing step can saturate the demand. fmi2GetRealOutputDerivatives of u at t: u' = Kp e' + Ki e +
Kd e'', u'' = Kp e'' + Ki e' (0 at the output's limit, no Ki part while the integral holds). FMU
states (get, set, serialise) carry the controller, its inputs and their derivatives: a rollback
continues bit-identically.
"""

import json
import math
from dataclasses import asdict, dataclass

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability
from pythonfmu.enums import Fmi2Initial
from pythonfmu.variables import Real

PARAMETERS = ("Kp", "Ki", "Kd", "u_max")
DEFAULTS = (10.0, 4.0, 0.15, 15.0)
INPUTS = ("setpoint", "measurement")
MIN_SAMPLE_INTERVAL = 1e-6  # s: a backward difference over a shorter time is round-off, not a rate
STATE_FORMAT = "fem_pendulum_fmu.pid_state/1"


@dataclass(frozen=True)
class Error:
    """The error over a step: e(s) = value + rate s + curvature s^2 / 2, s from the step's start;
    `known` when the master gave the inputs' derivatives (else rate and curvature are 0: held)."""

    value: float
    rate: float = 0.0
    curvature: float = 0.0
    known: bool = False

    def integral(self, h: float) -> float:
        """The exact integral of e over [0, h]."""
        return self.value * h + self.rate * h * h / 2.0 + self.curvature * h * h * h / 6.0


@dataclass
class Pid:
    kp: float = 10.0
    ki: float = 4.0
    kd: float = 0.15
    u_max: float = 15.0
    integral: float = 0.0
    last_error: float | None = None
    last_step: float = 0.0  # the size of the step that began at last_error's sample (s)
    error_rate: float = 0.0  # e' of the derivative term at the last sample
    u: float = 0.0
    u_rate: float = 0.0
    u_curvature: float = 0.0

    def update(self, setpoint: float, measurement: float, dt: float, rates: tuple | None = None) -> float:
        """The demand for a step of length dt from the inputs at its start; `rates`: their first and second
        derivatives ((setpoint', setpoint''), (measurement', measurement'')), None: held over the step."""
        if rates is None:
            return self.step(Error(setpoint - measurement), dt)
        (sp1, sp2), (m1, m2) = rates
        return self.step(Error(setpoint - measurement, sp1 - m1, sp2 - m2, known=True), dt)

    def step(self, error: Error, dt: float) -> float:
        """The demand for a step of length dt from the error over it; the integral stops growing while
        the output saturates."""
        rate = self._rate(error)
        candidate = self.integral + error.integral(dt)
        u = self.kp * error.value + self.ki * candidate + self.kd * rate
        frozen = abs(u) > self.u_max  # anti-windup: the integral holds
        if frozen:
            u = self.kp * error.value + self.ki * self.integral + self.kd * rate
        else:
            self.integral = candidate
        self.last_error, self.last_step, self.error_rate = error.value, dt, rate
        self.u = max(-self.u_max, min(self.u_max, u))
        curvature = error.curvature if error.known else 0.0
        ki = 0.0 if frozen else self.ki  # a held integral does not grow
        clamped = abs(u) > self.u_max  # at its limit the output stays there
        self.u_rate = 0.0 if clamped else self.kp * rate + ki * error.value + self.kd * curvature
        self.u_curvature = 0.0 if clamped else self.kp * curvature + ki * rate
        return self.u

    def _rate(self, error: Error) -> float:
        """e' at the sample: the inputs' own, else the backward difference over the previous step."""
        if error.known:
            return error.rate
        if self.last_error is None:
            return 0.0
        if self.last_step < MIN_SAMPLE_INTERVAL:
            return self.error_rate
        return (error.value - self.last_error) / self.last_step


@dataclass(frozen=True)
class PidState:
    """An FMU state of the controller: parameters, inputs, their derivatives, the controller (None before
    initialisation)."""

    values: dict
    inputs: dict
    rates: dict  # input name -> [first, second derivative]
    pid: dict | None
    time: float  # the communication time (before initialisation: the start time)

    def to_bytes(self) -> bytes:
        return json.dumps({"format": STATE_FORMAT, **asdict(self)}).encode()

    @staticmethod
    def from_bytes(data: bytes) -> "PidState":
        """The state to_bytes wrote; ValueError saying why the bytes are not one."""
        try:
            head = json.loads(bytes(data).decode())
            assert isinstance(head, dict) and head.pop("format") == STATE_FORMAT
            state = PidState(**head)
            assert set(state.values) == set(PARAMETERS) and set(state.inputs) == set(INPUTS)
            assert all(isinstance(v, (int, float)) for v in (*state.values.values(), *state.inputs.values()))
            assert set(state.rates) <= set(INPUTS) and all(len(r) == 2 for r in state.rates.values())
            assert isinstance(state.time, (int, float))
            if state.pid is not None:
                Pid(**state.pid)
        except Exception as exc:  # json, keys, types: all mean foreign or corrupt bytes
            raise ValueError(f"the bytes are not a serialised state of this PID controller ({exc!r})") from None
        return state

    def mismatch(self, values: dict, initialised: bool) -> str | None:
        """Why an instance with parameter `values`, initialised or not, cannot take this state, or None."""
        if not initialised:
            return None
        if self.pid is None:
            return "it was taken before initialisation and this instance is initialised"
        for name in PARAMETERS:
            if self.values[name] != values[name]:
                return f"it was taken with parameter {name} = {self.values[name]!r}, this instance has {values[name]!r}"
        return None


class PidController(Fmi2Slave):
    """PID controller: setpoint and measurement in, saturated torque demand u out."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)
        self.values = dict(zip(PARAMETERS, DEFAULTS, strict=True))
        self.inputs = dict.fromkeys(INPUTS, 0.0)
        self.rates: dict[str, list[float]] = {}
        self.pid: Pid | None = None
        self.time = 0.0
        for name in INPUTS:
            self.register_variable(Real(name, causality=Fmi2Causality.input, **self._access(self.inputs, name)))
        self.register_variable(Real("u", causality=Fmi2Causality.output, getter=self._u))
        for name in PARAMETERS:
            self.register_variable(
                Real(
                    name,
                    causality=Fmi2Causality.parameter,
                    variability=Fmi2Variability.fixed,
                    initial=Fmi2Initial.exact,
                    **self._access(self.values, name),
                )
            )

    @staticmethod
    def _access(table: dict, name: str) -> dict:
        def get() -> float:
            return table[name]

        def put(value: float) -> None:
            table[name] = float(value)

        return {"getter": get, "setter": put}

    def _u(self) -> float:
        return self.pid.u if self.pid is not None else 0.0

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        """Inputs always; a parameter only before the controller exists, or to the value it has (the
        binary refuses parameters in stepComplete). Refused whole, nothing changed (ValueError: fmi2Error)."""
        for vr, value in zip(vrs, values, strict=False):
            name = self.vars[vr].name
            if self.pid is not None and name in PARAMETERS and value != self.values[name]:
                raise ValueError(
                    f"parameter {name} cannot be set after initialisation (value {value!r} refused; it stays "
                    f"{self.values[name]!r}); nothing was changed"
                )
        super().set_real(vrs, values)

    def setup_experiment(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        if self.pid is None:  # an instance started from an FMU state keeps the state's time
            self.time = float(start_time)

    @property
    def communication_time(self) -> float:
        """The FMU's time, which the binary reads after the calls that may set it."""
        return self.time

    def exit_initialization_mode(self) -> None:
        if self.pid is None:  # else: restored from an FMU state, which brought its controller
            self.pid = Pid(*(self.values[name] for name in PARAMETERS))

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.pid is None or not step_size > 0:
            return False
        rates = tuple(self.rates.get(name, (0.0, 0.0)) for name in INPUTS) if self.rates else None
        self.pid.update(self.inputs["setpoint"], self.inputs["measurement"], step_size, rates)
        self.rates, self.time = {}, current_time + step_size
        return True

    # ----------------------------------------------------------- input and output derivatives
    def set_real_input_derivatives(self, vrs: list[int], orders: list[int], values: list[float]) -> None:
        """fmi2SetRealInputDerivatives of setpoint and measurement, orders 1 and 2 (checked by the binary)."""
        rates = {name: list(r) for name, r in self.rates.items()}
        for vr, order, value in zip(vrs, orders, values, strict=True):
            name = self.vars[vr].name
            if name not in INPUTS or order not in (1, 2) or not math.isfinite(value):
                raise ValueError(f"order {order!r} of {name} = {value!r}: inputs' orders 1 and 2, finite, only")
            rates.setdefault(name, [0.0, 0.0])[order - 1] = float(value)
        self.rates = rates

    def get_real_output_derivatives(self, vrs: list[int], orders: list[int]) -> list[float]:
        """u' and u'' at the last sample (0 before the first step)."""
        pid = self.pid
        out = []
        for vr, order in zip(vrs, orders, strict=True):
            if self.vars[vr].name != "u" or order not in (1, 2):
                raise ValueError(f"value reference {vr} order {order}: only u's orders 1 and 2 are given")
            out.append(0.0 if pid is None else (pid.u_rate if order == 1 else pid.u_curvature))
        return out

    # ---------------------------------------------------------------------------- FMU state
    def _get_fmu_state(self) -> PidState:
        pid = asdict(self.pid) if self.pid is not None else None
        rates = {name: list(r) for name, r in self.rates.items()}
        return PidState(dict(self.values), dict(self.inputs), rates, pid, self.time)

    def _set_fmu_state(self, state: PidState) -> None:
        problem = state.mismatch(self.values, self.pid is not None)
        if problem is not None:
            raise ValueError(f"FMU state not restored, the state is unchanged: {problem}")
        self.values.update(state.values)
        self.inputs.update(state.inputs)
        self.rates = {name: list(r) for name, r in state.rates.items()}
        if state.pid is not None:
            self.pid = Pid(**state.pid)
        self.time = float(state.time)

    @staticmethod
    def _fmu_state_to_bytes(state: PidState) -> bytes:
        return state.to_bytes()

    def _fmu_state_from_bytes(self, data: bytes) -> PidState:
        state = PidState.from_bytes(data)
        problem = state.mismatch(self.values, self.pid is not None)
        if problem is not None:
            raise ValueError(f"fmi2DeSerializeFMUstate refused, nothing was changed: {problem}")
        return state
