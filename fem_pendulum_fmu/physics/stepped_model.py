"""The protocol's `advance` and `outputs` for a model that stepping.py steps whole (rigid and reduced).

The FE model has its own (fem/model.py): it adds threads and its Jacobian to the state.
"""

from __future__ import annotations

from typing import Generic

import numpy as np

from .compiled_advance import advance
from .protocol import Outputs, PendulumModel, StopAt, check_advance_args, protocol_doc
from .stepping import AdvanceResult, StepControl, X
from .torque import Torque, TorqueProfile


class SteppedModel(Generic[X]):
    """`advance` and `outputs` of the protocol for a model whose whole state is `self._x`,
    stepped by the step control (rigid and reduced; the FE model adds threads and its Jacobian).

    Needs `self._x`, `self.time`, `self.control`, the `Steppable` methods and
    `self._compute_outputs(x, t, substeps)`."""

    _x: X
    time: float
    control: StepControl
    _outputs: Outputs
    last_min_gap: float

    def step(self, x: X, dt: float, torque: float) -> X | None:
        raise NotImplementedError

    def gap_and_rate(self, x: X) -> tuple[float, float]:
        raise NotImplementedError

    def contact_scales(self, x: X) -> tuple[float, float]:
        raise NotImplementedError

    def contact_force(self, x: X) -> float:
        raise NotImplementedError

    def contact_impulse(self, x0: X, x1: X, dt: float) -> np.ndarray:
        raise NotImplementedError

    def _compute_outputs(self, x: X, t: float, substeps: int) -> Outputs:
        raise NotImplementedError

    @protocol_doc(PendulumModel.advance)
    def advance(self, t_end: float, torque: Torque = 0.0, stop: StopAt | None = None) -> Outputs:
        """The shared step control (core/stepping.c) over the fidelity's state."""
        check_advance_args(self.time, t_end, torque)
        torque = torque if isinstance(torque, TorqueProfile) else float(torque)
        result = self._stepped(float(t_end), torque, stop)
        self._x = result.state
        self.time = result.end_time(float(t_end))
        self._outputs = self._compute_outputs(self._x, self.time, result.substeps)
        self.last_min_gap = result.finish(self._outputs)
        return self._outputs

    def _stepped(self, t_end: float, torque: Torque, stop: StopAt | None) -> AdvanceResult[X]:
        """The advance's steps from the current state (the core's step control over this model's Python functions;
        a model whose functions are C runs them there)."""
        return advance(self, self._x, self.time, t_end, torque, self.control, stop)

    def outputs(self) -> Outputs:
        return self._outputs
