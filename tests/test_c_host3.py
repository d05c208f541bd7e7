"""A native C host (examples/c_host/fmi3_host.c) runs the FMI 3.0 FMU with no environment variables at all.

The FMU's binary (fem_pendulum_fmu/fmi/shim/fmi3_*.c) starts the Python recorded at build time; the host
instantiates with early return allowed, steps across contact onset, saves and restores a state, is refused
a NaN torque and a truncated state, frees the instance, unloads the library and exits with 0.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import fmpy
import pendulum_closed_form as closed
import pytest
from fmpy import extract, read_model_description

from fem_pendulum_fmu.physics.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
RIGID, FEM = 2, 4  # model.fidelity items
ONSET = closed.first_impact(Scene()).time  # s, the default scene's first contact: 239.47 ms


@pytest.fixture(scope="module")
def host3(fmu3, tmp_path_factory) -> list[str]:
    """The compiled C host and its first arguments: the extracted FMU folder and its instantiation token."""
    folder = tmp_path_factory.mktemp("c_host3")
    binary = folder / "fmi3_host"
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's binary and this host"
    source = ROOT / "examples" / "c_host" / "fmi3_host.c"
    include = Path(fmpy.__file__).parent / "c-code"
    subprocess.run([compiler, "-O1", "-Wall", f"-I{include}", str(source), "-ldl", "-o", str(binary)], check=True)
    return [str(binary), extract(str(fmu3), unzipdir=str(folder / "fmu")), read_model_description(str(fmu3)).guid]


def run_host(host: list[str], fmu: Path, steps: int, fidelity: int) -> subprocess.CompletedProcess:
    vr = {v.name: v.valueReference for v in read_model_description(str(fmu)).modelVariables}
    args = [*host, str(steps), str(fidelity), str(vr["model.fidelity"]), str(vr["theta"])]
    return subprocess.run(args, env={}, capture_output=True, text=True, timeout=300)


def check_run(run: subprocess.CompletedProcess) -> list[str]:
    """Exit 0, early return at onset, the NaN torque and the truncated state refused with fmi3Error, the
    state replayed bit for bit."""
    assert run.returncode == 0, f"exit code {run.returncode}\n{run.stderr[-3000:]}"
    lines = run.stdout.split("\n")
    (early,) = [line.split() for line in lines if line.startswith("early-return")]
    assert early[1] == "1" and abs(float(early[2]) - ONSET) < 2e-4
    assert "nan-torque-status 3" in lines and "truncated-state-status 3" in lines
    assert "torque = nan is not allowed" in run.stderr  # reached the host's logger with logging off
    assert "truncated or padded" in run.stderr
    first = [line.split()[1] for line in lines if line.startswith("pass0")]
    again = [line.split()[1] for line in lines if line.startswith("pass1")]
    assert len(first) == 5 and first == again
    return lines


def test_c_host_without_environment_steps_returns_early_and_rolls_back(fmu3, host3):
    lines = check_run(run_host(host3, fmu3, 20, RIGID))
    times = [float(line.split()[0]) for line in lines if line[:1].isdigit()]
    assert len(times) == 20 and times[0] > ONSET


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", [FEM, RIGID], ids=["fem", "rigid"])
def test_c_host3_exits_cleanly_every_time(fmu3, host3, fidelity):
    codes = []
    for _ in range(20):
        run = run_host(host3, fmu3, 5, fidelity)
        codes.append(run.returncode)
        check_run(run)
    assert codes == [0] * 20
