"""The reduced model's inertia and gravity on z = (theta, q) (reduced/model.py has the equations).

M(q) = [[I0 + 2 a.q + q.q, (G^T q)^T], [G^T q, Id]] is the identity plus a border, so it is applied,
inverted and averaged in O(n), no factorisation; its parts (m00, c = G^T q, s = m00 - c.c) are what
the step and the outputs work with.
"""

from __future__ import annotations

import math

import numpy as np

from .modes import ModalBasis


class ModalMass:
    """The mass matrix M(q) of the floating frame and its O(n) algebra."""

    def __init__(self, basis: ModalBasis):
        self.n = basis.count + 1
        self.inertia0 = basis.inertia0
        self.gyro = basis.gyro  # G: the modes' gyroscopic coupling
        self.a = basis.a
        self.two_a = 2.0 * basis.a
        self.identity = np.eye(self.n)

    def parts(self, q: np.ndarray) -> tuple[float, np.ndarray, float]:
        """(m00, c, s): M(q) = [[m00, c^T], [c, Id]] and its Schur complement s = m00 - c.c."""
        c = q @ self.gyro
        m00 = self.inertia0 + float(self.two_a @ q) + float(q @ q)
        return m00, c, m00 - float(c @ c)

    def matrix(self, z: np.ndarray) -> np.ndarray:
        """M(q) as a dense matrix (the initial momenta, the contact impulse's metric, tests)."""
        m00, c, _ = self.parts(z[1:])
        M = self.identity.copy()
        M[0, 0] = m00
        M[0, 1:] = c
        M[1:, 0] = c
        return M

    def velocity(self, z: np.ndarray, p: np.ndarray) -> np.ndarray:
        """dz/dt = M(q)^-1 p."""
        _, c, s = self.parts(z[1:])
        return inverse_times(c, s, p)


def inverse_times(c: np.ndarray, s: float, p: np.ndarray) -> np.ndarray:
    """M(q)^-1 p from the parts of ModalMass.parts."""
    v = np.empty_like(p)
    v[0] = v0 = (p[0] - float(c @ p[1:])) / s
    v[1:] = p[1:] - v0 * c
    return v


def inverse_form(c: np.ndarray, s: float, p: np.ndarray) -> float:
    """p^T M(q)^-1 p (twice the kinetic energy)."""
    pq = p[1:]
    return float(pq @ pq) + (p[0] - float(c @ pq)) ** 2 / s


class Gravity:
    """g (sin theta S_x(q) + cos theta S_y(q)), S(q) = S0 + L q the first mass moment in the body frame."""

    def __init__(self, g: float, basis: ModalBasis):
        self.g = g
        self.n = basis.count + 1
        self.first_moment = basis.first_moment  # S0
        self.moment_modes = basis.moment_modes  # L, (2, m)

    def energy(self, z: np.ndarray) -> float:
        S = self.first_moment + self.moment_modes @ z[1:]
        return self.g * (math.sin(z[0]) * S[0] + math.cos(z[0]) * S[1])

    def gradient(self, z: np.ndarray) -> np.ndarray:
        """Gravity's gradient in z."""
        g = self.g
        s, c = math.sin(z[0]), math.cos(z[0])
        S = self.first_moment + self.moment_modes @ z[1:]
        grad = np.empty(self.n)
        grad[0] = g * (c * S[0] - s * S[1])
        grad[1:] = (g * s) * self.moment_modes[0] + (g * c) * self.moment_modes[1]
        return grad
