"""The FE model's omega output is the angular velocity of a rigid rotation at any angle.

(It was omega (2 cos theta - 1) before: the displacement's part of the angular
momentum had the wrong sign, invisible at theta = 0.)"""

from __future__ import annotations

import math

import pytest

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.scene import stiff


@pytest.mark.parametrize("degrees", [0.0, 20.0, 60.0, -120.0])
def test_omega_of_a_rigid_rotation(degrees):
    model = create(stiff(**{"model.mesh_size": 0.06, "theta0": math.radians(degrees), "omega0": 1.5}))
    out = model.outputs()
    assert out.theta == pytest.approx(math.radians(degrees), abs=1e-7)  # the rotation interpolated on the curved mesh
    assert out.omega == pytest.approx(1.5, rel=1e-8)
