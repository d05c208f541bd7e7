"""Entry script of the FemPendulum FMU (pythonfmu loads this module by its unique name).

The slave class is defined here, as a subclass, so that pythonfmu 0.7.0 keeps
finding it when several instances live in one process.
"""
from fem_pendulum_fmu.slave import PendulumSlave


class FemPendulum(PendulumSlave):
    """Nonlinear FE pendulum hitting a wall: torque in; angle, gap, contact force, energies out."""
