"""`fem-pendulum run` with bad input or a run the FMU cannot complete, as a user types it: bad input
is one line on stderr naming the value and what is allowed, exit 2, within seconds and before any
simulation; a run that stops early writes what it has, says where, what the FMU said and what to
try, and exits 1 (masters/failures.py, cli.py). Never a traceback."""

from __future__ import annotations

import csv
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

FAILING = [  # the soft pendulum on a coarse mesh under -20 N.m: the hinge inverts within 0.5 ms
    "pendulum.E=1e6",
    "pendulum.nu=0.45",
    "pendulum.rho=1000",
    "contact.stiffness=5e9",
    "model.mesh_size=0.05",
    "model.order=2",
]
TIMEOUT = 120  # s: every case answers in seconds (measured 1-3 s each); a hang would hit this


def fem_pendulum(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    command = [str(Path(sys.executable).parent / "fem-pendulum"), *args]
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--stop-time", "nan"], ["--stop-time nan", "finite time > 0"]),
        (["--stop-time", "-1"], ["--stop-time -1.0", "finite time > 0"]),
        (["--step", "0"], ["--step 0.0", "> 0"]),
        (["--step", "1", "--stop-time", "0.5"], ["--step 1.0", "at most --stop-time 0.5"]),
        (["--fmu", "missing.fmu"], ["missing.fmu", "fem-pendulum build"]),
        (["--torque", "missing.csv"], ["missing.csv", "No such file"]),
        (["--torque", "bad.csv"], ["bad.csv", "row 3", "column torque", "'abc'"]),
        (["--set", "pendulum.nu=0.5"], ["pendulum.nu = 0.5", "[0, 0.5)"]),
        (["--set", "model.mesh_size=1e-5"], ["model.mesh_size = 1e-05", "GiB", "model.mesh_size must be about"]),
        (["--set", "no.such=1"], ["no.such", "not a variable"]),
        (["--out", "file.txt/run"], ["file.txt/run", "cannot write"]),
    ],
)
def test_bad_input_is_one_line_and_exit_2(fmus, tmp_path, args, words):
    (tmp_path / "bad.csv").write_text("time,torque\n0.0,0.5\n0.5,abc\n")
    (tmp_path / "file.txt").write_text("a file, not a folder\n")
    fmu = [] if "--fmu" in args else ["--fmu", str(fmus[0])]
    run = fem_pendulum("run", *fmu, "--stop-time", "0.01", *args, cwd=tmp_path)
    assert run.returncode == 2, run.stdout + run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fem-pendulum run: error: "), run.stderr
    assert all(word in lines[0] for word in words), lines[0]
    assert not list(tmp_path.glob("out*")), "nothing is written before the input is checked"


@pytest.mark.slow
def test_a_run_that_stops_early_writes_what_it_has_and_exits_1(fmus, tmp_path):
    (tmp_path / "torque.csv").write_text("time,torque\n0.0,-20\n1.0,-20\n")
    sets = [word for item in FAILING for word in ("--set", item)]
    run = fem_pendulum(
        "run", "--fmu", str(fmus[0]), "--torque", "torque.csv", "--stop-time", "0.5", *sets, "--out", "o/run",
        cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 1, run.stdout + run.stderr
    assert "Traceback" not in run.stderr and "wrote" not in run.stdout
    message = run.stderr.strip()
    assert message.startswith("fem-pendulum run: incomplete: the run stopped at t = 0 s of 0.5 s"), message
    assert "smallest step" in message and "Try a smaller torque" in message, message
    with open(tmp_path / "o" / "run.csv") as f:
        rows = list(csv.DictReader(f))
    assert float(rows[-1]["time"]) < 0.5 and (tmp_path / "o" / "run.png").is_file()


def test_control_checks_its_arguments_first(fmus, tmp_path):
    for args, words in (
        (["--controller", "missing.fmu"], ["--controller 'missing.fmu'", "fem-pendulum build"]),
        (["--stop-time", "inf"], ["--stop-time inf"]),
        (["--set", "wall.kind=soft"], ["wall.kind", "'soft'", "rigid, deformable, none"]),
    ):
        pid = [] if "--controller" in args else ["--controller", str(fmus[1])]
        run = fem_pendulum("control", "--fmu", str(fmus[0]), *pid, *args, cwd=tmp_path)
        assert run.returncode == 2, run.stdout + run.stderr
        assert run.stderr.startswith("fem-pendulum control: error: ") and run.stderr.count("\n") == 1, run.stderr
        assert all(word in run.stderr for word in words), run.stderr


@pytest.mark.slow
def test_a_controller_loop_that_stops_early_writes_what_it_has_and_exits_1(fmus, tmp_path):
    """The soft pendulum on a coarse mesh in the PID loop: its hinge inverts at t = 0.781 s (measured,
    3.8 s of CPU) after the retry in two half steps; the loop ends there."""
    sets = [word for item in FAILING for word in ("--set", item)]
    run = fem_pendulum(
        "control", "--fmu", str(fmus[0]), "--controller", str(fmus[1]), "--stop-time", "1", *sets, "--out", "c/control",
        cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 1, run.stdout + run.stderr
    message = run.stderr.strip()
    assert message.startswith("fem-pendulum control: incomplete: the pendulum FMU stopped at t = "), message
    assert "smallest step" in message and "Traceback" not in message, message
    data = np.loadtxt(tmp_path / "c" / "control.csv", delimiter=",", skiprows=1)
    assert 0.0 < data[-1, 0] < 1.0


@pytest.mark.parametrize(
    "args, words",
    [
        (["--stop-time", "nan"], ["--stop-time nan", "finite time > 0"]),
        (["--workers", "-1"], ["--workers -1", ">= 1"]),
        (["--workers", "0"], ["--workers 0", ">= 1"]),
        (["--param", "pendulum.E=1e6,abc"], ["pendulum.E", "abc"]),
        (["--out", "file.txt"], ["--out 'file.txt' is a file"]),
        (["--out", "file.txt/sweep"], ["file.txt/sweep", "cannot write"]),
    ],
)
def test_sweep_checks_its_arguments_first(fmus, tmp_path, args, words):
    (tmp_path / "file.txt").write_text("a file, not a folder\n")
    run = fem_pendulum("sweep", "--fmu", str(fmus[0]), "--param", "theta0=0.1,0.2", *args, cwd=tmp_path)
    assert run.returncode == 2, run.stdout + run.stderr
    assert run.stderr.startswith("fem-pendulum sweep: error: ") and run.stderr.count("\n") == 1, run.stderr
    assert all(word in run.stderr for word in words), run.stderr


@pytest.mark.slow
def test_a_sweep_with_a_failed_sample_marks_it_and_exits_1(fmus, tmp_path):
    (tmp_path / "torque.csv").write_text("time,torque\n0.0,-20\n1.0,-20\n")
    sets = [word for item in FAILING[1:] for word in ("--set", item)]  # pendulum.E is the axis
    run = fem_pendulum(
        "sweep", "--fmu", str(fmus[0]), "--param", "pendulum.E=1e6,2.1e11", *sets, "--torque", "torque.csv",
        "--stop-time", "0.05", "--workers", "1", "--no-progress", "--out", "sweep",
        cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 1, run.stdout + run.stderr
    assert "2 samples: 1 ok, 1 error" in run.stdout and "stopped at t = " in run.stdout, run.stdout
    assert "smallest step" in run.stdout, run.stdout
    assert run.stderr.strip().splitlines()[-1].startswith("fem-pendulum sweep: incomplete: 1 of 2 samples"), run.stderr
    assert (tmp_path / "sweep" / "results.parquet").is_file()


def other_version(fmu: Path, folder: Path) -> Path:
    """A copy of the FMU whose shipped physics/scene.py has one line more than the installed package's."""
    changed = folder / "OtherVersion.fmu"
    name = "resources/fem_pendulum_fmu/physics/scene.py"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(changed, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            dst.writestr(item, data + b"\n# another version\n" if item.filename == name else data)
    return changed


@pytest.mark.parametrize("command", ["run", "control", "sweep"])
def test_an_fmu_of_another_version_than_the_installed_package_is_refused_in_one_line(fmus, tmp_path, command):
    """The commands import fem_pendulum_fmu; an FMU built from other sources would run the installed copy
    (fmi/preflight.py refuses it). Each command says why in one line and exits 1; the sweep marks both
    samples with the reason (the second one too: its worker tries a fresh instance again)."""
    fmu = str(other_version(fmus[0], tmp_path))
    extra = {
        "run": [],
        "control": ["--controller", str(fmus[1])],
        "sweep": ["--param", "pendulum.E=1e9,2e9", "--workers", "1", "--no-progress"],
    }[command]
    run = fem_pendulum(command, "--fmu", fmu, "--stop-time", "0.01", *extra, "--out", "out/x", cwd=tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith(f"fem-pendulum {command}: incomplete: ") and "Traceback" not in run.stderr, run.stderr
    said = last if command != "sweep" else run.stdout
    assert said.count("already imported fem_pendulum_fmu from") == (2 if command == "sweep" else 1), said
    assert "physics/scene.py" in said, said


@pytest.mark.slow
def test_run_says_what_auto_picked_and_why(fmus, tmp_path):
    """The steel scene's auto choice (physics/fidelity_rule.py), printed before the run: reduced, since
    its impacts excite vibration the 6 modes still cover (measured: up to 7350 Hz, modes to 9250 Hz)."""
    run = fem_pendulum(
        "run", "--fmu", str(fmus[0]), "--set", "model.fidelity=auto", "--stop-time", "0.05", "--out", "o/run",
        cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    first = run.stdout.splitlines()[0]
    assert first.startswith("model.fidelity = auto picks reduced: contact ") and "Hz" in first, run.stdout


@pytest.mark.slow
def test_ctrl_c_ends_a_run_with_what_it_has_and_no_traceback(fmus, tmp_path):
    """SIGINT while the FE model steps (8 s into a 60 s run of about 90 s): exit 130, one line, the
    CSV up to where it stopped. Inside doStep the interrupt reaches the FMU's Python, which answers
    fmi2Error with the KeyboardInterrupt logged; the command reads that as Ctrl-C."""
    import signal
    import time

    command = [str(Path(sys.executable).parent / "fem-pendulum"), "run", "--fmu", str(fmus[0])]
    child = subprocess.Popen(
        [*command, "--stop-time", "60", "--out", "o/run"],
        cwd=tmp_path,
        stderr=subprocess.PIPE,
        text=True,
        # as a terminal's foreground job has it: a suite started in the background inherits SIGINT ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(8.0)
    child.send_signal(signal.SIGINT)
    _, stderr = child.communicate(timeout=TIMEOUT)
    assert child.returncode == 130, stderr
    assert stderr.strip() == "fem-pendulum run: interrupted (what was written so far is kept)", stderr
    with open(tmp_path / "o" / "run.csv") as f:
        rows = list(csv.DictReader(f))
    assert 0.0 < float(rows[-1]["time"]) < 60.0


@pytest.mark.slow
def test_sweep_says_what_auto_picked(fmus, tmp_path):
    run = fem_pendulum(
        "sweep", "--fmu", str(fmus[0]), "--param", "theta0=0.2,0.3", "--set", "model.fidelity=auto",
        "--stop-time", "0.02", "--workers", "1", "--no-progress", "--out", "sweep",
        cwd=tmp_path,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith("model.fidelity = auto picks reduced for 2 sample(s) ("), run.stdout
