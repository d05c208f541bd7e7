"""The inputs of one FE step as a plain value, and the step the held Newton Jacobian was assembled at.

`FemModel.step` makes one `StepLoad` a step from its start state, size, torque and contact set;
fem/step_loader.py sets the step form's inputs from it, and the Newton solver (fem/newton.py) is given
it: the solver loads a step itself only to rebuild a restored Jacobian at its `JacobianPoint`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StepLoad:
    """What a step form is loaded with besides its unknowns (arrays of a state: never changed in place)."""

    u0: np.ndarray  # start displacement
    v0: np.ndarray  # start velocity
    dt: float
    torque: float  # N.m; the forms' torque load is made from it in one place (StepInputs.torque_load_of)
    active: np.ndarray | None  # head elements (local indices) with rigid-wall contact; None: no such contact
    a0: np.ndarray | None = None  # start acceleration: the Newmark schemes' only


@dataclass(frozen=True)
class JacobianPoint:
    """The step the held Newton Jacobian was assembled at and the iterate it was assembled at: part of the
    model's state, so that a restored model re-creates the very same matrix."""

    load: StepLoad  # without a0, which the Jacobian does not depend on (a state does not carry it)
    w: np.ndarray
    dt_factorised: float = 0.0  # the step size its inertia term was rescaled to (0: load.dt, as assembled)

    @property
    def serves(self) -> float:
        """The step size the factorised Jacobian is for."""
        return self.dt_factorised or self.load.dt

    def to_entries(self) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """The ModelState scalars and arrays (copies) of this point (keys "jac_*")."""
        load = self.load
        active = np.zeros(0, dtype=int) if load.active is None else load.active
        scalars = {"jac_dt": load.dt, "jac_torque": load.torque, "jac_dt_factorised": self.dt_factorised}
        arrays = {"jac_u0": load.u0.copy(), "jac_v0": load.v0.copy(), "jac_w": self.w.copy()}
        arrays["jac_active"] = active.copy()
        return scalars, arrays

    @staticmethod
    def from_entries(scalars: dict[str, float], arrays: dict[str, np.ndarray]) -> JacobianPoint:
        """Inverse of to_entries (the arrays copied; a state without jac_dt_factorised: 0)."""
        load = StepLoad(
            arrays["jac_u0"].copy(),
            arrays["jac_v0"].copy(),
            scalars["jac_dt"],
            scalars["jac_torque"],
            arrays["jac_active"].astype(int),
        )
        return JacobianPoint(load, arrays["jac_w"].copy(), scalars.get("jac_dt_factorised", 0.0))
