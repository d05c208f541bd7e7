"""Time derivatives of a model's continuous outputs at its current state (plain data, no FMI).

A co-simulation master extrapolates an output over the next communication step from its first and
second time derivatives (FMI 2.0 output derivatives, docs/reference/fmi2.md). Two ways to get them, both
from the state the model is in and the torque it will see:

* `flow_derivatives`, for a model whose equations of motion are a vector field dx/dt = f(x, T)
  over a small state vector (rigid, reduced): with F = f(x, T(0)) and its rate along the motion
  dF/dt = Df F + df/dT T'(0), every output y(x) has
      y'  = Dy F,
      y'' = D2y[F, F] + Dy dF/dt,
  each directional derivative a central difference of y (or f) over the motion step F or step^2 dF/dt. The errors are
  round-off and the differences' truncation over a motion of `step` seconds; the outputs' own time
  scale (a fast elastic mode, a short impact) does not enter, since no trajectory is integrated.
* `probe_derivatives`, for a model without such a field at hand (fem, whose acceleration needs the
  constrained mass-matrix solve its step does): three probe advances of `step` seconds from the
  state, then the state restored, so the model continues exactly as if never probed. One-sided
  differences of four points: y' to O(step^3), y'' to O(step^2); the scheme's own steps are those
  of a modified equation to O(step^2), so the derivatives are the scheme's, to that order.

theta' is the omega output, theta'' its rate (theta is a proxy angle wrapped to [-pi, pi]; the pair
is what masters see); the other outputs are differentiated as they are reported.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .protocol import CONTINUOUS_OUTPUTS, OutputDerivatives, Outputs, PendulumModel
from .torque import TorqueProfile

Flow = Callable[[np.ndarray, float], np.ndarray]  # (state, torque) -> d state / dt
Observe = Callable[[np.ndarray], Outputs]  # state -> its outputs

DIFFERENTIATED = tuple(name for name in CONTINUOUS_OUTPUTS if name != "theta")  # theta' is omega
# the motion (s) of flow_derivatives' differences: in free flight the outputs' round-off over 1e-5 s of motion
# is ~1e-6 of their second derivatives; in an impact a ten-thousandth of its duration keeps the penalty
# law's d^2.5 smooth over the difference (the rigid steel impact's energy rates balance to 1e-8 there; a
# thousandth left 6e-6), the gravity energy's round-off then ~2 % of its (small) second derivative
FLOW_STEP = 1e-5
IMPACT_SHARE = 1e-4


def flow_step(contact_duration: float) -> float:
    """The step of flow_derivatives for a contact of the estimated duration (inf: none in view)."""
    return min(FLOW_STEP, IMPACT_SHARE * contact_duration)


def _values(outputs: Outputs) -> np.ndarray:
    return np.array([float(getattr(outputs, name)) for name in DIFFERENTIATED])


def _assemble(time: float, omega: float, first: np.ndarray, second: np.ndarray) -> OutputDerivatives:
    """theta's derivatives from omega's, the rest as differentiated."""
    d1 = dict(zip(DIFFERENTIATED, map(float, first), strict=True))
    d2 = dict(zip(DIFFERENTIATED, map(float, second), strict=True))
    return OutputDerivatives(time, {"theta": omega, **d1}, {"theta": d1["omega"], **d2})


def flow_derivatives(
    x: np.ndarray, flow: Flow, observe: Observe, torque: TorqueProfile, time: float, step: float
) -> OutputDerivatives:
    """y' and y'' of the continuous outputs at state x moving along dx/dt = flow(x, T(s)), s from now.
    `step` (s): the motion over which the directional differences are taken."""
    now = observe(x)
    y0 = _values(now)
    F = flow(x, torque.at(0.0))
    F_rate = (flow(x + step * F, torque.at(step)) - flow(x - step * F, torque.at(-step))) / (2.0 * step)
    y_plus, y_minus = _values(observe(x + step * F)), _values(observe(x - step * F))
    first = (y_plus - y_minus) / (2.0 * step)
    # dF/dt moves the state by step^2 dF/dt over the difference: the motion's second-order part, as small as
    # the first-order one's, step F (dF/dt of an impact is far larger than F / step)
    square = step * step
    along_rate = (_values(observe(x + square * F_rate)) - _values(observe(x - square * F_rate))) / (2.0 * square)
    second = (y_plus - 2.0 * y0 + y_minus) / (step * step) + along_rate
    return _assemble(time, float(now.omega), first, second)


def probe_derivatives(model: PendulumModel, torque: TorqueProfile, step: float) -> OutputDerivatives:
    """y' and y'' of the continuous outputs of `model` at its state, from three probe advances of `step`
    seconds under `torque`; the model's state is restored afterwards (also when a probe fails)."""
    saved, t0 = model.get_state(), model.time
    now = model.outputs()
    points = [_values(now)]
    try:
        for k in range(1, 4):
            s = (k - 1) * step
            piece = TorqueProfile(torque.at(s), torque.derivative(s), torque.curvature)
            points.append(_values(model.advance(t0 + k * step, piece)))
    finally:
        model.set_state(saved)
    y0, y1, y2, y3 = points
    first = (-11.0 * y0 + 18.0 * y1 - 9.0 * y2 + 2.0 * y3) / (6.0 * step)
    second = (2.0 * y0 - 5.0 * y1 + 4.0 * y2 - y3) / (step * step)
    return _assemble(t0, float(now.omega), first, second)
