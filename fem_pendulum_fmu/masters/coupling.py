"""Higher-order hold between FMUs: one FMU's output derivatives passed on as another's input derivatives.

Between communication points a co-simulation master holds each input constant (zero-order hold, the
FMI default); FMUs that declare canInterpolateInputs and maxOutputDerivativeOrder let it pass the
outputs' first (first-order hold) or first and second time derivatives (second-order hold) instead,
so the receiving FMU follows a ramp or a parabola over its step (FMI 2.0, section 4.2.1; docs/reference/fmi2.md,
"Input interpolation and output derivatives"). Plain functions on fmpy FMU2Slave instances and value
references, so that any fmpy master can use them; benchmarks/coupling.py measures what they buy
(docs/notes/coupling.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

HOLD_ORDERS = (0, 1, 2)  # zero-, first- and second-order hold
Rates = list[float]  # an input's or output's time derivatives of orders 1, 2, ... (as many as the hold order)


class DerivativeSlave(Protocol):
    """What of fmpy's FMU2Slave these functions use."""

    def getRealOutputDerivatives(self, vr: Sequence[int], order: Sequence[int]) -> list[float]: ...

    def setRealInputDerivatives(self, vr: Sequence[int], order: Sequence[int], value: Sequence[float]) -> None: ...


def check_hold(order: int) -> int:
    """`order` if it is a hold order this project's FMUs take (0, 1, 2); ValueError naming it otherwise."""
    if order not in HOLD_ORDERS:
        raise ValueError(f"hold order {order!r} is not allowed: choose one of 0 (zero-order), 1 (first), 2 (second)")
    return order


def output_rates(slave: DerivativeSlave, vrs: Sequence[int], order: int) -> list[Rates]:
    """The derivatives of orders 1 to `order` of each output in `vrs`, one list per output (empty for
    order 0: nothing is asked)."""
    if check_hold(order) == 0 or not vrs:
        return [[] for _ in vrs]
    orders = [k for _ in vrs for k in range(1, order + 1)]
    values = slave.getRealOutputDerivatives([vr for vr in vrs for _ in range(order)], orders)
    return [values[i * order : (i + 1) * order] for i in range(len(vrs))]


def set_input_rates(slave: DerivativeSlave, vrs: Sequence[int], rates: Sequence[Sequence[float]]) -> None:
    """Set each input's derivatives, orders 1 to len(its rates), for the slave's next doStep (an input
    with none is held: nothing is set)."""
    refs = [vr for vr, r in zip(vrs, rates, strict=True) for _ in r]
    if refs:
        orders = [k for r in rates for k in range(1, len(r) + 1)]
        slave.setRealInputDerivatives(refs, orders, [x for r in rates for x in r])


def pass_rates(
    source: DerivativeSlave, outputs: Sequence[int], target: DerivativeSlave, inputs: Sequence[int], order: int
) -> list[Rates]:
    """Given output derivatives, set input derivatives: the `outputs` of `source` (value references)
    drive the `inputs` of `target` with a hold of `order`; returns the derivatives passed on. The
    values themselves the master sets as it always does (fmi2SetReal)."""
    rates = output_rates(source, outputs, order)
    set_input_rates(target, inputs, rates)
    return rates


def limited(value: float, rates: Rates, limit: float, step: float = 0.0) -> tuple[float, Rates]:
    """A signal through a saturation at +-limit (a torque-limited drive) over a step of `step` seconds:
    the clipped value, and its derivatives: none where the value is clipped (a held limit does not
    move), and of the highest order whose polynomial stays within the limit over the step (the drive
    cannot follow a ramp past its limit)."""
    if value > limit or value < -limit:
        return max(-limit, min(limit, value)), [0.0] * len(rates)
    kept = list(rates)
    while any(kept) and not _within(value, kept, limit, step):
        kept[max(k for k, r in enumerate(kept) if r != 0.0)] = 0.0
    return value, kept


def _within(value: float, rates: Rates, limit: float, step: float) -> bool:
    """Whether value + r1 s + r2 s^2 / 2 stays within +-limit for s in [0, step]."""
    r1, r2 = (list(rates) + [0.0, 0.0])[:2]
    points = [step]
    if r2 != 0.0 and 0.0 < -r1 / r2 < step:
        points.append(-r1 / r2)
    return all(abs(value + r1 * s + 0.5 * r2 * s * s) <= limit for s in points)


def taylor_rates(derivatives: Sequence[float], order: int) -> Rates:
    """The first `order` of a signal's known derivatives (e.g. an analytic set-point's), for
    set_input_rates."""
    return [float(d) for d in derivatives[: check_hold(order)]]
