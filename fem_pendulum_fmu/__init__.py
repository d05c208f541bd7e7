"""fem_pendulum_fmu: a nonlinear finite-element pendulum that hits a wall, as an FMI 2.0 co-simulation FMU.

The physics (fem_pendulum_fmu/physics/) knows nothing of FMI; fem_pendulum_fmu/fmi/ wraps it into the
FMU and fem_pendulum_fmu/masters/ drives FMUs. The public API of the physics is here, flat:

    from fem_pendulum_fmu import create, compliant
    model = create(compliant())
    out = model.advance(0.5, torque=0.0)

Its names load on first use (the command line and the FMU's start-up do not pay for numpy here).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .version import __version__

_EXPORTS = {
    "create": "physics.fidelity",
    "Scene": "physics.scene",
    "stiff": "physics.scene",
    "compliant": "physics.scene",
    "PRESETS": "physics.scene",
    "problems": "physics.scene",
    "validate": "physics.scene",
    "Outputs": "physics.protocol",
    "ModelState": "physics.protocol",
    "BodyField": "physics.protocol",
    "PendulumModel": "physics.protocol",
    "StepFailed": "physics.protocol",
    "OutputDerivatives": "physics.protocol",
    "TorqueProfile": "physics.torque",
}
__all__ = [
    "BodyField",
    "ModelState",
    "OutputDerivatives",
    "Outputs",
    "PRESETS",
    "PendulumModel",
    "Scene",
    "StepFailed",
    "TorqueProfile",
    "__version__",
    "compliant",
    "create",
    "problems",
    "stiff",
    "validate",
]

if TYPE_CHECKING:
    from .physics.fidelity import create
    from .physics.protocol import BodyField, ModelState, OutputDerivatives, Outputs, PendulumModel, StepFailed
    from .physics.scene import PRESETS, Scene, compliant, problems, stiff, validate
    from .physics.torque import TorqueProfile


def __getattr__(name: str) -> Any:
    """The public names, imported from their modules when first asked for."""
    if name not in _EXPORTS:
        raise AttributeError(f"module 'fem_pendulum_fmu' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
