"""The drive torque over one advance: a constant, or a polynomial in time given at the advance's start.

A co-simulation master that knows how the torque changes over a communication step can pass its
value and first two time derivatives at the step's start (FMI 2.0 input interpolation, docs/reference/fmi2.md):

    T(s) = value + rate s + curvature s^2 / 2,   s = time since the advance's start.

Every scheme integrates a constant torque as an impulse T dt per internal step; with a polynomial it
takes the exact mean of T over the internal step (`mean`), so the step's impulse is the exact
integral of T and its torque work, mean torque times the rotation increment, keeps each scheme's
energy balance as exact as with a constant torque. A constant torque stays a float all the way down:
the schemes compute exactly what they computed before profiles existed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class TorqueProfile:
    """T(s) = value + rate s + curvature s^2 / 2, s the time since the start of the advance it is given to.

    Parameters
    ----------
    value : float
        T at the advance's start (N.m).
    rate : float, default 0.0
        dT/ds there (N.m/s).
    curvature : float, default 0.0
        d^2T/ds^2 (N.m/s^2).
    """

    value: float
    rate: float = 0.0
    curvature: float = 0.0

    @property
    def constant(self) -> bool:
        return self.rate == 0.0 and self.curvature == 0.0

    def at(self, s: float) -> float:
        """T(s)."""
        if self.constant:
            return self.value
        return self.value + s * (self.rate + 0.5 * s * self.curvature)

    def derivative(self, s: float) -> float:
        """dT/ds at s."""
        return self.rate + s * self.curvature

    def mean(self, s0: float, s1: float) -> float:
        """The exact mean of T over [s0, s1]: the constant torque with the same impulse."""
        if self.constant:
            return self.value
        return self.value + 0.5 * (s0 + s1) * self.rate + (s0 * s0 + s0 * s1 + s1 * s1) * self.curvature / 6.0

    def largest(self, s0: float, s1: float) -> float:
        """max |T| over [s0, s1] (at an end, or at the parabola's vertex inside)."""
        if self.constant:
            return abs(self.value)
        found = max(abs(self.at(s0)), abs(self.at(s1)))
        if self.curvature != 0.0:
            vertex = -self.rate / self.curvature
            if s0 < vertex < s1:
                found = max(found, abs(self.at(vertex)))
        return found

    def problems(self) -> list[str]:
        """Why this is not a torque a model can take (each coefficient must be a finite number)."""
        named = (
            ("torque", self.value, "N.m"),
            ("its rate", self.rate, "N.m/s"),
            ("its curvature", self.curvature, "N.m/s^2"),
        )
        return [
            f"{name} = {value!r} is not allowed: it must be a finite number ({unit})"
            for name, value, unit in named
            if not math.isfinite(value)
        ]


Torque = float | TorqueProfile
"""What `advance` takes: a constant torque (N.m), or a TorqueProfile over the advance."""


def as_profile(torque: Torque) -> TorqueProfile:
    """The profile of a torque (a float is a constant profile)."""
    return torque if isinstance(torque, TorqueProfile) else TorqueProfile(float(torque))
