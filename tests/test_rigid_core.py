"""The rigid fidelity in the compiled core (core/rigid_model.c, core/rigid_advance.c) against the same law and
step in Python (rigid/arc_contact.py, rigid/solve.py, called back from the core's step control)."""

from __future__ import annotations

import numpy as np
import pytest

from fem_pendulum_fmu.physics.rigid.model import RigidModel
from fem_pendulum_fmu.physics.scene import steel
from fem_pendulum_fmu.physics.stepped_model import SteppedModel

# the head touches the default wall at theta = 0: angles from free flight to 12.5 mm deep (the whole block's
# thickness), the head on one face (whole segments) and across the block's edges; with the block's top lowered
# to the head centre's height (-0.24 m) every contact is across its corner
ANGLES = np.linspace(-0.1, 0.02, 1201)


@pytest.mark.parametrize("wall", [{}, {"block.y_max": -0.24}], ids=["face", "corner"])
def test_the_cores_contact_law_and_gap_are_arc_contacts(wall):
    """Energy, force and the energy's derivatives to 1e-12 of their largest, gap and slope to 1e-15 m: the core
    makes the same operations in the same order (measured: equal bit for bit on both walls); the bounds leave
    room for another libm's last bits."""
    model = RigidModel(steel(**wall))
    core = np.array([model.contact_energy(q) for q in ANGLES])
    python = np.array([model._contact(float(q))[1] for q in ANGLES])
    assert np.count_nonzero(core[:, 0]) > 100  # in contact over many angles
    for column in range(5):
        scale = np.max(np.abs(python[:, column]))
        assert np.max(np.abs(core[:, column] - python[:, column])) <= 1e-12 * scale
    gaps = np.array([model.geometric_gap(q) for q in ANGLES])
    reference = np.array([model.python_gap(float(q)) for q in ANGLES])
    assert np.max(np.abs(gaps - reference)) <= 1e-15


def test_the_cores_advance_steps_as_the_python_step():
    """2 s of the torque pulse through the impacts: the same internal steps in every advance, theta within
    1e-9 rad (measured 7.5e-14: the core's free-flight steps take one Newton update where the Python step's
    iterate, both converged)."""
    core, python = RigidModel(steel(theta0=0.2)), RigidModel(steel(theta0=0.2))
    python._stepped = lambda t_end, torque, stop: SteppedModel._stepped(python, t_end, torque, stop)
    impulse = 0.0
    for k in range(1, 2001):
        T = -1.0 if 100 <= k <= 300 else 0.0
        a, b = core.advance(k * 1e-3, T), python.advance(k * 1e-3, T)
        assert a.solver_substeps == b.solver_substeps, k
        assert abs(a.theta - b.theta) < 1e-9, k
        assert abs(a.energy_total - b.energy_total) < 1e-12 and abs(a.contact_hold - b.contact_hold) < 1e-12
        impulse += a.contact_impulse
    assert impulse > 0.0
