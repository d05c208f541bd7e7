"""Set-points and disturbances from text, a CSV file, a number or a function (masters/control/signals.py):
every form's value at known times, and every bad input's one-line message naming the value."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from fem_pendulum_fmu.masters.control.signals import KINDS, Signal, as_signal, parse_signal, read_signal_csv
from fem_pendulum_fmu.masters.failures import UsageError

DEG = math.pi / 180.0


@pytest.mark.parametrize(
    "text, quantity, expected",
    [
        # (text, quantity, [(t, value in SI)]): constants, with and without a unit
        ("0.25", "angle", [(-1.0, 0.25), (0.0, 0.25), (7.0, 0.25)]),
        ("-3e-2", "angle", [(1.0, -0.03)]),
        ("10deg", "angle", [(0.5, 10 * DEG)]),
        ("0.5rad", "angle", [(0.5, 0.5)]),
        ("2", "torque", [(1.0, 2.0)]),
        ("2N.m", "torque", [(1.0, 2.0)]),
        ("-1.5Nm", "torque", [(1.0, -1.5)]),
        # steps: from t = 0, or from T on (0 before)
        ("step:0.3", "angle", [(-1e-9, 0.0), (0.0, 0.3), (5.0, 0.3)]),
        ("step:10deg", "angle", [(0.0, 10 * DEG)]),
        ("step:10deg,0.5", "angle", [(0.499, 0.0), (0.5, 10 * DEG), (2.0, 10 * DEG)]),
        ("step:-2,0.25s", "torque", [(0.2, 0.0), (0.25, -2.0)]),
        ("STEP : 1.5 , 1", "torque", [(0.9, 0.0), (1.0, 1.5)]),
        # sines: A sin(2 pi F t); at t = 1/(4F) the sine is at its crest
        ("sine:20deg,0.75", "angle", [(0.0, 0.0), (1 / 3, 20 * DEG), (1.0, -20 * DEG)]),
        ("sine:0.5,2Hz", "torque", [(0.125, 0.5), (0.25, 0.0)]),
        # ramps: R t from t = 0, 0 before
        ("ramp:5deg", "angle", [(-1.0, 0.0), (0.0, 0.0), (2.0, 10 * DEG)]),
        ("ramp:0.1", "torque", [(3.0, 0.3)]),
    ],
)
def test_every_form_has_its_value_at_known_times(text, quantity, expected):
    signal = parse_signal(text, quantity)
    for t, value in expected:
        got = signal(t)
        assert type(got) is float  # plain math, no numpy scalar
        assert got == pytest.approx(value, rel=1e-12, abs=1e-15), (text, t)


def test_each_form_keeps_its_parameters_in_si_and_describes_itself():
    step = parse_signal("step:10deg,0.5", "angle")
    assert (step.kind, step.amplitude, step.step_time, step.unit) == ("step", 10 * DEG, 0.5, "rad")
    assert step.describe() == "step to 0.1745 rad (10 deg) at t = 0.5 s"
    sine = parse_signal("sine:20deg,0.75", "angle")
    assert (sine.kind, sine.amplitude, sine.frequency) == ("sine", 20 * DEG, 0.75)
    assert sine.describe() == "sine 0.3491 rad (20 deg) at 0.75 Hz"
    ramp = parse_signal("ramp:5deg", "angle")
    assert (ramp.kind, ramp.rate) == ("ramp", 5 * DEG)
    assert ramp.describe() == "ramp 0.08727 rad/s (5 deg/s)"
    constant = parse_signal("2N.m", "torque")
    assert (constant.kind, constant.value, constant.unit) == ("constant", 2.0, "N.m")
    assert constant.describe() == "constant 2 N.m"
    for signal in (step, sine, ramp, constant):
        as_dict = json.loads(json.dumps(signal.as_dict(), allow_nan=False))
        assert as_dict["kind"] == signal.kind and as_dict["description"] == signal.describe()
    assert parse_signal("step:10deg,0.5", "angle") == step  # frozen, compared by value
    with pytest.raises(AttributeError):
        step.amplitude = 1.0  # type: ignore[misc]


def write(tmp_path: Path, text: str, name: str = "signal.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "column, quantity, factor",
    [
        ("value", "angle", 1.0),
        ("value_rad", "angle", 1.0),
        ("value_deg", "angle", DEG),
        ("value", "torque", 1.0),
        ("value_Nm", "torque", 1.0),
        ("value_N.m", "torque", 1.0),
    ],
)
def test_a_csv_table_is_linear_between_rows_and_held_outside(tmp_path, column, quantity, factor):
    # a header with spaces and an extra column, and a blank line: all taken as a user writes them
    path = write(tmp_path, f"time, {column} ,note\n0,0,a\n1,10,b\n\n3,30,c\n")
    signal = parse_signal(str(path), quantity)
    assert signal.kind == "table" and signal.source == str(path)
    assert signal.times == (0.0, 1.0, 3.0) and signal.values == pytest.approx((0.0, 10 * factor, 30 * factor))
    for t, value in [(-1.0, 0.0), (0.0, 0.0), (0.5, 5.0), (1.0, 10.0), (2.0, 20.0), (3.0, 30.0), (9.0, 30.0)]:
        assert signal(t) == pytest.approx(value * factor, rel=1e-12, abs=1e-15), t
    assert read_signal_csv(path, quantity) == signal
    assert as_signal(path, quantity) == signal  # a Path, from the Python API
    assert signal.describe() == f"table of 3 rows from {path}, t = 0 to 3 s"


def test_a_csv_table_of_one_row_is_a_constant(tmp_path):
    signal = parse_signal(str(write(tmp_path, "time,value\n0.5,0.2\n")), "angle")
    assert [signal(t) for t in (0.0, 0.5, 10.0)] == [0.2, 0.2, 0.2]


ANGLE_ALLOWED = (
    "use a number, step:A[,T], sine:A,F, ramp:R (rad, or deg as in step:10deg) "
    "or a CSV file time,value (rad) or time,value_deg"
)
TORQUE_ALLOWED = "use a number, step:A[,T], sine:A,F, ramp:R (N.m) or a CSV file time,value (N.m)"


@pytest.mark.parametrize(
    "text, quantity, message",
    [
        ("sin:1", "angle", f"--setpoint 'sin:1': unknown form 'sin'; {ANGLE_ALLOWED}"),
        ("", "angle", f"--setpoint '': empty; {ANGLE_ALLOWED}"),
        ("nan", "angle", f"--setpoint 'nan': not a finite number; {ANGLE_ALLOWED}"),
        ("inf", "torque", f"--disturbance 'inf': not a finite number; {TORQUE_ALLOWED}"),
        ("fast", "angle", f"--setpoint 'fast': not a number, a form or an existing CSV file; {ANGLE_ALLOWED}"),
        ("10deg", "torque", f"--disturbance '10deg': not a number, a form or an existing CSV file; {TORQUE_ALLOWED}"),
        ("step:10deg", "torque", "--disturbance 'step:10deg': the amplitude '10deg' is not a finite number in N.m; "),
        ("step:", "angle", "--setpoint 'step:': the amplitude '' is not a finite number in rad, or deg as in 10deg; "),
        ("step:x", "angle", "--setpoint 'step:x': the amplitude 'x' is not a finite number in rad, or deg"),
        ("step:1,2,3", "angle", "--setpoint 'step:1,2,3': step:A[,T] takes 1 or 2 numbers, not 3; "),
        ("step:1,-1", "angle", "--setpoint 'step:1,-1': the step time '-1' is not a finite number >= 0 (s); "),
        ("step:1,1deg", "angle", "--setpoint 'step:1,1deg': the step time '1deg' is not a finite number >= 0 (s)"),
        ("sine:1", "angle", "--setpoint 'sine:1': sine:A,F takes 2 numbers, not 1; "),
        ("sine:1,0", "angle", "--setpoint 'sine:1,0': the frequency '0' is not a finite number > 0 (Hz); "),
        ("sine:1,nan", "torque", "--disturbance 'sine:1,nan': the frequency 'nan' is not a finite number > 0 (Hz)"),
        ("sine:nan,1", "angle", "--setpoint 'sine:nan,1': the amplitude 'nan' is not a finite number in rad"),
        ("ramp:1,2", "angle", "--setpoint 'ramp:1,2': ramp:R takes 1 number, not 2; "),
        ("ramp:5deg/s", "angle", "--setpoint 'ramp:5deg/s': the rate '5deg/s' is not a finite number in rad"),
    ],
)
def test_every_bad_text_is_one_line_naming_the_option_the_value_and_what_is_allowed(text, quantity, message):
    with pytest.raises(UsageError) as raised:
        parse_signal(text, quantity)
    said = str(raised.value)
    assert said.startswith(message) and "\n" not in said
    assert said.endswith(ANGLE_ALLOWED if quantity == "angle" else TORQUE_ALLOWED)
    assert isinstance(raised.value, ValueError)


def test_the_caller_names_the_value_in_the_message():
    with pytest.raises(UsageError, match=r"^setpoint= 'sin:1': unknown form 'sin'; use a number"):
        parse_signal("sin:1", "angle", name="setpoint=")
    with pytest.raises(UsageError, match=r"^disturbance 'sin:1': unknown form"):
        as_signal("sin:1", "torque")  # the Python API's default names drop the dashes


@pytest.mark.parametrize(
    "text, quantity, reason",
    [
        ("", "angle", "need the column time and one value column (found none)"),
        ("time,torque\n0,1\n", "torque", "need the column time and one value column (found time, torque)"),
        ("time,value_deg\n0,1\n", "torque", "need the column time and one value column (found time, value_deg)"),
        ("time,value,value_deg\n0,1,2\n", "angle", "need the column time and one value column (found time, value"),
        ("value\n1\n", "angle", "need the column time and one value column (found value)"),
        ("time,value\n", "angle", "no rows below the header"),
        ("time,value\n0,1\n1,nan\n", "angle", "row 3, column value: 'nan' is not a finite number"),
        ("time,value\n0,1\n1\n", "angle", "row 3, column value: '' is not a finite number"),
        ("time,value\nzero,1\n", "angle", "row 2, column time: 'zero' is not a finite number"),
        ("time,value\n0,1\n1,2\n1,3\n", "angle", "the times must increase strictly (row 4: 1 after 1)"),
        ("time,value\n0,1\n2,2\n1,3\n", "torque", "the times must increase strictly (row 4: 1 after 2)"),
    ],
)
def test_every_bad_csv_file_is_one_line_naming_the_file_and_the_rule(tmp_path, text, quantity, reason):
    path = write(tmp_path, text)
    option = "--setpoint" if quantity == "angle" else "--disturbance"
    with pytest.raises(UsageError) as raised:
        parse_signal(str(path), quantity)
    said = str(raised.value)
    assert said.startswith(f"{option} {str(path)!r}: {reason}") and "\n" not in said
    assert "give a header time,VALUE (" in said


def test_a_file_that_is_not_text_is_named_in_the_message(tmp_path):
    path = tmp_path / "signal.csv"
    path.write_bytes(b"\xff\xfe\x00\x81time")
    with pytest.raises(UsageError, match=r"^--setpoint '.*signal\.csv': cannot read it \(UnicodeDecodeError\)"):
        parse_signal(str(path), "angle")


def test_the_python_api_takes_numbers_signals_texts_paths_and_functions():
    assert as_signal(0.2, "angle") == Signal("constant", "angle", value=0.2)
    assert as_signal(3, "torque")(1.0) == 3.0
    step = parse_signal("step:10deg", "angle")
    assert as_signal(step, "angle") is step
    assert as_signal("sine:1,2", "torque").kind == "sine"

    def chirp(t: float) -> float:
        return 0.1 * t * t

    signal = as_signal(chirp, "angle")
    assert signal.kind == "function" and signal(2.0) == pytest.approx(0.4, rel=1e-15)
    assert "chirp" in signal.describe()
    assert json.loads(json.dumps(signal.as_dict()))["kind"] == "function"
    assert set(KINDS) == {"constant", "step", "sine", "ramp", "table", "function"}


@pytest.mark.parametrize(
    "obj, message",
    [
        (True, "setpoint True is not allowed; use a number (rad), a Signal, a function t -> rad, a path or a text"),
        (math.inf, "setpoint inf is not a finite number; use a number (rad)"),
        ([0.1, 0.2], "setpoint [0.1, 0.2] is not allowed; use a number (rad)"),
        (None, "setpoint None is not allowed; use a number (rad)"),
        (Signal("step", "torque", amplitude=1.0), "setpoint: a Signal of torque (step to 1 N.m at t = 0 s); give one"),
    ],
)
def test_the_python_api_names_what_it_cannot_take(obj, message):
    with pytest.raises(UsageError) as raised:
        as_signal(obj, "angle")
    assert str(raised.value).startswith(message)


def test_a_function_that_gives_no_finite_number_is_named_with_the_time():
    def broken(t: float) -> float:
        return math.nan if t > 1.0 else 0.0

    signal = as_signal(broken, "angle")
    assert signal(1.0) == 0.0
    with pytest.raises(UsageError, match=r"^setpoint function 'function .*broken' gave nan at t = 1.5 s; return a"):
        signal(1.5)
    words = as_signal(lambda t: "up", "torque")
    with pytest.raises(UsageError, match=r"^disturbance function .* gave 'up' at t = 0 s; return a finite number"):
        words(0.0)


def test_a_signal_built_in_code_is_checked():
    with pytest.raises(UsageError, match=r"Signal kind 'square' is not allowed: choose one of constant, step, sine"):
        Signal("square", "angle")  # type: ignore[arg-type]
    with pytest.raises(UsageError, match=r"Signal quantity 'force' is not allowed: choose one of angle, torque"):
        Signal("step", "force")  # type: ignore[arg-type]
    with pytest.raises(UsageError, match=r"Signal table: 2 times and 1 values"):
        Signal("table", "angle", times=(0.0, 1.0), values=(0.0,))
    with pytest.raises(UsageError, match=r"quantity 'force' is not allowed"):
        parse_signal("1", "force")  # type: ignore[arg-type]
