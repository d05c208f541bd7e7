"""The FE model's sample points on the head's outer boundary.

Positions X + u are evaluated there vectorised (numpy) for what the step
control and the contact set need: the gap and its rate at the closest point,
which head elements can reach the block within a step (contact is assembled on
those only), and, for the meshed wall, the contact energy against its deformed
face.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .. import contact as wall_contact
from ..contact_time import ClosestPoint
from ..fe_boundary import head_points
from .fem_space import FemSpace, FemState


class HeadBoundary:
    """Gauss points of the head boundary (the contact forms' rule) and the contact set they decide."""

    def __init__(self, space: FemSpace):
        head = head_points(space.mesh, space.contact_order)
        self._space = space
        self.points = head.points
        self.X = space.pos(head.points)  # reference positions (P, 2)
        self.weights = head.weights
        self.elements = head.elements
        self.point_element = np.repeat(np.arange(len(head.elements)), len(head.rule))
        self.active_local: set[int] = set()  # head elements (local indices) with contact assembled
        self._closest: tuple[FemState, ClosestPoint] | None = (
            None  # (state, closest point) of the last state asked about
        )

    def positions(self, u: np.ndarray) -> np.ndarray:
        gf_u = self._space.gf_u
        gf_u.vec.FV().NumPy()[:] = u
        return self.X + gf_u(self.points)

    def active_elements(self) -> np.ndarray:
        return np.array(sorted(self.active_local), dtype=int)

    def reachable(self, xs: FemState, dt: float) -> np.ndarray:
        """Head elements (local indices) whose points could reach the block during a step of dt from xs."""
        p = self.positions(xs.u)
        dist, _, _ = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self._space.scene.block)
        gf_v = self._space.gf_v
        gf_v.vec.FV().NumPy()[:] = xs.v
        speed = np.hypot(*gf_v(self.points).T)
        reach = 3.0 * float(np.max(speed)) * dt + 1e-4
        return np.unique(self.point_element[dist < reach])

    def activate(self, bits: ngs.BitArray, elements: np.ndarray) -> None:
        """Assemble contact on exactly these head elements (bits: the step form's BitArray)."""
        bits.Clear()
        for e in self.elements[elements]:
            bits.Set(int(e))
        self.active_local = set(int(i) for i in elements)

    def covers(self, bits: ngs.BitArray, u1: np.ndarray) -> bool:
        """True if every head point inside the block at the step's end was in the active set; else widen it."""
        p = self.positions(u1)
        dist, _, _ = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self._space.scene.block)
        touching = set(int(i) for i in np.unique(self.point_element[dist < 0.0]))
        missing = touching - self.active_local
        if not missing:
            return True
        self.activate(bits, np.array(sorted(self.active_local | missing), dtype=int))
        return False

    def wall_face_shift(self, p: np.ndarray) -> np.ndarray:
        """Displacement of the deformable wall at the face points level with head points (zero if rigid)."""
        shift = np.zeros_like(p)
        if not self._space.deformable_wall:
            return shift
        b = self._space.scene.block
        near = (p[:, 0] < b.x_max + 0.01) & (p[:, 1] > b.y_min) & (p[:, 1] < b.y_max)
        if np.any(near):
            ys = p[near, 1]
            pts = self._space.mesh(np.full(ys.shape, b.x_max - 1e-9), ys)
            shift[near] = self._space.gf_u(pts)
        return shift

    def meshed_wall_contact(self, u: np.ndarray) -> tuple[float, float]:
        """Contact energy and force against the deformed wall face, integrated on the head points."""
        p = self.positions(u)
        shift = self.wall_face_shift(p)
        sc = self._space.scene
        b, h, k = sc.block, sc.pendulum.thickness, sc.contact.stiffness
        level = (p[:, 1] > b.y_min) & (p[:, 1] < b.y_max)
        pen = np.where(level, np.maximum(b.x_max + shift[:, 0] - p[:, 0], 0.0), 0.0)
        return 0.5 * h * k * float(self.weights @ (pen * pen)), h * k * float(self.weights @ pen)

    def closest_point(self, xs: FemState) -> ClosestPoint:
        """The head point closest to the (deformed) wall and its rate.

        The stepper asks for the gap and then for the contact scales of the same
        state; the last answer is kept so the boundary is evaluated once."""
        if self._closest is not None and self._closest[0] is xs:
            return self._closest[1]
        p = self.positions(xs.u)
        if self._space.deformable_wall:
            p = p - self.wall_face_shift(p)
        dist, nx, ny = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self._space.scene.block)
        i = int(np.argmin(dist))
        gf_v = self._space.gf_v
        gf_v.vec.FV().NumPy()[:] = xs.v
        vel = gf_v(self.points)[i]
        result = ClosestPoint(p, dist, i, (float(nx[i]), float(ny[i])), float(nx[i] * vel[0] + ny[i] * vel[1]))
        self._closest = (xs, result)
        return result
