"""Entry script of the FemPendulum FMU (pythonfmu loads this module by its unique name).

pythonfmu 0.7.0 keeps only a borrowed hold on this module's globals: unless a
function defined here references them (through its __globals__), they are
released after the first instance and a second instance in the same process
fails to find its class. Hence the explicit __init__ below.
"""

import fem_pendulum_fmu.fmi.slave as _slave


class FemPendulum(_slave.PendulumSlave):
    """Nonlinear FE pendulum hitting a wall: torque in; angle, gap, contact force, energies out."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
