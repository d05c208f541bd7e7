"""A controller FMU or a Python function behind one shape: given what was measured at t, the
torque demanded over [t, t + step]."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from ..coupling import Rates, output_rates, set_input_rates
from ..failures import UsageError
from .connections import SETPOINT, Wiring, check_wiring, default_connections, parse_connection
from .hold import hold_order_of

if TYPE_CHECKING:
    from ..named_slave import NamedSlave


@dataclass(frozen=True, slots=True)
class Measurements:
    """What a controller sees at the communication point `time` (SI units): the pendulum's outputs
    there, the set-point there, and the torque the pendulum received over the step that ended there."""

    time: float
    theta: float  # rad, 0 hanging down, counter-clockwise positive; the wall is at theta = 0
    omega: float  # rad/s
    gap: float  # m, head to wall, negative in contact
    contact_force: float  # N
    setpoint: float  # rad
    torque: float  # N.m

    @property
    def error(self) -> float:
        """setpoint - theta (rad)."""
        return self.setpoint - self.theta


class Controller(Protocol):
    """The loop's view of a controller (loop.py)."""

    description: str
    hold: int  # the highest hold order it takes part in (hold.py); 0: its demand is held over a step

    def demand(
        self,
        m: Measurements,
        step: float,
        reading: Sequence[float],
        rates: Sequence[Rates] = (),
        setpoint: Sequence[float] = (),
    ) -> float:
        """The torque demanded over [m.time, m.time + step]; `reading` holds the pendulum outputs
        the loop read at m.time, in the order of `reads`, `rates` their time derivatives there and
        `setpoint` the set-point's (both empty with hold order 0)."""

    def demand_rates(self, order: int) -> Rates:
        """The time derivatives, orders 1 to `order`, of the demand the last `demand` gave."""

    def reads(self) -> tuple[str, ...]:
        """Pendulum outputs this controller needs beyond Measurements."""

    def close(self) -> None: ...


class FunctionController:
    """A Python callable `(t, measurements) -> torque` as a controller."""

    def __init__(self, law: Callable[[float, Measurements], float]) -> None:
        self.law = law
        self.description = getattr(law, "__qualname__", type(law).__name__)
        self.hold = 0  # a function gives a value, no derivatives

    def demand(
        self,
        m: Measurements,
        step: float,
        reading: Sequence[float],
        rates: Sequence[Rates] = (),
        setpoint: Sequence[float] = (),
    ) -> float:
        value = self.law(m.time, m)
        torque = float(value)
        if not math.isfinite(torque):
            raise ValueError(
                f"the controller {self.description} returned {value!r} at t = {m.time:.6g} s: "
                "it must return a finite torque (N.m)"
            )
        return torque

    def demand_rates(self, order: int) -> Rates:
        return [0.0] * order

    def reads(self) -> tuple[str, ...]:
        return ()

    def close(self) -> None:
        pass


class FmuController:
    """An FMI 2.0 co-simulation controller FMU, its inputs set from the wiring before each doStep and
    its torque output read after it (loop.py says why that order). `slave`: an instance of the FMU
    at `path` already initialised with `parameters`, to use instead of a new one (a sweep's worker
    reuses one, masters/sweep/loop_run.py)."""

    def __init__(
        self,
        path: Path,
        wiring: Wiring,
        parameters: Mapping[str, float | int | bool],
        slave: NamedSlave | None = None,
    ) -> None:
        from ..named_slave import NamedSlave

        self.slave = slave if slave is not None else NamedSlave(path, "controller", dict(parameters))
        self.description = path.name
        self.hold = hold_order_of(self.slave.md)
        self.wiring = wiring
        self._torque_vr = [self.slave.vr[wiring.torque_from]]
        self._vrs = [self.slave.vr[c.target.removeprefix("controller.")] for c in wiring.inputs]
        reads = wiring.pendulum_outputs()
        self._picks = [
            None if c.source == SETPOINT else reads.index(c.source.removeprefix("pendulum.")) for c in wiring.inputs
        ]

    def demand(
        self,
        m: Measurements,
        step: float,
        reading: Sequence[float],
        rates: Sequence[Rates] = (),
        setpoint: Sequence[float] = (),
    ) -> float:
        fmu = self.slave.fmu
        fmu.setReal(self._vrs, [m.setpoint if k is None else reading[k] for k in self._picks])
        if rates or setpoint:
            set_input_rates(fmu, self._vrs, [setpoint if k is None else rates[k] for k in self._picks])
        fmu.doStep(m.time, step)
        return fmu.getReal(self._torque_vr)[0]

    def demand_rates(self, order: int) -> Rates:
        return output_rates(self.slave.fmu, self._torque_vr, order)[0]

    def reads(self) -> tuple[str, ...]:
        return self.wiring.pendulum_outputs()

    def close(self) -> None:
        self.slave.close()


@dataclass(frozen=True)
class ControllerFmuSpec:
    """A controller FMU, how it is wired and its parameters' start values, checked (`controller_fmu`)."""

    path: Path
    wiring: Wiring
    parameters: dict[str, float | int | bool]
    hold: int = 0  # the highest hold order the FMU declares (hold.py)

    def open(self) -> FmuController:
        return FmuController(self.path, self.wiring, self.parameters)


def controller_fmu(
    path: Path, connect: Sequence[str] = (), parameters: Sequence[str] | Mapping[str, object] = ()
) -> ControllerFmuSpec:
    """Check a controller FMU, its --connect items and its --controller-set values against its
    modelDescription and the pendulum's interface: a ControllerFmuSpec, or UsageError."""
    from fmpy import read_model_description

    from ...fmi import interface

    try:
        md = read_model_description(str(path))
    except Exception as exc:  # fmpy raises many kinds for a file that is not an FMU
        raise UsageError(f"--controller {str(path)!r} is not an FMU fmpy can read ({exc})") from None
    if md.fmiVersion != "2.0" or md.coSimulation is None:
        raise UsageError(
            f"--controller {str(path)!r} is FMI {md.fmiVersion}: the loop takes FMI 2.0 co-simulation FMUs"
        )
    by_causality: dict[str, list[str]] = {}
    for v in md.modelVariables:
        if v.type == "Real" or v.causality == "parameter":
            by_causality.setdefault(v.causality, []).append(v.name)
    inputs, outputs = by_causality.get("input", []), by_causality.get("output", [])
    pendulum_outputs = [v.name for v in interface.load().of_causality("output")]
    wires = [parse_connection(c) for c in connect] or default_connections(inputs, outputs, pendulum_outputs)
    wiring = check_wiring(wires, inputs, outputs, pendulum_outputs)
    types = {v.name: v.type for v in md.modelVariables if v.causality == "parameter"}
    return ControllerFmuSpec(Path(path), wiring, parameter_values(parameters, types), hold_order_of(md))


def parameter_values(
    items: Sequence[str] | Mapping[str, object], types: Mapping[str, str], written: str = "--controller-set {}"
) -> dict:
    """--controller-set NAME=VALUE items (or a mapping) as typed start values of the controller's
    parameters, or UsageError naming the item and listing the parameters; `written` is how an
    error writes a parameter's name (a sweep's axis: "controller.{}")."""
    pairs = items.items() if isinstance(items, Mapping) else [_pair(item) for item in items]
    values: dict[str, float | int | bool] = {}
    for name, value in pairs:
        if name not in types:
            raise UsageError(
                f"{written.format(name)}: not a parameter of the controller "
                f"(parameters: {', '.join(sorted(types)) or 'none'})"
            )
        values[name] = _typed(name, value, types[name], written)
    return values


def _pair(item: str) -> tuple[str, str]:
    name, sep, text = item.partition("=")
    if not sep or not name.strip():
        raise UsageError(f"--controller-set {item!r}: expected NAME=VALUE, such as Kp=20")
    return name.strip(), text.strip()


def _typed(name: str, value: object, kind: str, written: str = "--controller-set {}") -> float | int | bool:
    """`value` as the controller parameter's type, or UsageError."""
    text = str(value).strip().lower()
    try:
        if kind == "Boolean":
            if text not in ("true", "false", "1", "0"):
                raise ValueError
            return text in ("true", "1")
        if kind in ("Integer", "Enumeration"):
            return int(text)
        number = float(text)
        if not math.isfinite(number):
            raise ValueError
        return number
    except ValueError:
        allowed = {"Boolean": "true or false", "Integer": "an integer", "Enumeration": "an item's number"}
        must = allowed.get(kind, "a finite number")  # no range check follows, as the pendulum's scene makes
        raise UsageError(f"{written.format(name)}={value}: {value!r} is not allowed: it must be {must}") from None
