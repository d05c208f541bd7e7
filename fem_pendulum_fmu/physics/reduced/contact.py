"""The wall's penalty contact on the head points (the law of fem/contact_law.py, summed in the deformed
configuration): its energy, gradient, Gauss-Newton Hessian and force, and the impulse a step applies."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .dynamics import ModalMass
from .head import HeadPoints


class ContactTerms(NamedTuple):
    """The contact at one z."""

    energy: float
    gradient: np.ndarray  # (n,) in z
    hessian: np.ndarray  # (n, n) Gauss-Newton
    force: np.ndarray  # (2,) on the body


# the compiled kernel's contact: (energy, gradient, Hessian, force), or None with no head point inside
CompiledContact = Callable[[np.ndarray], "tuple | None"]


class WallContact:
    """The contact terms at z, remembered by z's bytes (a step asks for the same few points again).
    Out of reach of the block, or with contact off: one shared read-only zero result, `none`,
    nothing allocated (compare with `is`)."""

    def __init__(
        self, head: HeadPoints, mass: ModalMass, hk: float, contact_on: bool, compiled: CompiledContact | None
    ):
        self.head = head
        self.mass = mass
        self.hk = hk  # thickness times the penalty stiffness
        self.contact_on = contact_on
        self.n = n = head.m + 1
        zeros = (np.zeros(n), np.zeros((n, n)), np.zeros(2))
        for array in zeros:
            array.flags.writeable = False
        self.none = ContactTerms(0.0, *zeros)
        self._compiled = compiled
        self._evaluate = self.evaluate if compiled is None else self._evaluate_compiled
        self._memo: dict[bytes, ContactTerms] = {}

    def terms(self, z: np.ndarray) -> ContactTerms:
        if not (self.contact_on and self.head.may_touch(z)):
            return self.none
        key = z.tobytes()
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        result = self._evaluate(z)
        if len(self._memo) > 32:
            self._memo.clear()
        self._memo[key] = result
        return result

    def force(self, z: np.ndarray) -> float:
        """Magnitude of the wall's force on the head at z (N)."""
        return float(np.hypot(*self.terms(z).force))

    def _evaluate_compiled(self, z: np.ndarray) -> ContactTerms:
        assert self._compiled is not None
        terms = self._compiled(z)
        return self.none if terms is None else ContactTerms(*terms)

    def evaluate(self, z: np.ndarray) -> ContactTerms:
        """The terms summed over the head points inside the block (numpy form of the compiled
        kernel's). Inside, the signed distance is max(qx, qy) < 0 and its gradient the nearer face's
        normal (box.Box's values for such points, computed here without its general case)."""
        head, box = self.head, self.head.box
        candidates, world = head.candidates(z, 0.0, 0.0)
        blk = head.block
        px, py = world[:, 0], world[:, 1]
        local_inside = np.flatnonzero((px < blk.x_max) & (px > blk.x_min) & (py < blk.y_max) & (py > blk.y_min))
        if not local_inside.size:
            return self.none
        inside = candidates[local_inside]
        pts = world[local_inside]
        ex, ey = pts[:, 0] - box.cx, pts[:, 1] - box.cy
        qx, qy = np.abs(ex) - box.hx, np.abs(ey) - box.hy
        x_face = qx >= qy
        depth = -np.maximum(qx, qy)
        normal = np.empty_like(pts)  # outward: the force direction
        normal[:, 0] = np.where(x_face, np.sign(ex), 0.0)
        normal[:, 1] = np.where(x_face, 0.0, np.sign(ey))
        w = head.weights[inside] * self.hk
        energy = 0.5 * float(w @ (depth * depth))
        # d depth / dz = -n . dx/dz with dx/dtheta = J x, dx/dq = R phi
        s, c = math.sin(z[0]), math.cos(z[0])
        rn = normal @ np.array([[c, -s], [s, c]])  # rows: (R^T n)^T
        D = np.empty((len(inside), self.n))  # d depth / dz
        D[:, 0] = normal[:, 0] * pts[:, 1] - normal[:, 1] * pts[:, 0]
        D[:, 1:] = -np.matmul(rn[:, None, :], head.phi[inside])[:, 0, :]
        grad = D.T @ (w * depth)
        hess = D.T @ (w[:, None] * D)
        force = (w * depth) @ normal
        return ContactTerms(energy, grad, hess, force)

    def impulse(self, z0: np.ndarray, z1: np.ndarray, dt: float) -> np.ndarray:
        """The step's contact impulse (N.s, vector). The step applies the contact's share of the
        discrete gradient, Gc = gc(zm) + (C(z1) - C(z0) - gc(zm).dz) / (dz.M dz) M dz (the Gonzalez
        correction is linear in the energy, so the shares of gravity, contact and strain add up to
        the step's); Gc[0] is minus the contact moment about the pivot. The force is the midpoint's
        penalty force scaled to that moment, so the impulse's moment is exactly the scheme's
        contact angular impulse. A step whose midpoint is out of contact (the step onto the wall, aimed
        at the onset): the force at the end in contact, scaled the same way."""
        if not self.contact_on:
            return np.zeros(2)
        dz, zm = z1 - z0, 0.5 * (z0 + z1)
        gcm = self.terms(zm).gradient
        Wdz = self.mass.matrix(zm) @ dz
        denom = float(dz @ Wdz)
        gc = gcm + ((self.terms(z1).energy - self.terms(z0).energy - gcm @ dz) / denom) * Wdz if denom > 0.0 else gcm
        for z in (zm, z1, z0):
            _, grad, _, force = self.terms(z)
            if grad[0] != 0.0:
                return dt * (gc[0] / grad[0]) * force
        return np.zeros(2)
