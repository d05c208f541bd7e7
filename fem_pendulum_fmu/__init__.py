"""fem_pendulum_fmu: a nonlinear finite-element pendulum that hits a wall, as an FMI 2.0 co-simulation FMU.

The physics (fem_pendulum_fmu/physics/) knows nothing of FMI; fem_pendulum_fmu/fmi/ wraps it into the
FMU and fem_pendulum_fmu/masters/ drives FMUs. The public API of the physics is here, flat:

    from fem_pendulum_fmu import create, rubber
    model = create(rubber())
    out = model.advance(0.5)  # to the absolute time 0.5 s; torque 0 N.m unless given
    out.energy_total  # the FMU's output energy.total: its names, '.' written '_'

Its names load on first use (the command line and the FMU's start-up do not pay for numpy here).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .version import __version__

_EXPORTS = {
    "create": "physics.fidelity",
    "Scene": "physics.scene",
    "steel": "physics.scene",
    "rubber": "physics.scene",
    "stiff": "physics.scene",  # deprecated: steel
    "compliant": "physics.scene",  # deprecated: rubber
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
    "create",
    "problems",
    "rubber",
    "steel",
    "validate",
]

if TYPE_CHECKING:
    from .physics.fidelity import create
    from .physics.protocol import BodyField, ModelState, OutputDerivatives, Outputs, PendulumModel, StepFailed
    from .physics.scene import PRESETS, Scene, problems, rubber, steel, validate
    from .physics.scene import compliant as compliant  # deprecated: rubber
    from .physics.scene import stiff as stiff  # deprecated: steel
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
