"""The slave's FMI glue in-process, with a scripted model: what each situation answers and logs.

(pythonfmu turns do_step's False into fmi2Discard, or into fmi2Error when the
slave flagged the call; tests/test_fmu.py checks the statuses through the FMU.)
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from pythonfmu.enums import Fmi2Status

from fem_pendulum_fmu.fmi import slave as slave_module
from fem_pendulum_fmu.physics.protocol import ModelState, Outputs, StepFailed, check_advance_args

ROOT = Path(__file__).resolve().parents[1]


class ScriptedModel:
    """Advances like a clock; checks its arguments as every model does (physics/protocol.py); raises what the
    test asks for; state = (time, calls)."""

    fidelity = "rigid"

    def __init__(self, scene):
        self.scene, self.time, self.calls, self.fail = scene, 0.0, 0, None

    def advance(self, t_end, torque):
        check_advance_args(self.time, t_end, torque)
        if self.fail is not None:
            raise self.fail
        self.calls += 1
        self.time = t_end
        return self.outputs()

    def outputs(self):
        return Outputs(time=self.time, theta=self.time * 10.0, substeps=self.calls)

    def get_state(self):
        return ModelState("rigid", self.time, {"calls": float(self.calls)})

    def set_state(self, state):
        if state.fidelity != "rigid":
            raise ValueError("state of another fidelity")
        self.time, self.calls = state.time, int(state.scalars["calls"])


@pytest.fixture
def slave(monkeypatch):
    monkeypatch.setattr(slave_module, "create", ScriptedModel)
    s = slave_module.PendulumSlave(instance_name="test", resources=str(ROOT))
    s.setup_experiment(0.0, None, None)
    s.enter_initialization_mode()
    s.exit_initialization_mode()
    s.log_queue.clear()
    return s


def statuses(s):
    return [(m.status, m.msg) for m in s.log_queue]


def test_do_step_advances_to_t_plus_h_with_the_torque_held(slave):
    slave.set_real([slave.interface.by_name("torque").value_reference], [1.5])
    assert slave.do_step(0.0, 1e-3) is True and slave.model.time == 1e-3
    assert slave.do_step(1e-3, 4e-3) is True and slave.model.time == 5e-3
    theta = slave.interface.by_name("theta").value_reference
    assert slave.get_real([theta]) == [pytest.approx(0.05)]
    assert slave.get_integer([slave.interface.by_name("solver.substeps").value_reference]) == [2]


@pytest.mark.parametrize(
    "t, h, torque, words",
    [
        (0.0, 1e-3, math.nan, "torque = nan"),
        (0.0, 1e-3, math.inf, "torque = inf"),
        (0.0, 0.0, 0.0, "t_end = 0.0"),
        (0.0, -1e-3, 0.0, "t_end = -0.001"),
        (0.0, math.nan, 0.0, "t_end = nan"),
        (0.25, 1e-3, 0.0, "communication point 0.25"),
    ],
)
def test_invalid_input_is_refused_with_an_error_and_the_state_kept(slave, t, h, torque, words):
    slave.torque = torque
    assert slave.do_step(t, h) is False
    assert slave.model.time == 0.0 and slave.model.calls == 0
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.error and words in msg and msg.startswith("doStep refused")
    slave.torque = 0.0
    assert slave.do_step(0.0, 1e-3) is True  # the instance goes on


def test_a_value_error_of_the_model_is_an_error_with_the_state_kept(slave):
    """physics/protocol.py: advance raises ValueError for a bad argument, its state unchanged; the slave
    answers fmi2Error, does not take the model for broken, and the next good doStep goes on."""
    slave.do_step(0.0, 1e-3)
    before, outputs = slave._get_fmu_state(), slave.outputs
    slave.model.fail = ValueError("torque = 1e300 is not allowed here")
    assert slave.do_step(1e-3, 1e-3) is False
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.error and "doStep refused: torque = 1e300" in msg
    assert slave.broken is None and slave.outputs is outputs and slave._get_fmu_state().model == before.model
    slave.model.fail = None
    assert slave.do_step(1e-3, 1e-3) is True and slave.model.time == 2e-3


def test_a_bad_torque_leaves_a_real_model_as_it_was():
    """The same through the rigid model, whose advance checks the torque (the slave does not check it again)."""
    s = slave_module.PendulumSlave(instance_name="test", resources=str(ROOT))
    s.set_integer([s.interface.by_name("model.fidelity").value_reference], [2])
    s.exit_initialization_mode()
    assert s.do_step(0.0, 1e-3) is True
    before = s.model.get_state()
    s.set_real([s.interface.by_name("torque").value_reference], [math.nan])
    assert s.do_step(1e-3, 1e-3) is False
    assert "torque = nan is not allowed" in s.log_queue[-1].msg and s.log_queue[-1].status == Fmi2Status.error
    after = s.model.get_state()
    assert (after.time, after.scalars) == (before.time, before.scalars)
    assert all((after.arrays[k] == v).all() for k, v in before.arrays.items())
    s.set_real([s.interface.by_name("torque").value_reference], [0.0])
    assert s.do_step(1e-3, 1e-3) is True and s.model.time == 2e-3


def test_a_step_the_model_cannot_complete_is_discarded(slave):
    slave.do_step(0.0, 1e-3)
    before = slave.outputs
    slave.model.fail = StepFailed("Newton did not converge at dt = 1e-9")
    assert slave.do_step(1e-3, 1e-3) is False
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.discard and "Newton" in msg and "state kept" in msg
    assert slave.outputs is before and slave.model.time == 1e-3
    slave.model.fail = None
    assert slave.do_step(1e-3, 1e-3) is True  # the master may retry


def test_an_unexpected_model_exception_is_an_error_not_a_crash(slave):
    saved = slave._get_fmu_state()
    slave.model.fail = ZeroDivisionError("division by zero")
    assert slave.do_step(0.0, 1e-3) is False
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.error and "ZeroDivisionError" in msg
    slave.model.fail = None
    # nothing promises the model's state survived: no step from it until a state is restored
    assert slave.do_step(0.0, 1e-3) is False and "restore an FMU state" in slave.log_queue[-1].msg
    slave._set_fmu_state(saved)
    assert slave.do_step(0.0, 1e-3) is True


def test_parameter_after_initialisation_is_refused_and_kept(slave):
    vr = slave.interface.by_name("pendulum.E").value_reference
    slave.set_real([vr], [1.0])
    assert slave.get_real([vr]) == [2.1e11]
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.error and "pendulum.E" in msg and "after initialisation" in msg


def test_invalid_parameters_are_named_at_initialisation():
    s = slave_module.PendulumSlave(instance_name="test", resources=str(ROOT))
    s.set_real([s.interface.by_name("pendulum.nu").value_reference], [0.7])
    s.exit_initialization_mode()
    assert s.model is None
    assert any(m.status == Fmi2Status.error and "pendulum.nu = 0.7" in m.msg for m in s.log_queue)
    s.log_queue.clear()
    assert s.do_step(0.0, 1e-3) is False
    assert "doStep refused: invalid parameters" in s.log_queue[0].msg


def test_state_round_trip_and_refusals(slave):
    slave.do_step(0.0, 1e-3)
    state = slave._get_fmu_state()
    restored = slave._fmu_state_from_bytes(slave._fmu_state_to_bytes(state))
    slave.do_step(1e-3, 1e-3)
    slave._set_fmu_state(restored)
    assert (slave.model.time, slave.model.calls) == (1e-3, 1) and slave.outputs.time == 1e-3
    slave._set_fmu_state(restored)  # the same state restores twice: it was copied, not consumed
    assert slave.model.time == 1e-3
    assert slave.log_queue == []
    other = dataclasses.replace(restored, values={**restored.values, "gravity": 1.62})
    slave._set_fmu_state(other)
    assert "gravity = 1.62" in slave.log_queue[-1].msg and slave.log_queue[-1].status == Fmi2Status.error
    foreign = dataclasses.replace(restored, model=ModelState("fem", 1e-3))
    slave._set_fmu_state(foreign)
    assert "another fidelity" in slave.log_queue[-1].msg
    assert slave._fmu_state_from_bytes(b"junk") is None  # refused where the bytes arrive, not at set
    assert "not a serialised state of this FMU" in slave.log_queue[-1].msg
    assert slave._fmu_state_from_bytes(slave._fmu_state_to_bytes(other)) is None
    assert "gravity = 1.62" in slave.log_queue[-1].msg
    assert (slave.model.time, slave.model.calls) == (1e-3, 1)


def test_package_log_records_reach_the_fmi_log_under_categories(slave):
    def chatty_advance(t_end, torque):
        slave_module.LOG.debug("debug line")
        slave_module.LOG.warning("warning line")
        slave_module.LOG.error("error line")
        slave.model.time = t_end
        return slave.model.outputs()

    slave.model.advance = chatty_advance
    assert slave.do_step(0.0, 1e-3) is True
    assert [(m.msg, m.status, m.category) for m in slave.log_queue] == [
        ("debug line", Fmi2Status.ok, "logAll"),
        ("warning line", Fmi2Status.warning, "logStatusWarning"),
        ("error line", Fmi2Status.error, "logStatusError"),
    ]
    slave_module.LOG.warning("outside a call")  # not routed: the handler is attached only during calls
    assert len(slave.log_queue) == 3


@pytest.mark.parametrize(
    "call, args, words",
    [
        ("get_real", ([999],), "value reference 999 is no variable"),
        ("set_real", ([999], [1.0]), "value reference 999 is no variable"),
        ("get_integer", ([0],), "value reference 0 is torque, not of type Integer"),
        ("set_boolean", ([0], [True]), "not of type Boolean"),
        ("set_real", ([1], [0.5]), "theta (value reference 1) is an output and cannot be set"),
        ("get_string", ([0],), "not of type String"),
    ],
)
def test_a_bad_value_reference_is_an_error_not_a_crash(slave, call, args, words):
    before = slave._get_fmu_state()
    result = getattr(slave, call)(*args)
    if call.startswith("get"):
        assert len(result) == len(args[0])
    [(status, msg)] = statuses(slave)
    assert status == Fmi2Status.error and words in msg and "nothing was changed" in msg
    assert slave._get_fmu_state().values == before.values and slave.torque == before.torque
    assert slave.do_step(0.0, 1e-3) is True  # and the instance goes on
