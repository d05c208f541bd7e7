"""Controller in the loop: PID FMU + torque-limited drive + pendulum FMU (fixed-step fmpy master)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pendulum_closed_form as closed
import pytest

from fem_pendulum_fmu.masters.control.command import DEFAULT_SETPOINT
from fem_pendulum_fmu.masters.control.loop import drive
from fem_pendulum_fmu.masters.control.signals import parse_signal
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import Scene

MASTER_RUNS = str(Path(__file__).resolve().parent / "master_runs.py")


def run_loop(fmus, start_values: dict) -> dict:
    run = subprocess.run(
        [sys.executable, MASTER_RUNS, "loop", str(fmus[0]), str(fmus[1]), json.dumps(start_values)],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return {
        k: np.array(v) if isinstance(v, list) else v for k, v in json.loads(run.stdout.strip().splitlines()[-1]).items()
    }


@pytest.fixture(scope="module")
def fem_loop(fmus):
    return run_loop(fmus, {})  # the FMU's defaults (Scene(), test_interface): the full FE model, stiff steel pendulum


@pytest.fixture(scope="module")
def rigid_loop(fmus):
    return run_loop(fmus, {"model.fidelity": 2})


def linear_tracking_rms() -> float:
    """RMS error of the linearised loop in steady state, without the wall (rad).

    Rigid pendulum of the default scene's closed-form mass properties (tests/pendulum_closed_form.py:
    I = 0.04451 kg m^2, m g d = 1.0912 * 9.81 * 0.18165 N.m/rad) under the PID: theta/setpoint
    = C(s) / (I s^2 + m g d + C(s)), C = Kp + Ki/s + Kd s."""
    kp, ki, kd = 10.0, 4.0, 0.15  # the PID FMU's defaults (masters/pid/fem_pendulum_pid_entry.py)
    amplitude, frequency = math.radians(20.0), 0.75  # the default set-point, DEFAULT_SETPOINT
    w = 2j * math.pi * frequency
    c = kp + ki / w + kd * w
    body = closed.body(Scene())
    ratio = c / (body.inertia * w**2 + body.gravity_moment(Scene().gravity) + c)
    return abs(1 - ratio) * amplitude / math.sqrt(2)


@pytest.mark.slow
def test_tracking_error_away_from_the_wall(fem_loop, rigid_loop):
    # Measured (fem-pendulum control): 3.45 deg RMS with the FE model, 3.7 deg with the rigid one,
    # over the half-periods with a positive set-point (the wall blocks the others). The linear loop
    # lags the 0.75 Hz sine by 1.2 deg RMS in steady state (linear_tracking_rms); each positive
    # half-period starts from rest against the wall, behind a set-point already rising at 94 deg/s,
    # so the error is about 3 times the steady-state one. 5 deg bounds it with margin; under 2 deg
    # would mean the wall was not in the loop.
    assert 1.0 < math.degrees(linear_tracking_rms()) < 1.5
    for loop in (fem_loop, rigid_loop):
        assert math.radians(2.0) < loop["rms_away"] < math.radians(5.0), math.degrees(loop["rms_away"])
        assert loop["theta"].max() > math.radians(15.0)  # it does swing out towards +20 degrees
    # the stiff steel pendulum tracks like a rigid one: same error within 0.5 deg
    assert abs(fem_loop["rms_away"] - rigid_loop["rms_away"]) < math.radians(0.5)


@pytest.mark.slow
def test_every_swing_to_negative_angles_ends_on_the_wall(fem_loop, rigid_loop):
    for loop in (fem_loop, rigid_loop):
        impacts = loop["impacts"]
        # set-point negative from 0.667 s to 1.333 s (and again from 2.0 s): the controller keeps
        # driving the head into the wall, which it hits again and again (measured: 13 rebounds)
        during = impacts[(impacts > 0.66) & (impacts < 1.34)]
        assert len(during) >= 10, impacts
        assert np.all(np.diff(during) < 0.1)  # no swing in that half-period escapes the wall
        assert not np.any((impacts > 0.1) & (impacts < 0.66)), impacts  # nor hits it while swinging out
        assert loop["gap"].min() < 0.0  # the samples do catch penetration
        assert np.all(loop["theta"] > -math.radians(1.0))  # the wall holds it
        assert np.max(np.abs(loop["torque"])) <= 15.0


@pytest.mark.slow
def test_energy_balance_holds_in_the_loop(fem_loop):
    swing = swing_energy(Scene())  # fem_loop runs the FMU's defaults, Scene()'s
    assert np.max(np.abs(fem_loop["balance"])) < 1e-3 * swing


def test_drive_limits_the_torque():
    assert drive(40.0, 15.0) == 15.0 and drive(-40.0, 15.0) == -15.0 and drive(3.0, 15.0) == 3.0
    setpoint = parse_signal(DEFAULT_SETPOINT, "angle", "--setpoint")
    assert abs(setpoint(1 / 3) - math.radians(20.0)) < 1e-12  # a quarter period of 0.75 Hz


def test_pid_saturates_and_stops_integrating():
    from fem_pendulum_fmu.masters.pid.fem_pendulum_pid_entry import Pid

    pid = Pid(kp=10.0, ki=4.0, kd=0.0, u_max=15.0)
    assert pid.update(1.0, 0.0, 1e-3) == pytest.approx(10.004)
    assert pid.update(10.0, 0.0, 1e-3) == 15.0  # saturated
    assert pid.integral == pytest.approx(1e-3)  # the saturated step did not wind up the integral
