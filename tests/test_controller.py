"""Controller in the loop: PID FMU + torque-limited drive + pendulum FMU (fixed-step fmpy master)."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fem_pendulum_fmu.host_env import host_environment
from fem_pendulum_fmu.masters.controller_loop import LoopSettings, drive

ROOT = Path(__file__).resolve().parents[1]

LOOP = """
import json, math, sys
from pathlib import Path
from fem_pendulum_fmu.masters.controller_loop import run_loop, tracking_error
r = run_loop(Path(sys.argv[1]), Path(sys.argv[2]), stop_time=2.0, step=1e-3)
print(json.dumps({"rms_away": tracking_error(r), "theta": r["theta"].tolist(), "gap": r["gap"].tolist(),
                  "torque": r["torque"].tolist(), "setpoint": r["setpoint"].tolist(),
                  "balance": (r["energy.total"] - r["energy.total"][0] - r["energy.torque_work"]).tolist()}))
import os; sys.stdout.flush(); os._exit(0)  # skip interpreter teardown with the FMUs loaded
"""


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--output", str(out / "FemPendulum.fmu")],
                   check=True, cwd=ROOT, capture_output=True)
    run = subprocess.run([sys.executable, "-c", LOOP, str(out / "FemPendulum.fmu"), str(out / "PidController.fmu")],
                         check=True, capture_output=True, text=True)
    import json

    return {k: np.array(v) if isinstance(v, list) else v for k, v in json.loads(run.stdout.strip().splitlines()[-1]).items()}


def test_tracking_error_away_from_the_wall(loop):
    # Measured 3.5 degrees RMS over the half-periods with a positive set-point (the wall
    # blocks the others): the PID lags the 0.75 Hz sine and starts each swing from rest
    # against the wall (fem-pendulum-control prints it). 5 degrees bounds it with margin.
    assert loop["rms_away"] < math.radians(5.0), math.degrees(loop["rms_away"])
    assert loop["theta"].max() > math.radians(15.0)  # it does swing out towards +20 degrees


def test_every_swing_to_negative_angles_ends_on_the_wall(loop):
    gap, sp = loop["gap"], loop["setpoint"]
    # set-point negative between 0.667 s and 1.333 s: the head bounces on the wall repeatedly
    window = (np.arange(len(gap)) * 1e-3 > 0.7) & (np.arange(len(gap)) * 1e-3 < 1.3)
    near = gap[window] < 0.5e-3
    bounces = int(np.sum(near[1:] & ~near[:-1]))
    assert bounces >= 5, bounces
    assert np.all(loop["theta"] > -math.radians(1.0))  # the wall holds it
    assert np.max(np.abs(loop["torque"])) <= 15.0


def test_energy_balance_holds_in_the_loop(loop):
    swing = 1.091 * 9.81 * 0.1817 * (1 - math.cos(math.radians(20)))
    assert np.max(np.abs(loop["balance"])) < 1e-3 * swing


def test_drive_limits_the_torque():
    assert drive(40.0, 15.0) == 15.0 and drive(-40.0, 15.0) == -15.0 and drive(3.0, 15.0) == 3.0
    assert abs(LoopSettings().setpoint(1 / 3) - math.radians(20.0)) < 1e-12


def test_host_environment_names_libpython_and_this_environment():
    env = host_environment()
    assert "libpython" in env["LD_PRELOAD"]
    assert Path(sys.executable).parent.as_posix() in env["PATH"]
