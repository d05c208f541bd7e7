"""The loop's metrics (masters/control/metrics.py) on synthetic tables whose answers the tests work out
on their own: an analytic second-order step response, contact episodes of known impulse, a demand at
the drive limit for a known time, an energy series with a known imbalance."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from fem_pendulum_fmu.masters.control.metrics import (
    METRIC_NAMES,
    METRIC_UNITS,
    impact_times,
    loop_metrics,
    metrics_json,
)
from fem_pendulum_fmu.masters.control.series import COLUMNS
from fem_pendulum_fmu.masters.control.signals import Signal, parse_signal
from fem_pendulum_fmu.masters.failures import UsageError

DT = 1e-3


def loop_table(stop_time: float = 1.0, dt: float = DT, **columns) -> pd.DataFrame:
    """A loop's table with every column of series.py: `time` = k dt, the columns given (arrays, or
    functions of the time), zeros elsewhere."""
    time = np.arange(int(round(stop_time / dt)) + 1) * dt
    data = {name: np.zeros_like(time) for name in COLUMNS}
    data["time"] = time
    for name, values in columns.items():
        name = name.replace("__", ".")  # energy__total -> energy.total
        assert name in COLUMNS, name
        data[name] = values(time) if callable(values) else np.broadcast_to(np.asarray(values, dtype=float), time.shape)
    return pd.DataFrame(data, columns=list(COLUMNS))


def metrics_of(table, setpoint=None, drive_limit=15.0):
    return loop_metrics(table, step_size=DT, drive_limit=drive_limit, setpoint=setpoint)


# an underdamped second-order response to a unit step: y(t) = 1 - e^(-z w t) (cos wd t + z / sqrt(1 - z^2) sin wd t)
ZETA, OMEGA = 0.3, 2 * math.pi * 1.7


def unit_response(t, zeta: float = ZETA):
    t = np.maximum(t, 0.0)
    wd = OMEGA * math.sqrt(1 - zeta**2)
    return 1 - np.exp(-zeta * OMEGA * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))


def bisect(f, a: float, b: float) -> float:
    """The root of f in [a, b] (f(a), f(b) of opposite signs), to the last bit."""
    fa = f(a)
    for _ in range(200):
        m = 0.5 * (a + b)
        if m in (a, b):
            break
        if (f(m) > 0) == (fa > 0):
            a, fa = m, f(m)
        else:
            b = m
    return 0.5 * (a + b)


def exact_step_figures(band: float = 0.02) -> dict[str, float]:
    """Overshoot, peak time, 10-90 % rise time and 2 % settling time of unit_response, worked out
    without the sampled table: closed forms, and roots found by bisection on the function itself."""
    # y' = (w / sqrt(1 - z^2)) e^(-z w t) sin(wd t) > 0 before the peak: y rises monotonically up to it
    peak = math.pi / (OMEGA * math.sqrt(1 - ZETA**2))
    rise = bisect(lambda t: unit_response(t) - 0.9, 0.0, peak) - bisect(lambda t: unit_response(t) - 0.1, 0.0, peak)
    # |y - 1| <= e^(-z w t) / sqrt(1 - z^2): past `envelope` the response is in the band for good; the last time it
    # leaves the band before then is found on a 1 us grid and refined by bisection
    envelope = -math.log(band * math.sqrt(1 - ZETA**2)) / (ZETA * OMEGA)
    fine = np.linspace(0.0, envelope, 2_000_001)
    last = int(np.flatnonzero(np.abs(unit_response(fine) - 1) > band)[-1])
    settle = bisect(lambda t: abs(unit_response(t) - 1) - band, fine[last], fine[last + 1])
    return {
        "overshoot": math.exp(-ZETA * math.pi / math.sqrt(1 - ZETA**2)),
        "peak_time": peak,
        "rise_time": rise,
        "settling_time": settle,
    }


EXACT = exact_step_figures()
# The sampled peak is the largest of the samples around the true one, at most DT / 2 away; there y' = 0 and,
# from y'' + 2 z w y' + w^2 (y - 1) = 0, y'' = -w^2 * overshoot, so the sample is short of the peak by at most
# w^2 * overshoot / 2 * (DT / 2)^2 = 5.3e-6 (of the step). Measured: 2.2e-6 short, both cases.
PEAK_TOLERANCE = OMEGA**2 * EXACT["overshoot"] / 2 * (DT / 2) ** 2
# A crossing interpolated linearly between samples DT apart is off by up to DT^2 / 8 * |y''| / |y'| there: 2.2e-6 s
# at the 10 % crossing, 5.8e-7 s at 90 %, 3.0e-8 s where the response settles (y'' and y' of the analytic response).
# Measured: rise time 1.8e-6 s, settling time 2.9e-8 s off, both cases.
CROSSING_TOLERANCE = 3e-6


@pytest.mark.parametrize(
    "start, amplitude, step_time",
    [
        (0.0, 0.2, 0.0),  # up from rest at t = 0
        (0.1, -0.15, 0.25),  # down from 0.1 rad, at t = 0.25 s (a row)
    ],
)
def test_a_second_order_step_response_has_its_analytic_overshoot_rise_and_settling_time(start, amplitude, step_time):
    setpoint = Signal("step", "angle", amplitude=amplitude, step_time=step_time)
    table = loop_table(
        6.0,  # long enough that the last 10 %, where the final value is taken, is settled to 3e-8 of the step
        setpoint=lambda t: np.where(t >= step_time, amplitude, 0.0),
        theta=lambda t: start + (amplitude - start) * unit_response(t - step_time),
    )
    metrics = metrics_of(table, setpoint)
    assert metrics["overshoot"] == pytest.approx(EXACT["overshoot"], abs=PEAK_TOLERANCE)
    assert metrics["overshoot"] < EXACT["overshoot"]  # the samples cannot overshoot the true peak
    assert metrics.times["overshoot"] - step_time == pytest.approx(EXACT["peak_time"], abs=DT / 2)
    assert metrics["rise_time"] == pytest.approx(EXACT["rise_time"], abs=CROSSING_TOLERANCE)
    assert metrics["settling_time"] == pytest.approx(EXACT["settling_time"], abs=CROSSING_TOLERANCE)
    assert "rise_time" not in metrics.times and "settling_time" not in metrics.times  # durations, not instants
    assert metrics.units["overshoot"] == "" and metrics.units["settling_time"] == "s"
    assert metrics.missing == {}


def test_the_step_figures_are_not_those_of_a_different_response():
    """Negative control: a 10 % stronger damping moves every step figure beyond its tolerance (measured: overshoot
    by 0.039, rise time by 3.7e-3 s, settling time by 1.0e-2 s)."""
    table = loop_table(6.0, setpoint=0.2, theta=lambda t: 0.2 * unit_response(t, zeta=1.1 * ZETA))
    metrics = metrics_of(table, parse_signal("step:0.2", "angle"))
    for name in ("overshoot", "rise_time", "settling_time"):
        assert abs(metrics[name] - EXACT[name]) > 100 * CROSSING_TOLERANCE, name


def test_a_response_that_never_settles_or_rises_says_so_with_inf():
    step = parse_signal("step:0.2", "angle")
    undamped_theta = lambda t: 0.2 * (1 - np.cos(OMEGA * t))  # noqa: E731
    undamped = metrics_of(loop_table(2.0, setpoint=0.2, theta=undamped_theta), step)
    assert undamped["settling_time"] == math.inf
    # the final value: the mean over the last 10 % of the run (rows 1800 .. 2000), the peak 0.4 rad (cos = -1)
    final = float(np.mean(undamped_theta(np.arange(1800, 2001) * DT)))
    assert undamped["overshoot"] == pytest.approx(0.4 / final - 1, abs=PEAK_TOLERANCE)
    sluggish = metrics_of(loop_table(1.0, setpoint=0.2, theta=lambda t: 0.1 * t), step)  # 50 % of the step at the end
    assert sluggish["settling_time"] == math.inf  # still rising at the end: 5 % above its final value (0.095 rad)
    assert sluggish["steady_state_error"] == pytest.approx(0.2 - 0.095, abs=1e-12)
    assert sluggish["overshoot"] == pytest.approx(0.1 / 0.095 - 1, abs=1e-12)
    assert sluggish.times["overshoot"] == 1.0  # the peak: the last row
    payload = json.dumps(metrics_json(sluggish), allow_nan=False)
    assert json.loads(payload)["metrics"]["settling_time"] == {"value": "inf", "unit": "s", "time": None}


@pytest.mark.parametrize(
    "setpoint, reason",
    [
        (None, "needs a step set-point (none was given to the metrics)"),
        (parse_signal("sine:0.3,1", "angle"), "needs a step set-point (this run's: sine 0.3 rad (17.19 deg) at 1 Hz)"),
        (parse_signal("step:0.2,5", "angle"), "the step at t = 5 s comes after the run's end (t = 1 s)"),
        (parse_signal("step:0", "angle"), "theta did not move from 0 rad after the step to 0 rad: no response"),
    ],
)
def test_without_a_step_to_measure_the_step_metrics_are_missing_and_say_why(setpoint, reason):
    metrics = metrics_of(loop_table(1.0), setpoint)
    assert metrics.missing == {"overshoot": reason, "rise_time": reason, "settling_time": reason}
    assert "overshoot" not in metrics and "settling_time" not in metrics.values
    assert set(metrics) == set(METRIC_NAMES) - {"overshoot", "rise_time", "settling_time"}


def test_tracking_error_rms_maximum_and_its_time():
    # error = setpoint - theta = 0.1 sin(2 pi t) over 1001 rows t = 0 .. 1 s: the squares sum to 0.1^2 * 500
    # (the 1000 rows of a whole period sum sin^2 to 500; the last row adds sin(2 pi) = 0)
    table = loop_table(1.0, setpoint=0.3, theta=lambda t: 0.3 - 0.1 * np.sin(2 * np.pi * t))
    metrics = metrics_of(table)
    assert metrics["rms_error"] == pytest.approx(0.1 * math.sqrt(500 / 1001), rel=1e-12)
    assert metrics["max_error"] == pytest.approx(0.1, rel=1e-12)
    assert metrics.times["max_error"] in (0.25, 0.75)  # the crests, equal but for rounding
    assert metrics.units["rms_error"] == metrics.units["max_error"] == "rad"
    # a theta that passes the set-point by 0.07 rad at t = 0.437 s, and by less either side: |error| is the figure
    theta = 0.3 + 0.07 * np.maximum(0.0, 1 - np.abs(np.arange(1001) - 437) / 20)
    spike = metrics_of(loop_table(1.0, setpoint=0.3, theta=theta))
    assert spike["max_error"] == pytest.approx(0.07, rel=1e-12) and spike.times["max_error"] == pytest.approx(0.437)


def test_the_steady_state_error_is_the_mean_error_over_the_last_tenth_of_the_run():
    # error = 0.01 t over t = 0 .. 1 s; the last 10 %: the 101 rows t = 0.900 .. 1.000 s, whose mean t is 0.95 s
    table = loop_table(1.0, setpoint=0.3, theta=lambda t: 0.3 - 0.01 * t)
    assert metrics_of(table)["steady_state_error"] == pytest.approx(0.0095, rel=1e-12)
    rows = np.arange(900, 1001) * DT
    assert metrics_of(table)["steady_state_error"] == pytest.approx(float(np.mean(0.01 * rows)), rel=1e-12)
    overshooting = loop_table(1.0, setpoint=0.3, theta=0.32)  # theta above the set-point: a negative error
    assert metrics_of(overshooting)["steady_state_error"] == pytest.approx(-0.02, rel=1e-12)


def test_a_set_point_that_moves_at_the_end_has_no_steady_state_error():
    # a sine set-point tracked with a lag: its error over the last tenth is a swing, not a steady state
    moving = metrics_of(loop_table(1.0, setpoint=lambda t: 0.3 * np.sin(2 * np.pi * t), theta=0.0))
    assert "steady_state_error" not in moving and "rms_error" in moving
    assert moving.missing["steady_state_error"].startswith("the set-point moves over the last 10% of the run (")
    # one that stops moving before the last tenth has one
    settled = metrics_of(loop_table(1.0, setpoint=lambda t: np.minimum(t, 0.8), theta=0.79))
    assert settled["steady_state_error"] == pytest.approx(0.01, rel=1e-12)


def contact_table():
    """Two impacts: rows 240-242 (impulses 0.01 + 0.03 + 0.005 N.s, largest force 800 N in row 241) and rows
    700-702 (0.02 + 0.02 N.s and a last step seen by its impulse alone, 4e-6 N.s; largest force 400 N); row 0
    carries a contact summary too (a run that starts on the wall), which counts for nothing: no step before it."""
    force, impulse = np.zeros(1001), np.zeros(1001)
    force[[0, 240, 241, 242, 700, 701]] = [900.0, 100.0, 800.0, 50.0, 300.0, 400.0]
    impulse[[0, 240, 241, 242, 700, 701, 702]] = [0.05, 0.01, 0.03, 0.005, 0.02, 0.02, 4e-6]
    return loop_table(1.0, contact_force_max=force, contact_impulse=impulse)


def test_two_contact_episodes_give_their_count_times_largest_force_and_impulse():
    table = contact_table()
    metrics = metrics_of(table)
    assert metrics["impacts"] == 2.0 and metrics.times["impacts"] == pytest.approx(0.240, abs=1e-15)
    assert metrics.impact_times == pytest.approx((0.240, 0.700), abs=1e-15)
    assert impact_times(table) == pytest.approx([0.240, 0.700], abs=1e-15)
    assert metrics["max_contact_force"] == 800.0 and metrics.times["max_contact_force"] == pytest.approx(0.241)
    assert metrics["max_impulse"] == pytest.approx(0.045, rel=1e-12)  # 0.01 + 0.03 + 0.005 > 0.02 + 0.02 + 4e-6
    assert metrics.times["max_impulse"] == pytest.approx(0.240, abs=1e-15)
    assert [metrics.units[name] for name in ("impacts", "max_contact_force", "max_impulse")] == ["", "N", "N.s"]


def test_the_impacts_are_read_from_any_table_with_the_columns():
    frame = contact_table()
    structured = frame.to_records(index=False)
    as_dict = {name: frame[name].to_numpy() for name in frame.columns}
    for table in (structured, as_dict):
        assert impact_times(table) == pytest.approx([0.240, 0.700], abs=1e-15)
        assert metrics_of(table)["max_impulse"] == pytest.approx(0.045, rel=1e-12)


def test_an_impact_in_the_last_step_and_a_run_without_impacts():
    force = np.zeros(101)
    force[-1] = 5.0
    metrics = metrics_of(loop_table(0.1, contact_force_max=force))
    assert metrics["impacts"] == 1.0 and metrics.impact_times == pytest.approx((0.1,))
    assert metrics["max_impulse"] == 0.0 and "max_impulse" not in metrics.times  # no impulse reported: no instant
    quiet = metrics_of(loop_table(0.1))
    assert (quiet["impacts"], quiet["max_contact_force"], quiet["max_impulse"]) == (0.0, 0.0, 0.0)
    assert quiet.impact_times == () and not {"impacts", "max_contact_force", "max_impulse"} & set(quiet.times)


def test_time_at_the_drive_limit_sums_the_steps_whose_demand_reaches_it():
    demand = np.zeros(1001)
    demand[0] = 15.0  # row 0: no step before it
    demand[101:351] = 15.0  # 250 steps at the limit: 0.25 s
    demand[601:701] = -15.0 * (1 - 1e-13)  # 100 steps within the relative tolerance 1e-12: 0.1 s
    demand[801:851] = 15.0 * (1 - 1e-9)  # just below the limit: not counted
    demand[900:910] = 20.0  # a demand above the limit counts too (the drive delivers its limit): 0.01 s
    metrics = metrics_of(loop_table(1.0, demand=demand), drive_limit=15.0)
    assert metrics["time_at_drive_limit"] == pytest.approx(0.36, rel=1e-12)
    assert metrics_of(loop_table(1.0, demand=demand), drive_limit=math.inf)["time_at_drive_limit"] == 0.0
    assert "time_at_drive_limit" not in metrics.times and metrics.units["time_at_drive_limit"] == "s"


def test_the_energy_error_is_the_largest_imbalance_and_its_time():
    # E = 0.2 J + W + a bump of -3 mJ centred on t = 0.6 s (a row); W, the torque's work, grows 0.5 J/s
    def energy(t):
        return 0.2 + 0.5 * t - 0.003 * np.exp(-(((t - 0.6) / 0.02) ** 2))

    table = loop_table(1.0, energy__total=energy, energy__torque_work=lambda t: 0.5 * t)
    metrics = metrics_of(table)
    assert metrics["energy_error"] == pytest.approx(0.003, rel=1e-9)
    assert metrics.times["energy_error"] == pytest.approx(0.6, abs=1e-15)
    assert metrics.units["energy_error"] == "J"
    # the balance is over the run: a torque_work that does not start at 0 changes nothing
    shifted = loop_table(1.0, energy__total=energy, energy__torque_work=lambda t: 1 + 0.5 * t)
    assert metrics_of(shifted)["energy_error"] == pytest.approx(0.003, rel=1e-9)
    balanced = loop_table(1.0, energy__total=lambda t: 0.2 + 0.5 * t, energy__torque_work=lambda t: 0.5 * t)
    assert metrics_of(balanced)["energy_error"] < 1e-15


def test_metrics_are_a_mapping_of_their_values_and_their_json_is_strict():
    table = contact_table()
    table["theta"] = 0.2 * (1 - np.exp(-table["time"] / 0.05))  # a response to the step
    metrics = metrics_of(table, parse_signal("step:0.2", "angle"))
    assert dict(metrics) == metrics.values and len(metrics) == len(METRIC_NAMES) and list(metrics) == list(METRIC_NAMES)
    assert metrics.units == METRIC_UNITS
    payload = json.loads(json.dumps(metrics_json(metrics), allow_nan=False))
    assert payload["metrics"]["max_contact_force"] == {"value": 800.0, "unit": "N", "time": pytest.approx(0.241)}
    assert payload["metrics"]["rms_error"]["time"] is None
    assert payload["impact_times"] == pytest.approx([0.24, 0.7])
    assert payload["setpoint"] == "step to 0.2 rad (11.46 deg) at t = 0 s"
    assert (payload["step_size"], payload["drive_limit"], payload["missing"]) == (DT, 15.0, {})
    assert json.loads(json.dumps(metrics_json(metrics_of(table, drive_limit=math.inf))))["drive_limit"] == "inf"


def test_bad_tables_and_arguments_are_named():
    with pytest.raises(UsageError, match=r"^the loop's table has no column demand, energy.total; it needs time, "):
        metrics_of(loop_table(0.1).drop(columns=["demand", "energy.total"]))
    with pytest.raises(UsageError, match=r"^the loop's table has no rows"):
        metrics_of(loop_table(0.1).iloc[:0])
    with pytest.raises(UsageError, match=r"^step_size 0.0 is not allowed: it must be a finite step > 0 \(s\)"):
        loop_metrics(loop_table(0.1), step_size=0.0, drive_limit=15.0)
    with pytest.raises(
        UsageError, match=r"^drive_limit nan is not allowed: it must be a torque > 0 \(N.m\), or math.inf"
    ):
        loop_metrics(loop_table(0.1), step_size=DT, drive_limit=math.nan)
    one_row = metrics_of(loop_table(0.0, setpoint=0.1))
    assert one_row["rms_error"] == pytest.approx(0.1) and one_row["time_at_drive_limit"] == 0.0
