"""Assertions on a controller-in-the-loop run, for a user's test suite:

    assert_loop(result, rms_error_below=0.05, max_contact_force_below=500, settles_within=1.5)

checks every bound given against the run's metrics (metrics.py) and raises one LoopCheckFailed
listing every check that failed, each line naming the metric, its value with its unit, when it
happened (for a metric that happens at an instant) and the bound, e.g.

    max_contact_force = 812.4 N at t = 0.734 s, above the bound 500 N

A `_below` bound holds when the value is below it (strictly; steady_state_error: its magnitude),
`impacts_at_most` and `settles_within` when the value is not above it. A bound on a metric the run
could not measure (settles_within without a step set-point) is a UsageError saying why.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping

from ..failures import UsageError
from .metrics import SETTLING_BAND, Metrics

# the keyword of each check: (the metric it bounds, how)
CHECKS: dict[str, tuple[str, str]] = {
    "rms_error_below": ("rms_error", "below"),
    "max_error_below": ("max_error", "below"),
    "max_contact_force_below": ("max_contact_force", "below"),
    "max_impulse_below": ("max_impulse", "below"),
    "impacts_at_most": ("impacts", "at_most"),
    "settles_within": ("settling_time", "at_most"),
    "overshoot_below": ("overshoot", "below"),
    "steady_state_error_below": ("steady_state_error", "magnitude_below"),
    "energy_error_below": ("energy_error", "below"),
    "time_at_drive_limit_below": ("time_at_drive_limit", "below"),
}


class LoopCheckFailed(AssertionError):
    """Checks of a loop run that failed: `failures` holds one line per failed check, `metrics` the
    run's metrics; the message lists them all."""

    def __init__(self, failures: list[str], checked: int, metrics: Metrics) -> None:
        self.failures = failures
        self.metrics = metrics
        lines = "\n".join(f"  {line}" for line in failures)
        super().__init__(f"{len(failures)} of {checked} loop checks failed:\n{lines}")


def assert_loop(
    result_or_metrics: object,
    *,
    rms_error_below: float | None = None,
    max_error_below: float | None = None,
    max_contact_force_below: float | None = None,
    max_impulse_below: float | None = None,
    impacts_at_most: float | None = None,
    settles_within: float | None = None,
    overshoot_below: float | None = None,
    steady_state_error_below: float | None = None,
    energy_error_below: float | None = None,
    time_at_drive_limit_below: float | None = None,
) -> None:
    """Check a run (anything with a `.metrics` that is a Metrics, or a Metrics) against the bounds
    given (None: not checked; units those of metrics.METRIC_UNITS: rad, N, N.s, s, J, a count, a
    fraction of the step); LoopCheckFailed listing every failed check."""
    __tracebackhide__ = True  # pytest shows the failed checks, not this function's source
    bounds = {
        "rms_error_below": rms_error_below,
        "max_error_below": max_error_below,
        "max_contact_force_below": max_contact_force_below,
        "max_impulse_below": max_impulse_below,
        "impacts_at_most": impacts_at_most,
        "settles_within": settles_within,
        "overshoot_below": overshoot_below,
        "steady_state_error_below": steady_state_error_below,
        "energy_error_below": energy_error_below,
        "time_at_drive_limit_below": time_at_drive_limit_below,
    }
    given = {keyword: bound for keyword, bound in bounds.items() if bound is not None}
    metrics = metrics_of(result_or_metrics)
    failures = failed_checks(metrics, given)
    if failures:
        raise LoopCheckFailed(failures, len(given), metrics)


def metrics_of(result_or_metrics: object) -> Metrics:
    """The Metrics of a run result (its `.metrics`), or the Metrics given; TypeError otherwise."""
    if isinstance(result_or_metrics, Metrics):
        return result_or_metrics
    metrics = getattr(result_or_metrics, "metrics", None)
    if isinstance(metrics, Metrics):
        return metrics
    raise TypeError(
        f"assert_loop takes a loop result (with .metrics) or its Metrics, not {type(result_or_metrics).__name__}"
    )


def failed_checks(metrics: Metrics, bounds: Mapping[str, float]) -> list[str]:
    """One line per bound (keyword of CHECKS -> bound) the metrics break, in the order of CHECKS.
    TypeError for an unknown keyword or a bound that is not a number; UsageError for a NaN bound
    or a bound on a metric the run could not measure."""
    unknown = sorted(set(bounds) - set(CHECKS))
    if unknown:
        raise TypeError(f"unknown loop check {', '.join(unknown)}; the checks are {', '.join(CHECKS)}")
    for keyword, bound in bounds.items():
        if not isinstance(bound, numbers.Real) or isinstance(bound, bool):
            raise TypeError(f"{keyword} {bound!r} is not a number")
        if math.isnan(bound):
            raise UsageError(f"{keyword} {bound!r} is not allowed: it must be a number")
        name = CHECKS[keyword][0]
        if name not in metrics.values:
            why = metrics.missing.get(name, "was not measured")
            raise UsageError(f"{keyword}: {name} {why}")
    lines = (_failure(metrics, keyword, float(bounds[keyword])) for keyword in CHECKS if keyword in bounds)
    return [line for line in lines if line]


def _failure(metrics: Metrics, keyword: str, bound: float) -> str:
    """The line saying how the metric breaks the bound, "" if it keeps it."""
    name, how = CHECKS[keyword]
    value = metrics.values[name]
    unit = metrics.units.get(name, "")
    compared = abs(value) if how == "magnitude_below" else value
    kept = compared <= bound if how == "at_most" else compared < bound
    if kept:
        return ""
    relation = "above" if compared > bound else "not below"
    if how == "magnitude_below":
        relation = f"its magnitude {relation}"
    measured = f"{name} = {_amount(name, value, unit)}{_when(metrics, name, value)}"
    return f"{measured}, {relation} the bound {_amount(name, bound, unit)}"


def _amount(name: str, value: float, unit: str) -> str:
    """A figure with its unit: degrees beside radians, a percentage beside the overshoot."""
    text = f"{value:.4g}" + (f" {unit}" if unit else "")
    if unit == "rad" and math.isfinite(value):
        return f"{text} ({math.degrees(value):.3g} deg)"
    if name == "overshoot" and math.isfinite(value):
        return f"{text} ({100.0 * value:.3g} % of the step)"
    return text


def _when(metrics: Metrics, name: str, value: float) -> str:
    """When the metric happened, as the failure line says it ("" for a metric over the run)."""
    if name == "settling_time" and math.isinf(value):
        return f" (theta is outside the {100 * SETTLING_BAND:g} % band of the step at the end of the run)"
    if name not in metrics.times:
        return ""
    t = f"t = {metrics.times[name]:.4g} s"
    return f" (the first at {t})" if name == "impacts" else f" at {t}"
