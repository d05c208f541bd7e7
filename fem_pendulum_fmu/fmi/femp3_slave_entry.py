"""Entry script of the FMI 3.0 FemPendulum FMU (the binary loads this module by its unique name).

pythonfmu3's builder finds the class by its base list naming Fmi3Slave; the class is defined here, so
that its module is this one (shim/slave.c looks for a class defined in the entry module).
"""

from pythonfmu3 import Fmi3Slave

import fem_pendulum_fmu.fmi.slave3 as _slave3


class FemPendulum(_slave3.PendulumSlave3, Fmi3Slave):
    """Nonlinear FE pendulum hitting a wall (FMI 3.0): torque in; angle, gap, contact force, energies out."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
