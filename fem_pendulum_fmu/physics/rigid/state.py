"""The rigid model's state, and its ModelState (the protocol's get_state / set_state).

A NamedTuple: the shared stepper (stepping.py) passes states opaquely and the model unpacks them at
every step, which a tuple does cheapest; the names are for the reader and for the ModelState's keys.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from ..protocol import ModelState, Outputs, check_state_fidelity, model_state

FIDELITY = "rigid"


class RigidState(NamedTuple):
    """The whole state of the rigid pendulum: its angle (rad, continuous, not wrapped), angular
    velocity (rad/s) and the work the torque has done since the start (J)."""

    theta: float
    omega: float
    torque_work: float

    def to_model_state(self, time: float, outputs: Outputs) -> ModelState:
        """The ModelState of this state at `time`, with the advance summary of `outputs`."""
        return model_state(FIDELITY, time, outputs, self._asdict(), {})

    @classmethod
    def from_model_state(cls, state: ModelState) -> RigidState:
        """The state a ModelState of the rigid fidelity carries; ValueError for any other ModelState,
        one lacking a value, or one with a non-finite value."""
        check_state_fidelity(state, FIDELITY)
        sc = state.scalars
        missing = [k for k in cls._fields if k not in sc]
        if missing:
            raise ValueError(f"rigid model state lacks {', '.join(missing)}")
        x = cls(*(float(sc[k]) for k in cls._fields))
        if not all(math.isfinite(v) for v in x):
            raise ValueError(f"rigid model state has non-finite values: {tuple(x)!r}")
        return x
