"""Set-points (angles) and disturbances (torques at the hinge): from a line of text, a number, a CSV
file or a Python function, to one shape, a Signal.

    --setpoint 0.1 | 10deg | step:10deg | step:0.2,0.5 | sine:20deg,0.75 | ramp:5deg | setpoint.csv
    --disturbance 2 | step:1.5,0.3 | sine:0.5,2 | ramp:0.1 | torque.csv

- a number: the constant value;
- step:A[,T]: A from the time T (s, default 0) on, 0 before;
- sine:A,F: A sin(2 pi F t), F in Hz;
- ramp:R: R t from t = 0 on (R per s), 0 before;
- a CSV file with a header: `time` and a value column whose name gives the unit (`value` is the
  quantity's SI unit; angles also `value_rad`, `value_deg`; torques `value_Nm`, `value_N.m`);
  linear between rows, held at the first and last value outside them; times finite and strictly
  increasing, at least one row.

Angles are in radians unless the amplitude or rate ends in `deg` (`rad` may be written); torques in
N.m (`Nm` or `N.m` may be written). A Signal keeps its parameters in SI units and is called once per
loop step, signal(t) -> float, in plain math. Every bad input is a UsageError: one line naming the
option, the value and what is allowed.
"""

from __future__ import annotations

import bisect
import csv
import math
import numbers
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args

from ..failures import UsageError, finite_cell

Quantity = Literal["angle", "torque"]
Kind = Literal["constant", "step", "sine", "ramp", "table", "function"]
QUANTITIES: tuple[Quantity, ...] = get_args(Quantity)
KINDS: tuple[Kind, ...] = get_args(Kind)
FORMS = ("step", "sine", "ramp")

UNIT: dict[Quantity, str] = {"angle": "rad", "torque": "N.m"}
# the suffixes a number may carry, and the factor to SI ("" first: no suffix)
SUFFIXES: dict[Quantity, dict[str, float]] = {
    "angle": {"": 1.0, "rad": 1.0, "deg": math.pi / 180.0},
    "torque": {"": 1.0, "Nm": 1.0, "N.m": 1.0},
}
# the value columns of a CSV file, and the factor to SI
VALUE_COLUMNS: dict[Quantity, dict[str, float]] = {
    "angle": {"value": 1.0, "value_rad": 1.0, "value_deg": math.pi / 180.0},
    "torque": {"value": 1.0, "value_Nm": 1.0, "value_N.m": 1.0},
}
OPTION: dict[Quantity, str] = {"angle": "--setpoint", "torque": "--disturbance"}
ALLOWED: dict[Quantity, str] = {
    "angle": "a number, step:A[,T], sine:A,F, ramp:R (rad, or deg as in step:10deg) "
    "or a CSV file time,value (rad) or time,value_deg",
    "torque": "a number, step:A[,T], sine:A,F, ramp:R (N.m) or a CSV file time,value (N.m)",
}


@dataclass(frozen=True)
class Signal:
    """A set-point or disturbance: what it is (`kind` and its parameters, SI units) and its value at
    a time, `signal(t)`.

    Parameters
    ----------
    kind : "constant" (`value`), "step" (`amplitude` from `step_time` on, 0 before), "sine"
        (`amplitude` sin(2 pi `frequency` t)), "ramp" (`rate` t from t = 0 on, 0 before), "table"
        (linear in `times`, `values`, held outside them) or "function" (`function(t)`).
    quantity : "angle" (rad) or "torque" (N.m).
    value, amplitude : rad or N.m.  step_time : s.  frequency : Hz.  rate : rad/s or N.m/s.
    times, values : the table's rows (s; rad or N.m).
    function : a Python callable t -> value (SI units), for the "function" kind.
    source : the text or file the signal was read from ("" when built in code).
    """

    kind: Kind
    quantity: Quantity
    value: float = 0.0
    amplitude: float = 0.0
    step_time: float = 0.0
    frequency: float = 0.0
    rate: float = 0.0
    times: tuple[float, ...] = ()
    values: tuple[float, ...] = ()
    function: Callable[[float], float] | None = None
    source: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise UsageError(f"Signal kind {self.kind!r} is not allowed: choose one of {', '.join(KINDS)}")
        if self.quantity not in QUANTITIES:
            raise UsageError(f"Signal quantity {self.quantity!r} is not allowed: choose one of {', '.join(QUANTITIES)}")
        if self.kind == "table" and not (len(self.times) == len(self.values) >= 1):
            raise UsageError(f"Signal table: {len(self.times)} times and {len(self.values)} values; give as many, >= 1")
        if self.kind == "function" and not callable(self.function):
            raise UsageError(f"Signal function {self.function!r} is not callable")

    def __call__(self, t: float) -> float:
        """The value at time t (s), in rad or N.m."""
        kind = self.kind
        if kind == "sine":
            return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t)
        if kind == "step":
            return self.amplitude if t >= self.step_time else 0.0
        if kind == "constant":
            return self.value
        if kind == "ramp":
            return self.rate * t if t > 0.0 else 0.0
        if kind == "table":
            return _interpolate(self.times, self.values, t)
        return self._call_function(t)

    def rates(self, t: float, order: int) -> list[float]:
        """The signal's time derivatives of orders 1 to `order` just after t (rad/s, rad/s^2 or N.m/s,
        ...), for a loop that passes them on (hold.py): exact for the forms, a table's slope from t
        on; zeros for a step (it jumps, it does not move) and for a function (none is known)."""
        kind, rates = self.kind, [0.0] * order
        if kind == "sine" and order:
            w = 2.0 * math.pi * self.frequency
            rates[0] = self.amplitude * w * math.cos(w * t)
            if order > 1:
                rates[1] = -self.amplitude * w * w * math.sin(w * t)
        elif kind == "ramp" and order and t >= 0.0:
            rates[0] = self.rate
        elif kind == "table" and order:
            rates[0] = _slope(self.times, self.values, t)
        return rates

    def _call_function(self, t: float) -> float:
        """The user's function at t, checked to be a finite number (a NaN set-point would poison the run)."""
        assert self.function is not None
        value = self.function(t)
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = math.nan
        if not math.isfinite(number):
            name = OPTION[self.quantity].lstrip("-")
            said = f"{name} function {self.describe()!r} gave {value!r} at t = {t:g} s"
            raise UsageError(f"{said}; return a finite number ({self.unit})")
        return number

    @property
    def unit(self) -> str:
        """The SI unit of the values: rad or N.m."""
        return UNIT[self.quantity]

    def describe(self) -> str:
        """A short text for a plot's legend or the metrics' JSON, e.g. "step to 0.1745 rad (10 deg) at t = 0 s"."""
        if self.kind == "constant":
            return f"constant {self._amount(self.value)}"
        if self.kind == "step":
            return f"step to {self._amount(self.amplitude)} at t = {self.step_time:.4g} s"
        if self.kind == "sine":
            return f"sine {self._amount(self.amplitude)} at {self.frequency:.4g} Hz"
        if self.kind == "ramp":
            return f"ramp {self._amount(self.rate, '/s')}"
        if self.kind == "table":
            origin = f" from {self.source}" if self.source else ""
            return f"table of {len(self.times)} rows{origin}, t = {self.times[0]:.4g} to {self.times[-1]:.4g} s"
        return f"function {getattr(self.function, '__qualname__', repr(self.function))}"

    def _amount(self, number: float, per: str = "") -> str:
        """A number with its unit, and in degrees for an angle."""
        text = f"{number:.4g} {self.unit}{per}"
        return f"{text} ({math.degrees(number):.4g} deg{per})" if self.quantity == "angle" else text

    def as_dict(self) -> dict[str, Any]:
        """The signal's kind, quantity, unit, parameters (SI) and description, JSON-safe (a table gives
        its rows' count and source, not its rows)."""
        found: dict[str, Any] = {"kind": self.kind, "quantity": self.quantity, "unit": self.unit}
        parameters: dict[str, dict[str, Any]] = {
            "constant": {"value": self.value},
            "step": {"amplitude": self.amplitude, "step_time": self.step_time},
            "sine": {"amplitude": self.amplitude, "frequency": self.frequency},
            "ramp": {"rate": self.rate},
            "table": {"rows": len(self.times), "source": self.source},
            "function": {},
        }
        found.update(parameters[self.kind])
        found["description"] = self.describe()
        return found


def _interpolate(times: tuple[float, ...], values: tuple[float, ...], t: float) -> float:
    """Linear between rows, the first and last value outside them (bisect: a scalar, no numpy)."""
    i = bisect.bisect_right(times, t)
    if i == 0:
        return values[0]
    if i == len(times):
        return values[-1]
    t0, t1 = times[i - 1], times[i]
    v0 = values[i - 1]
    return v0 + (values[i] - v0) * (t - t0) / (t1 - t0)


def _slope(times: tuple[float, ...], values: tuple[float, ...], t: float) -> float:
    """The slope of the table's row interval that starts at or before t and ends after it (0 outside)."""
    i = bisect.bisect_right(times, t)
    if i == 0 or i == len(times):
        return 0.0
    return (values[i] - values[i - 1]) / (times[i] - times[i - 1])


def parse_signal(text: str, quantity: Quantity, name: str | None = None) -> Signal:
    """The signal a line of text describes (the module's docstring lists the forms).

    Parameters
    ----------
    text : a number, step:A[,T], sine:A,F, ramp:R or the path of a CSV file.
    quantity : "angle" (a set-point) or "torque" (a disturbance).
    name : how the value is named in an error, default "--setpoint" or "--disturbance".

    Raises UsageError naming `name`, the text and what is allowed.
    """
    _check_quantity(quantity)
    name = OPTION[quantity] if name is None else name
    stripped = text.strip()

    def fail(reason: str) -> UsageError:
        return UsageError(f"{name} {text!r}: {reason}; use {ALLOWED[quantity]}")

    if not stripped:
        raise fail("empty")
    constant = _number(stripped, SUFFIXES[quantity])
    if constant is not None:
        return Signal("constant", quantity, value=constant, source=stripped)
    head, colon, rest = stripped.partition(":")
    form = head.strip().lower()
    if colon and form.isalpha() and len(form) > 1 and not Path(stripped).is_file():  # "C:\..." is a path
        if form not in FORMS:
            raise fail(f"unknown form {head.strip()!r}")
        return _parse_form(form, rest, quantity, fail)
    path = Path(stripped)
    if not path.is_file():
        raise fail("not a finite number" if _is_float(stripped) else "not a number, a form or an existing CSV file")
    return read_signal_csv(path, quantity, name)


def _parse_form(form: str, rest: str, quantity: Quantity, fail: Callable[[str], UsageError]) -> Signal:
    """step:A[,T], sine:A,F or ramp:R, the text after the colon being `rest`."""
    arguments = [a.strip() for a in rest.split(",")]
    counts = {"step": (1, 2), "sine": (2, 2), "ramp": (1, 1)}
    usage = {"step": "step:A[,T]", "sine": "sine:A,F", "ramp": "ramp:R"}
    low, high = counts[form]
    if not low <= len(arguments) <= high:
        takes = f"{low} or {high} numbers" if low != high else f"{low} number" + ("s" if low > 1 else "")
        raise fail(f"{usage[form]} takes {takes}, not {len(arguments)}")
    amount = _number(arguments[0], SUFFIXES[quantity])
    if amount is None:
        what = "rate" if form == "ramp" else "amplitude"
        raise fail(f"the {what} {arguments[0]!r} is not a finite number in {_suffix_words(quantity)}")
    if form == "ramp":
        return Signal("ramp", quantity, rate=amount, source=f"ramp:{rest}")
    if form == "step":
        at = _number(arguments[1], {"": 1.0, "s": 1.0}) if len(arguments) == 2 else 0.0
        if at is None or at < 0.0:
            raise fail(f"the step time {arguments[1]!r} is not a finite number >= 0 (s)")
        return Signal("step", quantity, amplitude=amount, step_time=at, source=f"step:{rest}")
    frequency = _number(arguments[1], {"": 1.0, "Hz": 1.0})
    if frequency is None or frequency <= 0.0:
        raise fail(f"the frequency {arguments[1]!r} is not a finite number > 0 (Hz)")
    return Signal("sine", quantity, amplitude=amount, frequency=frequency, source=f"sine:{rest}")


def _number(text: str, suffixes: dict[str, float]) -> float | None:
    """A finite number with one of the suffixes (longest first), in SI; None if the text is not one."""
    for suffix in sorted(suffixes, key=len, reverse=True):
        if suffix and not text.endswith(suffix):
            continue
        body = text[: len(text) - len(suffix)].strip()
        try:
            number = float(body)
        except ValueError:
            continue
        return number * suffixes[suffix] if math.isfinite(number) else None
    return None


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _suffix_words(quantity: Quantity) -> str:
    return "rad, or deg as in 10deg" if quantity == "angle" else "N.m"


def _check_quantity(quantity: str) -> None:
    if quantity not in QUANTITIES:
        raise UsageError(f"quantity {quantity!r} is not allowed: choose one of {', '.join(QUANTITIES)}")


def read_signal_csv(path: Path, quantity: Quantity, name: str | None = None) -> Signal:
    """The table of a CSV file with a header `time,VALUE` (VALUE: VALUE_COLUMNS[quantity]; other
    columns ignored). UsageError naming the file and the row, column or rule it breaks."""
    _check_quantity(quantity)
    name = OPTION[quantity] if name is None else name
    columns = ", ".join(VALUE_COLUMNS[quantity])

    def fail(reason: str) -> UsageError:
        return UsageError(f"{name} {str(path)!r}: {reason}; give a header time,VALUE ({columns}) and rows")

    try:
        with open(path, newline="") as f:
            rows = [row for row in csv.reader(f) if any(cell.strip() for cell in row)]
    except (OSError, UnicodeDecodeError) as exc:
        raise fail(f"cannot read it ({getattr(exc, 'strerror', None) or type(exc).__name__})") from None
    header = [cell.strip() for cell in rows[0]] if rows else []
    value_names = [column for column in header if column in VALUE_COLUMNS[quantity]]
    if "time" not in header or len(value_names) != 1:
        found = ", ".join(header) or "none"
        raise fail(f"need the column time and one value column (found {found})")
    k_time, k_value = header.index("time"), header.index(value_names[0])
    times, values = [], []
    for number, row in enumerate(rows[1:], start=2):
        times.append(_cell(row, k_time, "time", number, fail))
        values.append(_cell(row, k_value, value_names[0], number, fail))
    if not times:
        raise fail("no rows below the header")
    for k in range(1, len(times)):
        if not times[k] > times[k - 1]:
            raise fail(f"the times must increase strictly (row {k + 2}: {times[k]:g} after {times[k - 1]:g})")
    factor = VALUE_COLUMNS[quantity][value_names[0]]
    return Signal("table", quantity, times=tuple(times), values=tuple(v * factor for v in values), source=str(path))


def _cell(row: list[str], k: int, column: str, number: int, fail: Callable[[str], UsageError]) -> float:
    """Cell k of data row `number` as a finite number, or the error naming where it is."""
    value, text = finite_cell(row, k)
    if value is None:
        raise fail(f"row {number}, column {column}: {text!r} is not a finite number")
    return value


def as_signal(obj: object, quantity: Quantity, name: str | None = None) -> Signal:
    """A Signal from what the Python API takes: a Signal (of this quantity), a number (constant), a
    text (parse_signal), a path (read_signal_csv) or a callable t -> value in SI units (kind
    "function", checked to give a finite number at every call).

    `name` names the value in errors, default "setpoint" or "disturbance"."""
    _check_quantity(quantity)
    name = OPTION[quantity].lstrip("-") if name is None else name
    if isinstance(obj, Signal):
        if obj.quantity != quantity:
            raise UsageError(f"{name}: a Signal of {obj.quantity} ({obj.describe()}); give one of {quantity}")
        return obj
    if isinstance(obj, numbers.Real) and not isinstance(obj, bool):
        value = float(obj)
        if not math.isfinite(value):
            raise UsageError(f"{name} {obj!r} is not a finite number; use {_api_allowed(quantity)}")
        return Signal("constant", quantity, value=value)
    if isinstance(obj, str):
        return parse_signal(obj, quantity, name)
    if isinstance(obj, os.PathLike):
        return read_signal_csv(Path(obj), quantity, name)
    if callable(obj):
        return Signal("function", quantity, function=obj)
    raise UsageError(f"{name} {obj!r} is not allowed; use {_api_allowed(quantity)}")


def _api_allowed(quantity: Quantity) -> str:
    unit = UNIT[quantity]
    return f"a number ({unit}), a Signal, a function t -> {unit}, a path or a text: {ALLOWED[quantity]}"
