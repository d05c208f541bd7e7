"""The reduced model's state, typed, and its form as the protocol's ModelState."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..protocol import ModelState, Outputs, check_state_fidelity, model_state

FIDELITY = "reduced"


class ReducedState(NamedTuple):
    """z = (theta, q), the momenta p = M(q) dz/dt and the torque's work so far (what the energy
    balance counts against). A NamedTuple: the stepper passes states around opaquely, and a step
    builds one as cheaply as a bare tuple."""

    z: np.ndarray
    p: np.ndarray
    torque_work: float

    def to_model_state(self, time: float, outputs: Outputs) -> ModelState:
        """The ModelState of this state at `time`, the advance summary taken from `outputs`."""
        return model_state(
            FIDELITY, time, outputs, {"torque_work": self.torque_work}, {"z": self.z.copy(), "p": self.p.copy()}
        )

    @classmethod
    def from_model_state(cls, state: ModelState, n: int) -> ReducedState:
        """The state `state` carries for a model of n = 1 + modes coordinates; ValueError if it does not fit."""
        check_state_fidelity(state, FIDELITY)
        z, p = state.arrays.get("z"), state.arrays.get("p")
        if z is None or p is None or z.shape != (n,) or p.shape != (n,) or "torque_work" not in state.scalars:
            raise ValueError(f"state does not fit this reduced model ({n - 1} modes: z and p of length {n})")
        x = cls(z.astype(float).copy(), p.astype(float).copy(), float(state.scalars["torque_work"]))
        if not (np.all(np.isfinite(x.z)) and np.all(np.isfinite(x.p)) and math.isfinite(x.torque_work)):
            raise ValueError("reduced model state has non-finite values")
        return x
