"""The figures of a controller-in-the-loop run, from its table (series.py), for a report, a sweep's
summary or an assertion (checks.py).

The table is anything whose `table[column]` gives a column as an array (a pandas DataFrame, a numpy
structured array, a dict of arrays), one row per communication point t_k. Row k holds the values at
t_k and the summaries of the step that ends at t_k (series.py); row 0 has no step before it, so the
step summaries of row 0 count for nothing here.

The metrics, by name (METRIC_UNITS gives their units; `times` gives, for those that happen at an
instant, when):

- rms_error (rad): root mean square of the error setpoint - theta over the rows t_0 .. t_n;
- max_error (rad): the largest |setpoint - theta|, at the time of the row it is in;
- steady_state_error (rad): the mean error over the rows of the last 10 % of the run (signed);
  measured only where the set-point holds still over those rows (a sine's or a ramp's has no
  steady state: `missing` says so);
- for a step set-point (Signal kind "step"), the response theta takes from its value at the step's
  first row, theta_s, to its final value theta_f, the mean theta over the last 10 % of the run (the
  step is theta_f - theta_s; none if it is 0), as a control textbook measures it, so that a
  response that settles off the set-point still has a settling time and steady_state_error says
  how far off: overshoot (the peak beyond theta_f as a fraction of the step, >= 0, at the time of
  the peak), rise_time (s, from 10 % to 90 % of the step, the crossings interpolated between rows;
  math.inf if it never gets to 90 %) and settling_time (s from the step's time until theta enters,
  for good, the band of 2 % of the step around theta_f, interpolated between rows; math.inf if it
  is outside the band at the end of the run, so that a bound on it fails);
- impacts (count): contact episodes, maximal runs of steps with contact_force_max > 0 or
  contact_impulse > 0; its time is the first's, and `impact_times` lists them all;
- max_contact_force (N): the largest contact_force_max, at the time of its step;
- max_impulse (N.s): the largest impulse of one impact (the sum of contact_impulse over its
  episode), at the impact's time;
- time_at_drive_limit (s): the summed length of the steps whose |demand| >= drive_limit (relative
  tolerance 1e-12);
- energy_error (J): the largest |E(t) - E(t_0) - (W(t) - W(t_0))| of the energy balance, E =
  energy.total, W = energy.torque_work (the work of the hinge torque), at its time.

An impact's time, like every time of a step summary, is the end t_k of the step it began in: it
happened within (t_k - step_size, t_k]. A metric that cannot be measured is absent from `values`
and `missing` says why. Every figure is a plain float (impacts too); numpy only, no loop over rows.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, KeysView
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..failures import UsageError
from .signals import Signal

METRIC_UNITS: dict[str, str] = {
    "rms_error": "rad",
    "max_error": "rad",
    "steady_state_error": "rad",
    "overshoot": "",  # a fraction of the step
    "rise_time": "s",
    "settling_time": "s",
    "impacts": "",  # a count
    "max_contact_force": "N",
    "max_impulse": "N.s",
    "time_at_drive_limit": "s",
    "energy_error": "J",
}
METRIC_NAMES = tuple(METRIC_UNITS)
STEP_METRICS = ("overshoot", "rise_time", "settling_time")
REQUIRED_COLUMNS = (
    "time",
    "setpoint",
    "theta",
    "demand",
    "contact_force_max",
    "contact_impulse",
    "energy.total",
    "energy.torque_work",
)
SETTLING_BAND = 0.02  # of the step
RISE_FROM, RISE_TO = 0.1, 0.9  # of the step
STEADY_STATE_SHARE = 0.1  # of the run's duration, at its end
DRIVE_LIMIT_RTOL = 1e-12


@dataclass(frozen=True)
class Metrics:
    """A run's metrics: `values[name]` (also `metrics[name]`), `units[name]`, `times[name]` (s) for
    those that happen at an instant (and did), `missing[name]`: why a metric was not measured.

    `impact_times` (s) are the impacts' times; `setpoint` describes the set-point the step metrics
    were measured against ("" if none was given); `step_size` (s) and `drive_limit` (N.m) are those
    the metrics were computed with."""

    values: dict[str, float]
    times: dict[str, float]
    units: dict[str, str]
    impact_times: tuple[float, ...] = ()
    missing: dict[str, str] = field(default_factory=dict)
    setpoint: str = ""
    step_size: float = math.nan
    drive_limit: float = math.inf

    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def __contains__(self, name: object) -> bool:
        return name in self.values

    def __iter__(self) -> Iterator[str]:
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def keys(self) -> KeysView[str]:
        """The names of the metrics measured (so that dict(metrics) is metrics.values)."""
        return self.values.keys()


def loop_metrics(table: Any, *, step_size: float, drive_limit: float, setpoint: Signal | None = None) -> Metrics:
    """The metrics of a run (the module's docstring defines them).

    Parameters
    ----------
    table : the run's table (series.py columns; REQUIRED_COLUMNS at least), one row or more.
    step_size : the communication step (s): the resolution of the times of step summaries.
    drive_limit : the drive's torque limit (N.m), > 0 (math.inf: no limit).
    setpoint : the set-point the run followed; a step one adds overshoot, rise_time and settling_time.

    Raises UsageError for a table without the columns or rows, or a bad step_size or drive_limit.
    """
    if not (math.isfinite(step_size) and step_size > 0.0):
        raise UsageError(f"step_size {step_size!r} is not allowed: it must be a finite step > 0 (s)")
    if not drive_limit > 0.0:
        raise UsageError(f"drive_limit {drive_limit!r} is not allowed: it must be a torque > 0 (N.m), or math.inf")
    columns = table_columns(table)
    time = columns["time"]
    values: dict[str, float] = {}
    times: dict[str, float] = {}
    missing: dict[str, str] = {}
    error = columns["setpoint"] - columns["theta"]
    _tracking(time, error, values, times)
    _steady_state(time, columns["setpoint"], error, values, missing)
    _step_response(time, columns["theta"], setpoint, values, times, missing)
    _contacts(time, columns["contact_force_max"], columns["contact_impulse"], values, times)
    lengths = np.diff(time)
    at_limit = np.abs(columns["demand"][1:]) >= drive_limit * (1.0 - DRIVE_LIMIT_RTOL)
    values["time_at_drive_limit"] = float(np.sum(lengths[at_limit]))
    total, work = columns["energy.total"], columns["energy.torque_work"]
    imbalance = np.abs((total - total[0]) - (work - work[0]))
    k = int(np.argmax(imbalance))
    values["energy_error"], times["energy_error"] = float(imbalance[k]), float(time[k])
    ordered = {name: values[name] for name in METRIC_NAMES if name in values}
    return Metrics(
        values=ordered,
        times={name: times[name] for name in METRIC_NAMES if name in times},
        units={name: METRIC_UNITS[name] for name in ordered},
        impact_times=tuple(float(t) for t in impact_times(table)),
        missing=missing,
        setpoint="" if setpoint is None else setpoint.describe(),
        step_size=float(step_size),
        drive_limit=float(drive_limit),
    )


def table_columns(table: Any, names: tuple[str, ...] = REQUIRED_COLUMNS) -> dict[str, np.ndarray]:
    """The columns `names` of a table as float arrays; UsageError listing every missing one, or
    for a table of no rows."""
    available = _column_names(table)
    absent = [name for name in names if available is not None and name not in available]
    if absent:
        raise UsageError(f"the loop's table has no column {', '.join(absent)}; it needs {', '.join(names)}")
    try:
        columns = {name: np.asarray(table[name], dtype=float).reshape(-1) for name in names}
    except (KeyError, IndexError, ValueError) as exc:
        raise UsageError(f"the loop's table: {exc}; it needs the columns {', '.join(names)}") from None
    if len(columns[names[0]]) == 0:
        raise UsageError("the loop's table has no rows; it needs one row at least (t_0)")
    return columns


def _column_names(table: Any) -> set[str] | None:
    """The column names of a DataFrame, a structured array or a mapping; None if it does not say."""
    if hasattr(table, "columns"):
        return {str(name) for name in table.columns}
    dtype = getattr(table, "dtype", None)
    if dtype is not None and dtype.names is not None:
        return set(dtype.names)
    if hasattr(table, "keys"):
        return {str(name) for name in table.keys()}
    return None


def _tracking(time: np.ndarray, error: np.ndarray, values: dict[str, float], times: dict[str, float]) -> None:
    """rms_error, max_error (and when)."""
    values["rms_error"] = float(np.sqrt(np.mean(error**2)))
    k = int(np.argmax(np.abs(error)))
    values["max_error"], times["max_error"] = float(abs(error[k])), float(time[k])


def _steady_state(
    time: np.ndarray, setpoint: np.ndarray, error: np.ndarray, values: dict[str, float], missing: dict[str, str]
) -> None:
    """steady_state_error over the last STEADY_STATE_SHARE of the run, where the set-point holds still there."""
    rows = steady_rows(time)
    held = setpoint[rows]
    if np.ptp(held) > 0.0:
        missing["steady_state_error"] = (
            f"the set-point moves over the last {STEADY_STATE_SHARE:.0%} of the run "
            f"({held.min():.4g} to {held.max():.4g} rad): there is no steady state to measure"
        )
        return
    values["steady_state_error"] = float(np.mean(error[rows]))


def steady_rows(time: np.ndarray) -> np.ndarray:
    """The rows of the last STEADY_STATE_SHARE of the run, that at its start included however the
    times were rounded."""
    return time >= time[-1] - STEADY_STATE_SHARE * (time[-1] - time[0]) * (1.0 + 1e-9)


def _step_response(
    time: np.ndarray,
    theta: np.ndarray,
    setpoint: Signal | None,
    values: dict[str, float],
    times: dict[str, float],
    missing: dict[str, str],
) -> None:
    """overshoot (and the peak's time), rise_time and settling_time of a step set-point, or why not."""
    reason = _no_step_response(time, theta, setpoint)
    if reason or setpoint is None:
        missing.update(dict.fromkeys(STEP_METRICS, reason))
        return
    first = int(np.argmax(time >= setpoint.step_time))  # the step's first row: theta there has not answered yet
    start, final = theta[first], float(np.mean(theta[steady_rows(time)]))
    t = time[first:]
    response = (theta[first:] - start) / (final - start)  # 0 at the step, 1 at the final value
    peak = int(np.argmax(response))
    values["overshoot"], times["overshoot"] = max(0.0, float(response[peak]) - 1.0), float(t[peak])
    risen = first_crossing(t, response, RISE_TO)
    values["rise_time"] = risen - first_crossing(t, response, RISE_FROM) if math.isfinite(risen) else math.inf
    values["settling_time"] = settling_time(t, response, SETTLING_BAND) - setpoint.step_time


def _no_step_response(time: np.ndarray, theta: np.ndarray, setpoint: Signal | None) -> str:
    """Why a run has no step response to measure ("" if it has one)."""
    if setpoint is None:
        return "needs a step set-point (none was given to the metrics)"
    if setpoint.kind != "step":
        return f"needs a step set-point (this run's: {setpoint.describe()})"
    after = time >= setpoint.step_time
    if not after.any():
        return f"the step at t = {setpoint.step_time:g} s comes after the run's end (t = {time[-1]:g} s)"
    start, final = float(theta[int(np.argmax(after))]), float(np.mean(theta[steady_rows(time)]))
    if final == start:
        return f"theta did not move from {start:g} rad after the step to {setpoint.amplitude:g} rad: no response"
    return ""


def first_crossing(t: np.ndarray, y: np.ndarray, level: float) -> float:
    """The first time y reaches `level` from below, linear between samples (t[0] if it starts there;
    math.inf if it never does)."""
    reached = y >= level
    k = int(np.argmax(reached))
    if not reached[k]:
        return math.inf
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - y[k - 1]) / (y[k] - y[k - 1]) * (t[k] - t[k - 1]))


def settling_time(t: np.ndarray, y: np.ndarray, band: float) -> float:
    """The time after which |y - 1| <= band for good, linear between the last sample outside the
    band and the next (t[0] if y never leaves it; math.inf if it is outside at the end)."""
    beyond = np.abs(y - 1.0) - band
    outside = np.flatnonzero(beyond > 0.0)
    if len(outside) == 0:
        return float(t[0])
    k = int(outside[-1])
    if k == len(y) - 1:
        return math.inf
    return float(t[k] + beyond[k] / (beyond[k] - beyond[k + 1]) * (t[k + 1] - t[k]))


def contact_episodes(force_max: np.ndarray, impulse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The impacts as rows [start, stop): maximal runs of rows k >= 1 whose step saw contact
    (contact_force_max > 0 or contact_impulse > 0)."""
    contact = (np.asarray(force_max) > 0.0) | (np.asarray(impulse) > 0.0)
    contact[:1] = False  # row 0 has no step before it
    edges = np.diff(np.concatenate(([0], contact.astype(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def impact_times(table: Any) -> np.ndarray:
    """The impacts' times (s): the end of the step each began in (see contact_episodes)."""
    columns = table_columns(table, ("time", "contact_force_max", "contact_impulse"))
    starts, _ = contact_episodes(columns["contact_force_max"], columns["contact_impulse"])
    return columns["time"][starts]


def _contacts(
    time: np.ndarray, force_max: np.ndarray, impulse: np.ndarray, values: dict[str, float], times: dict[str, float]
) -> None:
    """impacts (and the first's time), max_contact_force and max_impulse (and when)."""
    starts, stops = contact_episodes(force_max, impulse)
    values["impacts"] = float(len(starts))
    values["max_contact_force"] = values["max_impulse"] = 0.0
    if len(starts) == 0:
        return
    times["impacts"] = float(time[starts[0]])
    k = 1 + int(np.argmax(force_max[1:]))
    if force_max[k] > 0.0:  # an impact seen by its impulse alone has no force to report
        values["max_contact_force"], times["max_contact_force"] = float(force_max[k]), float(time[k])
    summed = np.concatenate(([0.0], np.cumsum(impulse)))
    per_impact = summed[stops] - summed[starts]
    j = int(np.argmax(per_impact))
    if per_impact[j] > 0.0:
        values["max_impulse"], times["max_impulse"] = float(per_impact[j]), float(time[starts[j]])


def json_number(value: float) -> float | str | None:
    """A float as JSON takes it: inf and -inf as the strings "inf" and "-inf", NaN as None (null)."""
    if math.isnan(value):
        return None
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return float(value)


def metrics_json(metrics: Metrics) -> dict[str, Any]:
    """The metrics as a JSON-safe dict (json.dumps(..., allow_nan=False) takes it), to write beside
    the run's CSV:

        {"metrics": {name: {"value": v, "unit": u, "time": t or null}}, "missing": {name: why},
         "impact_times": [t, ...], "setpoint": "...", "step_size": s, "drive_limit": N.m}

    Infinite numbers are the strings "inf" / "-inf" (a settling_time that never settles, no drive
    limit), NaN is null; a metric that happens at no instant has "time": null.
    """
    return {
        "metrics": {
            name: {
                "value": json_number(value),
                "unit": metrics.units.get(name, METRIC_UNITS.get(name, "")),
                "time": json_number(metrics.times[name]) if name in metrics.times else None,
            }
            for name, value in metrics.values.items()
        },
        "missing": dict(metrics.missing),
        "impact_times": [json_number(t) for t in metrics.impact_times],
        "setpoint": metrics.setpoint,
        "step_size": json_number(metrics.step_size),
        "drive_limit": json_number(metrics.drive_limit),
    }
