"""fem_pendulum_fmu: a nonlinear finite-element pendulum that hits a wall, as an FMI 2.0 co-simulation FMU.

The physics (scene, models, stepping) knows nothing of FMI; `slave` and
`build_fmu.py` wrap it. Start with `fem_pendulum_fmu.physics.fidelity.create(scene)`.
"""

__version__ = "0.1.0"
