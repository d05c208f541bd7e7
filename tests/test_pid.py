"""The PID controller FMU (fem_pendulum_fmu/masters/pid/): its control law with held inputs and with
input derivatives, the derivatives of its output, no vanishing step in its derivative term, and its
FMU state: a rollback continues bit-identically (through the FMU, in fresh interpreters: @isolated).
"""

from __future__ import annotations

import math

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from isolated import isolated

from fem_pendulum_fmu.masters.pid.fem_pendulum_pid_entry import Pid

H = 1e-3


def errors(n):
    """A swinging error sample sequence (setpoint 0.2, measurement a sine)."""
    return [(0.2, 0.3 * math.sin(0.05 * k)) for k in range(n)]


def test_held_inputs_give_the_rectangle_integral_and_the_backward_difference():
    pid, integral, last = Pid(), 0.0, None
    for sp, meas in errors(20):
        e = sp - meas
        u = pid.update(sp, meas, H)
        integral += e * H
        rate = 0.0 if last is None else (e - last) / H
        assert u == 10.0 * e + 4.0 * integral + 0.15 * rate  # the same operations: the same bits
        last = e


def test_a_vanishing_step_does_not_saturate_the_demand():
    """A master that adds up time ends on a step of 1e-13 s: the derivative term divides the last change
    of the error by the time between its samples (the previous 1 ms step), not by that step."""
    pid = Pid()
    for sp, meas in errors(30):
        u_before = pid.update(sp, meas, H)
    sp, meas = 0.2, 0.3 * math.sin(0.05 * 30)
    u_tiny = pid.update(sp, meas, 1e-13)
    # measured 0.097 N.m apart: the proportional term's response to the new sample
    assert abs(u_tiny) < 15.0 and abs(u_tiny - u_before) < 0.5
    # the step after it: its backward difference would be over 1e-13 s; the last estimate is kept
    u_after = pid.update(sp, meas + 1e-9, H)
    assert abs(u_after - u_tiny) < 0.01  # measured 4e-4 N.m
    old_rule = 0.15 * ((sp - meas) - (0.2 - 0.3 * math.sin(0.05 * 29))) / 1e-13  # what dividing by the step gave
    assert abs(old_rule) > 15.0


def test_input_derivatives_give_the_exact_rate_and_integral_and_the_output_derivatives():
    pid = Pid()
    pid.update(0.2, 0.1, H)
    integral = pid.integral
    e, e1, e2 = 0.1, 0.5 - 2.0, 3.0 - 40.0  # setpoint (0.2, 0.5, 3), measurement (0.1, 2, 40)
    u = pid.update(0.2, 0.1, H, ((0.5, 3.0), (2.0, 40.0)))
    step_integral = e * H + e1 * H * H / 2 + e2 * H**3 / 6
    assert u == pytest.approx(10.0 * e + 4.0 * (integral + step_integral) + 0.15 * e1, rel=1e-14)
    assert pid.u_rate == pytest.approx(10.0 * e1 + 4.0 * e + 0.15 * e2, rel=1e-14)
    assert pid.u_curvature == pytest.approx(10.0 * e2 + 4.0 * e1, rel=1e-14)
    pid.update(5.0, 0.0, H, ((0.5, 3.0), (2.0, 40.0)))  # saturated: the output holds at its limit
    assert pid.u == 15.0 and pid.u_rate == pid.u_curvature == 0.0


class Controller:
    """The PID FMU through fmpy, initialised with its defaults."""

    def __init__(self, fmu):
        md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)), modelIdentifier="PidController")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def step(self, measurement, rates=None):
        self.fmu.setReal([self.vr["setpoint"], self.vr["measurement"]], [0.2, measurement])
        if rates is not None:
            self.fmu.setRealInputDerivatives([self.vr["measurement"]] * 2, [1, 2], list(rates))
        self.fmu.doStep(self.t, H)
        self.t += H
        u = self.vr["u"]
        return [*self.fmu.getReal([u]), *self.fmu.getRealOutputDerivatives([u, u], [1, 2])]


@isolated
def test_the_pid_fmu_rolls_back_bit_identically_and_takes_derivatives(fmus, tmp_path):
    pid = Controller(fmus[1])
    for k in range(5):
        pid.step(0.01 * k)
    pid.fmu.setRealInputDerivatives([pid.vr["measurement"]], [1], [0.7])  # set before the state is taken
    state, t = pid.fmu.getFMUstate(), pid.t
    blob = bytes(pid.fmu.serializeFMUstate(state))

    def run(inst):
        return [inst.step(0.05), inst.step(0.05, (0.7, -3.0))] + [inst.step(0.06 + 0.01 * k) for k in range(3)]

    first = run(pid)
    pid.fmu.setFMUstate(state)
    pid.t = t
    assert run(pid) == first
    other = Controller(fmus[1])
    other.fmu.setFMUstate(other.fmu.deSerializeFMUstate(blob))
    other.t = t
    assert run(other) == first
    # the state carried measurement' = 0.7: e' = -0.7, e = 0.15 (no e'': 0)
    assert first[0][1:] == pytest.approx([10.0 * -0.7 + 4.0 * 0.15, 4.0 * -0.7])
    assert first[1][1:] == pytest.approx([10.0 * -0.7 + 4.0 * 0.15 + 0.15 * 3.0, 10.0 * 3.0 + 4.0 * -0.7])
    # then held inputs again (the derivatives went with the step): e' the backward difference, (0.14 - 0.15) / H
    assert first[2][1:] == pytest.approx([10.0 * -10.0 + 4.0 * 0.14, 4.0 * -10.0])
