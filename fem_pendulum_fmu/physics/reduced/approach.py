"""What the step control (stepping.py) asks of the reduced model about the wall: the gap and its rate,
and the contact's duration and depth scales; and the gap output.

Far from the block the head's bounding circle answers (a lower bound of the gap is all the stepper
needs there); near it the closest head point. Both are remembered for the last state asked about:
the stepper asks for the gap, then the scales, of one state, and the outputs for the gap of the
accepted one.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..contact_time import ClosestPoint, contact_time_scale, effective_mass
from ..rigid import arc_contact as rigid_contact
from .dynamics import ModalMass
from .head import HeadPoints
from .state import ReducedState

SCALE_BAND = 0.02  # m: contact scales consider head points at most this far behind the closest (penetrations < 2 mm)
FAR_GAP = 0.01  # m: beyond this the stepper sees the head's bounding circle instead of every point


class WallApproach:
    """The gap, rate and contact scales of states (stepping.Steppable's gap_and_rate and contact_scales)."""

    def __init__(
        self,
        head: HeadPoints,
        mass: ModalMass,
        exact_gap: Callable[[np.ndarray], float],
        hk: float,
        max_step: float,
        contact_on: bool,
    ):
        self.head = head
        self.mass = mass
        self.exact_gap = exact_gap  # the smallest distance of all head points (the compiled kernel's or head.gap)
        self.hk = hk
        self.max_step = max_step  # the stepper's largest step: how far ahead the scales look
        self.contact_on = contact_on
        self._head_centre_depth = -head.centre[1]
        self._closest_memo: tuple[ReducedState, ClosestPoint, np.ndarray] | None = None
        self._circle_memo: tuple[ReducedState, tuple[float, float]] | None = None

    def gap_and_rate(self, x: ReducedState) -> tuple[float, float]:
        """Gap and rate of the closest head point; beyond FAR_GAP, the bounding circle's gap and rate
        instead. Contact off: (inf, 0), nothing to step towards."""
        if not self.contact_on:
            return math.inf, 0.0
        circle_gap, circle_rate = self.circle_gap(x)
        if circle_gap > FAR_GAP:
            return circle_gap, circle_rate
        closest = self.closest(x)
        return closest.gap, closest.rate

    def contact_scales(self, x: ReducedState) -> tuple[float, float]:
        """Contact duration and depth from the rigid-body effective mass at the closest point (as fem/model.py)."""
        if not self.contact_on:
            return math.inf, 0.0
        circle_gap, circle_rate = self.circle_gap(x)
        if circle_gap > FAR_GAP and circle_gap + 2.0 * self.max_step * min(circle_rate, 0.0) > 0.0:
            return math.inf, 0.0  # no contact within the next two largest steps
        closest = self.closest(x)
        assert self._closest_memo is not None
        weights = self.head.weights[self._closest_memo[2]]
        m_eff = effective_mass(self.mass.inertia0, closest.arm, self._head_centre_depth)
        dist = closest.gaps
        near = dist < dist[closest.index] + SCALE_BAND  # points further behind the closest one cannot take part
        return contact_time_scale(dist[near], weights[near], m_eff, closest.rate, self.hk)

    def output_gap(self, x: ReducedState) -> float:
        """The gap output at x: the closest point's if the stepper just asked for it, else the exact gap."""
        memo = self._closest_memo
        if memo is not None and memo[0] is x:
            return memo[1].gap
        return self.exact_gap(x.z)

    def closest(self, x: ReducedState) -> ClosestPoint:
        """The head point closest to the wall and its rate."""
        if self._closest_memo is not None and self._closest_memo[0] is x:
            return self._closest_memo[1]
        z = x.z
        points, world, dist = self.head.near(z, SCALE_BAND)
        i = int(np.argmin(dist))
        px, py = float(world[i, 0]), float(world[i, 1])
        n_x, n_y = self.head.box.normal(px, py)
        v = self.mass.velocity(z, x.p)
        s, c = math.sin(z[0]), math.cos(z[0])
        ex, ey = self.head.phi[points[i]] @ v[1:]
        w = float(v[0])
        rate = n_x * (-w * py + c * ex - s * ey) + n_y * (w * px + s * ex + c * ey)
        result = ClosestPoint(world, dist, i, (n_x, n_y), rate)
        self._closest_memo = (x, result, points)
        return result

    def circle_gap(self, x: ReducedState) -> tuple[float, float]:
        """Gap of the head's bounding circle to the block and its rate: a lower bound of the gap."""
        if self._circle_memo is not None and self._circle_memo[0] is x:
            return self._circle_memo[1]
        cx, cy, radius = self.head.circle(x.z)
        d, qx, qy = rigid_contact.point_box(cx, cy, self.head.block)
        if d <= 0.0:  # the centre inside the block: no bound from the circle
            result = (-radius, 0.0)
        else:
            nx, ny = (cx - qx) / d, (cy - qy) / d
            result = (d - radius, float(self.mass.velocity(x.z, x.p)[0]) * (-cy * nx + cx * ny))
        self._circle_memo = (x, result)
        return result
