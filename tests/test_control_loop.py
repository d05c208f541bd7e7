"""A user's own controller in the loop: a controller FMU that is not the project's, through
`fem-pendulum control` and `fem_pendulum_fmu.testing.closed_loop`, and the same law as a Python function."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fem_pendulum_fmu.masters.control.series import COLUMNS
from fem_pendulum_fmu.testing import closed_loop

CLI = str(Path(sys.executable).parent / "fem-pendulum")
KP, KD = 100.0, 0.4  # Kp this high saturates the 15 N.m drive at the start of a 10-degree step
WIRES = [
    "pendulum.theta=controller.theta",
    "pendulum.omega=controller.omega",
    "setpoint=controller.setpoint",
    "controller.torque=pendulum.torque",
]


def pd_law(t: float, m) -> float:
    """The law of tests/pd_controller_under_test.py with KP, KD, on what the loop measured at t."""
    return KP * (m.setpoint - m.theta) - KD * m.omega


def control(fmus, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([CLI, "control", "--fmu", str(fmus[0]), *args], cwd=cwd, capture_output=True, text=True)


@pytest.mark.slow
def test_the_torque_received_is_the_users_law_of_what_its_fmu_was_given(fmus, pd_fmu, tmp_path):
    connect = [word for wire in WIRES for word in ("--connect", wire)]
    run = control(
        fmus, "--controller", str(pd_fmu), *connect, "--controller-set", f"Kp={KP}", "--controller-set", f"Kd={KD}",
        "--setpoint", "step:10deg", "--disturbance", "sine:0.5,3", "--set", "model.fidelity=rigid",
        "--stop-time", "0.4", "--out", "out/pd", cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    with open(tmp_path / "out" / "pd.csv") as f:
        assert f.readline().strip().split(",") == list(COLUMNS)
    table = np.genfromtxt(tmp_path / "out" / "pd.csv", delimiter=",", names=True, deletechars="")
    t, theta, omega, setpoint = (table[c][:-1] for c in ("time", "theta", "omega", "setpoint"))
    demand = KP * (setpoint - theta) - KD * omega  # row k + 1 holds the step that began at row k
    disturbance = 0.5 * np.sin(2 * np.pi * 3 * t)
    assert np.allclose(setpoint, np.radians(10.0), rtol=0, atol=1e-15)
    assert np.max(np.abs(table["demand"][1:] - demand)) < 1e-12
    assert np.max(np.abs(table["disturbance"][1:] - disturbance)) < 1e-12
    assert np.max(np.abs(table["torque"][1:] - (np.clip(demand, -15.0, 15.0) + disturbance))) < 1e-12
    assert np.any(demand > 15.0)  # the drive limit was in play
    report = json.loads((tmp_path / "out" / "pd.json").read_text())
    assert report["controller"] == str(pd_fmu) and "rms_error" in json.dumps(report)
    assert (tmp_path / "out" / "pd.png").stat().st_size > 20_000


def test_a_python_function_and_the_same_law_as_an_fmu_give_the_same_series(fmus, pd_fmu):
    loop = dict(setpoint="step:10deg", disturbance="sine:0.5,3", stop_time=0.5, fidelity="rigid", fmu=fmus[0])
    as_fmu = closed_loop(pd_fmu, connect=WIRES, controller_parameters={"Kp": KP, "Kd": KD}, **loop)
    as_function = closed_loop(pd_law, **loop)
    assert list(as_function.series.columns) == list(COLUMNS) and len(as_function.series) == 501
    assert np.max(np.abs(as_fmu.series.to_numpy() - as_function.series.to_numpy())) <= 1e-12
    assert as_fmu.metrics == as_function.metrics
    # wired by name: the FMU's inputs theta, omega, setpoint and its one output torque need no --connect
    by_name = closed_loop(pd_fmu, controller_parameters={"Kp": KP, "Kd": KD}, **loop)
    assert np.array_equal(by_name.series.to_numpy(), as_fmu.series.to_numpy())


@pytest.mark.parametrize(
    "args, words",
    [
        (["--connect", "pendulum.thta=controller.theta", "--connect", "controller.torque=pendulum.torque"],
         ["pendulum.thta", "outputs:", "theta", "omega", "contact_force"]),
        (["--connect", "pendulum.theta=controller.angle", "--connect", "controller.torque=pendulum.torque"],
         ["controller.angle", "omega, setpoint, theta"]),
        (["--connect", "pendulum.theta=controller.theta"], ["exactly one controller output", "torque"]),
        (["--connect", "theta"], ["'theta'", "FROM=TO"]),
        (["--controller-set", "Kq=1"], ["Kq", "Kd, Kp"]),
        (["--controller-set", "Kp=fast"], ["Kp=fast", "finite number"]),
        (["--setpoint", "sin:1"], ["--setpoint", "'sin:1'", "step:"]),
        (["--disturbance", "step:2deg"], ["--disturbance", "step:2deg"]),
        (["--drive-limit", "0"], ["--drive-limit 0", "> 0"]),
    ],
)  # fmt: skip
def test_wrong_names_and_values_get_one_line_naming_them(fmus, pd_fmu, tmp_path, args, words):
    run = control(fmus, "--controller", str(pd_fmu), *args, cwd=tmp_path)
    assert run.returncode == 2, run.stdout + run.stderr
    assert run.stderr.startswith("fem-pendulum control: error: ") and run.stderr.count("\n") == 1, run.stderr
    assert all(word in run.stderr for word in words), run.stderr
    assert not (tmp_path / "out").exists()  # nothing ran


def test_a_function_controller_that_returns_nan_is_named_with_the_time(fmus):
    with pytest.raises(ValueError, match=r"returned nan at t = 0\.005 s"):
        closed_loop(lambda t, m: float("nan") if t > 0.0045 else 0.0, stop_time=0.01, fidelity="rigid", fmu=fmus[0])


def test_a_loop_on_the_fe_model_is_deterministic(fmus):
    """Two runs of the same loop on the FE pendulum (one NGSolve thread, the FMU's default) give the same
    table bit for bit: a controller test's figures do not drift from run to run."""
    loop = dict(setpoint="step:10deg", stop_time=0.05, fmu=fmus[0], pendulum={"model.mesh_size": 0.04})
    first, second = closed_loop(pd_law, **loop), closed_loop(pd_law, **loop)
    assert np.array_equal(first.series.to_numpy(), second.series.to_numpy())
    assert first.series["theta"].iloc[-1] > 0.01  # it moved: 50 ms of the step response
