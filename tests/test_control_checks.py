"""assert_loop (masters/control/checks.py): every check passes and fails where its bound says, and the
failure message lists every failed check with the metric, its value and unit, when, and the bound."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest

from fem_pendulum_fmu.masters.control.checks import CHECKS, LoopCheckFailed, assert_loop, failed_checks
from fem_pendulum_fmu.masters.control.metrics import METRIC_UNITS, Metrics, loop_metrics
from fem_pendulum_fmu.masters.control.series import COLUMNS
from fem_pendulum_fmu.masters.control.signals import parse_signal
from fem_pendulum_fmu.masters.failures import UsageError

DT = 1e-3


def metrics(values: dict[str, float], times: dict[str, float] | None = None) -> Metrics:
    return Metrics(values=values, times=times or {}, units={name: METRIC_UNITS[name] for name in values})


# one run's figures, each with a time where the metric happens at an instant
RUN = metrics(
    {
        "rms_error": 0.02,
        "max_error": 0.0524,
        "steady_state_error": -0.004,
        "overshoot": 0.253,
        "rise_time": 0.12,
        "settling_time": 1.05,
        "impacts": 3.0,
        "max_contact_force": 812.4,
        "max_impulse": 0.0451,
        "time_at_drive_limit": 0.36,
        "energy_error": 0.0031,
    },
    {
        "max_error": 0.25,
        "overshoot": 0.308,
        "impacts": 0.239,
        "max_contact_force": 0.734,
        "max_impulse": 0.24,
        "energy_error": 0.6,
    },
)

# every bound the run keeps, a little above its figure
KEPT = {
    "rms_error_below": 0.03,
    "max_error_below": 0.06,
    "max_contact_force_below": 1000.0,
    "max_impulse_below": 0.05,
    "impacts_at_most": 3,
    "settles_within": 1.05,
    "overshoot_below": 0.3,
    "steady_state_error_below": 0.005,
    "energy_error_below": 0.004,
    "time_at_drive_limit_below": 0.4,
}

# every bound the run breaks, and the line that says so
BROKEN = {
    "rms_error_below": (0.01, "rms_error = 0.02 rad (1.15 deg), above the bound 0.01 rad (0.573 deg)"),
    "max_error_below": (0.05, "max_error = 0.0524 rad (3 deg) at t = 0.25 s, above the bound 0.05 rad (2.86 deg)"),
    "max_contact_force_below": (500.0, "max_contact_force = 812.4 N at t = 0.734 s, above the bound 500 N"),
    "max_impulse_below": (0.03, "max_impulse = 0.0451 N.s at t = 0.24 s, above the bound 0.03 N.s"),
    "impacts_at_most": (2, "impacts = 3 (the first at t = 0.239 s), above the bound 2"),
    "settles_within": (1.0, "settling_time = 1.05 s, above the bound 1 s"),
    "overshoot_below": (
        0.2,
        "overshoot = 0.253 (25.3 % of the step) at t = 0.308 s, above the bound 0.2 (20 % of the step)",
    ),
    "steady_state_error_below": (
        0.001,
        "steady_state_error = -0.004 rad (-0.229 deg), its magnitude above the bound 0.001 rad (0.0573 deg)",
    ),
    "energy_error_below": (0.001, "energy_error = 0.0031 J at t = 0.6 s, above the bound 0.001 J"),
    "time_at_drive_limit_below": (0.1, "time_at_drive_limit = 0.36 s, above the bound 0.1 s"),
}


def test_a_run_that_keeps_every_bound_passes():
    assert set(KEPT) == set(CHECKS) == set(BROKEN)
    assert assert_loop(RUN, **KEPT) is None
    assert failed_checks(RUN, KEPT) == []
    assert_loop(RUN)  # no bound, nothing checked


@pytest.mark.parametrize("keyword", list(BROKEN))
def test_each_broken_bound_names_the_metric_its_value_when_and_the_bound(keyword):
    bound, line = BROKEN[keyword]
    with pytest.raises(LoopCheckFailed) as raised:
        assert_loop(RUN, **{**KEPT, keyword: bound})
    assert raised.value.failures == [line]
    assert str(raised.value) == f"1 of 10 loop checks failed:\n  {line}"
    assert raised.value.metrics is RUN


def test_every_failed_check_is_listed_in_one_message():
    with pytest.raises(AssertionError) as raised:  # LoopCheckFailed is an AssertionError: pytest reports it as one
        assert_loop(RUN, **{keyword: bound for keyword, (bound, _) in BROKEN.items()})
    message = str(raised.value)
    assert message.splitlines() == ["10 of 10 loop checks failed:", *(f"  {line}" for _, line in BROKEN.values())]


def test_a_value_at_its_bound_fails_below_and_passes_at_most():
    with pytest.raises(LoopCheckFailed, match=r"rms_error = 0.02 rad \(1.15 deg\), not below the bound 0.02 rad"):
        assert_loop(RUN, rms_error_below=0.02)
    assert_loop(RUN, impacts_at_most=3, settles_within=1.05)
    nan = metrics({"energy_error": math.nan})
    with pytest.raises(LoopCheckFailed, match=r"energy_error = nan J, not below the bound 1 J"):
        assert_loop(nan, energy_error_below=1.0)


def test_a_run_that_never_settles_says_so():
    restless = metrics({"settling_time": math.inf})
    with pytest.raises(LoopCheckFailed) as raised:
        assert_loop(restless, settles_within=2.0)
    assert raised.value.failures == [
        "settling_time = inf s (theta is outside the 2 % band of the step at the end of the run), above the bound 2 s"
    ]


@dataclass
class Result:
    """What closed_loop returns, as far as assert_loop reads it."""

    metrics: Metrics


def table_of(theta: np.ndarray, force: np.ndarray) -> pd.DataFrame:
    """A loop's table with every column of series.py: a step set-point of 0.2 rad at t = 0, `theta` and
    `force` (contact_force_max) given, zeros elsewhere."""
    data = {name: np.zeros_like(theta) for name in COLUMNS}
    data.update(time=np.arange(len(theta)) * DT, setpoint=np.full_like(theta, 0.2), theta=theta)
    data["contact_force_max"] = force
    return pd.DataFrame(data)


def test_a_loop_result_is_checked_through_its_metrics():
    t = np.arange(2001) * DT
    force = np.where((t > 0.3) & (t < 0.305), 600.0, 0.0)  # one impact, steps ending at 0.301 .. 0.304 s
    # first order: within 2 % after 0.1 s * ln 50 = 0.391 s; its final value, the mean of the last 10 % of the
    # run, is 1e-9 of the step below its last row, which is the peak: an overshoot of 1e-9
    theta = 0.2 * (1 - np.exp(-t / 0.1))
    step = parse_signal("step:0.2", "angle")
    result = Result(loop_metrics(table_of(theta, force), step_size=DT, drive_limit=15.0, setpoint=step))
    assert_loop(result, settles_within=0.392, overshoot_below=1e-6, impacts_at_most=1, max_contact_force_below=601)
    with pytest.raises(LoopCheckFailed) as raised:
        assert_loop(result, settles_within=0.39, max_contact_force_below=500)
    assert raised.value.failures == [
        "max_contact_force = 600 N at t = 0.301 s, above the bound 500 N",
        "settling_time = 0.3912 s, above the bound 0.39 s",
    ]


def test_a_bound_on_a_step_metric_of_a_run_without_a_step_says_it_needs_one():
    t = np.arange(101) * DT
    sine = parse_signal("sine:0.2,1", "angle")
    result = Result(loop_metrics(table_of(0.0 * t, 0.0 * t), step_size=DT, drive_limit=15.0, setpoint=sine))
    needs = r"^settles_within: settling_time needs a step set-point \(this run's: sine 0.2 rad \(11.46 deg\) at 1 Hz\)$"
    with pytest.raises(UsageError, match=needs):
        assert_loop(result, settles_within=1.0, rms_error_below=1.0)
    with pytest.raises(UsageError, match=r"^overshoot_below: overshoot needs a step set-point"):
        assert_loop(result, overshoot_below=0.1)
    with pytest.raises(UsageError, match=r"^settles_within: settling_time was not measured"):
        assert_loop(metrics({"rms_error": 0.1}), settles_within=1.0)  # Metrics made by hand, without a reason


def test_wrong_arguments_are_type_errors_or_named():
    with pytest.raises(TypeError, match="unexpected keyword argument 'rms_below'"):
        assert_loop(RUN, rms_below=0.1)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match=r"^unknown loop check rms_below; the checks are rms_error_below, max_error"):
        failed_checks(RUN, {"rms_below": 0.1})
    with pytest.raises(TypeError, match=r"^rms_error_below '0.1' is not a number"):
        assert_loop(RUN, rms_error_below="0.1")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"^impacts_at_most True is not a number"):
        assert_loop(RUN, impacts_at_most=True)
    with pytest.raises(UsageError, match=r"^energy_error_below nan is not allowed: it must be a number"):
        assert_loop(RUN, energy_error_below=math.nan)
    with pytest.raises(TypeError, match=r"^assert_loop takes a loop result \(with .metrics\) or its Metrics, not dict"):
        assert_loop({"rms_error": 0.1}, rms_error_below=1.0)
