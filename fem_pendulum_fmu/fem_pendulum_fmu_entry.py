"""Entry script of the FemPendulum FMU (pythonfmu loads this module by its unique name).

The slave class is defined here, as a subclass, and the module pins extra
references to itself: pythonfmu 0.7.0 releases a reference to the entry
module it does not own each time an instance is created, and without these
the module is freed after the first instance, so that a second instance in
the same process looks for its class in whatever module took the memory.
"""
import sys

import fem_pendulum_fmu.models.fem  # noqa: F401  (every import happens here, before the first instance)
from fem_pendulum_fmu.slave import PendulumSlave, pin_module

pin_module(sys.modules[__name__])


class FemPendulum(PendulumSlave):
    """Nonlinear FE pendulum hitting a wall: torque in; angle, gap, contact force, energies out."""
