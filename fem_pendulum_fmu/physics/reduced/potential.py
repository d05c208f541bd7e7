"""The reduced model's potential energy: gravity + wall contact + strain, and its gradient."""

from __future__ import annotations

import numpy as np

from .contact import WallContact
from .dynamics import Gravity
from .strain import LinearStrain, NeoHookeanStrain


class Potential:
    """V(z) = gravity + contact + strain. The parts are remembered for the last z: a step's accepted
    end point is the next step's start and the outputs' state (a pure function of z, so reusing it
    changes no bit)."""

    def __init__(self, gravity: Gravity, contact: WallContact, strain: LinearStrain | NeoHookeanStrain):
        self.gravity = gravity
        self.contact = contact
        self.strain = strain
        self._memo: tuple[np.ndarray, tuple[float, float, float]] | None = None

    def parts(self, z: np.ndarray) -> tuple[float, float, float]:
        """(gravity, contact, strain) energies at z."""
        memo = self._memo
        if memo is not None and memo[0] is z:
            return memo[1]
        parts = (self.gravity.energy(z), float(self.contact.terms(z).energy), self.strain.energy(z[1:]))
        self._memo = (z, parts)
        return parts

    def remember(self, z: np.ndarray, parts: tuple[float, float, float]) -> None:
        """Take `parts` as the parts at z (the compiled step returns them with its end point)."""
        self._memo = (z, parts)

    def energy(self, z: np.ndarray) -> float:
        gravity, contact, strain = self.parts(z)
        return gravity + contact + strain

    def gradient(self, z: np.ndarray) -> np.ndarray:
        """Gradient of V in z."""
        grad = self.gravity.gradient(z) + self.contact.terms(z).gradient
        grad[1:] += self.strain.gradient(z[1:])
        return grad
