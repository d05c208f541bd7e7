"""The reduced model's advance in the compiled core (core/reduced_advance.c) against the same model's Python
functions for the wall (reduced/approach.py, reduced/contact.py) around the same compiled step, on the same
step control (core/stepping.c, the Python functions called back).

Both make the same decisions from the same quantities; the core sums the gap's, rate's and scales' terms
in its own order, so states drift apart by round-off. Measured on the steel scene through the first
impact and rebound (1 s, the torque pulse): 6.5e-14 rad, the same number of internal steps in every
advance; on rubber through its first impact without the torque (0.3 s): 1.8e-13 rad. Pressed into the
wall by the torque, the rubber's chattering contact grows any change of the last bits to hundredths of
a radian (the energy stays within 4e-6 of 0.707 J either way), so rubber is compared without it.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.protocol import StepFailed
from fem_pendulum_fmu.physics.reduced.model import ReducedModel
from fem_pendulum_fmu.physics.scene import rubber, steel
from fem_pendulum_fmu.physics.stepped_model import SteppedModel
from fem_pendulum_fmu.physics.torque import TorqueProfile

THETA_TOL = 1e-9  # rad: the measured drift (6.5e-14, 1.8e-13) with a margin for another machine's libm


def pair(scene) -> tuple[ReducedModel, ReducedModel]:
    """(the core's advance, the Python functions' advance) of one scene."""
    core, python = ReducedModel(scene), ReducedModel(scene)
    python._stepped = lambda t_end, torque, stop: SteppedModel._stepped(python, t_end, torque, stop)
    return core, python


@pytest.mark.parametrize(
    ("preset", "steps", "torque"), [(steel, 1000, -1.0), (rubber, 300, 0.0)], ids=["steel", "rubber"]
)
def test_the_core_steps_as_the_python_functions(preset, steps, torque):
    core, python = pair(preset())
    impulse = 0.0
    for k in range(1, steps + 1):
        T = torque if 100 <= k <= 300 else 0.0
        a, b = core.advance(k * 1e-3, T), python.advance(k * 1e-3, T)
        assert a.solver_substeps == b.solver_substeps, k
        assert abs(a.theta - b.theta) < THETA_TOL, k
        assert abs(a.gap_min - b.gap_min) < THETA_TOL and abs(a.contact_hold - b.contact_hold) < 1e-12
        assert a.contact_force_max == pytest.approx(b.contact_force_max, rel=1e-6, abs=1e-9)
        impulse += a.contact_impulse
    assert impulse > 0.0  # through an impact


def test_a_torque_polynomial_and_a_stop_are_taken_as_the_python_functions_take_them():
    core, python = pair(steel())
    torque = TorqueProfile(-0.5, -4.0, 30.0)
    for model in (core, python):
        model.advance(0.2, torque)
    assert core.outputs().theta == pytest.approx(python.outputs().theta, abs=THETA_TOL)
    asked: list[list[tuple[float, float, float]]] = [[], []]
    for model, log in zip((core, python), asked, strict=True):
        model.advance(0.3, 0.0, stop=lambda t, g0, g1, log=log: log.append((t, g0, g1)) or t > 0.25)
    assert len(asked[0]) == len(asked[1]) > 0
    assert np.allclose(asked[0], asked[1], rtol=0.0, atol=THETA_TOL)
    assert core.time == pytest.approx(python.time, abs=1e-15) and core.time < 0.3


def test_a_failing_stop_and_too_many_steps_leave_the_state_as_it_was():
    core = ReducedModel(steel(**{"solver.max_substeps": 3}))
    before = core.get_state()

    def broken(t: float, g0: float, g1: float) -> bool:
        raise RuntimeError("the master's stop failed")

    with pytest.raises(RuntimeError, match="the master's stop failed"):
        core.advance(0.01, 0.0, stop=broken)
    with pytest.raises(StepFailed, match="more than solver.max_substeps = 3") as failed:
        core.advance(0.01, 0.0)  # 5 steps of max_step
    assert failed.value.shorter_step_helps
    after = core.get_state()
    assert after.time == before.time
    for name, array in before.arrays.items():
        assert np.array_equal(array, after.arrays[name]), name


def test_an_exception_in_a_python_models_function_reaches_the_caller_and_keeps_the_state():
    """The FE model's step and contact geometry are called back from the core's step control: an exception
    there ends the advance, the caller gets it, and the model's state is as it was."""
    model = FemModel(steel())
    model.advance(0.002)
    before = model.get_state().to_bytes()

    def broken(x):
        raise RuntimeError("the gap could not be measured")

    model.gap_and_rate = broken  # type: ignore[method-assign]
    with pytest.raises(RuntimeError, match="the gap could not be measured"):
        model.advance(0.003)
    assert model.get_state().to_bytes() == before
