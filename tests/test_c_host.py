"""A native C host (examples/c_host/fmi2_host.c) runs the FMU with no environment variables at all.

The FMU's binary (fem_pendulum_fmu/fmi/shim) starts the Python recorded
at build time; the host loads, steps, saves and restores a state, frees the
instance, unloads the library and exits with 0 (docs/notes/fmu_layer.md says what crashed
here before).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import extract, read_model_description

from fem_pendulum_fmu.fmi.host_env import host_environment

ROOT = Path(__file__).resolve().parents[1]
RIGID, FEM = 2, 4  # model.fidelity items

MASTER_RUNS = str(ROOT / "tests" / "master_runs.py")


@pytest.fixture(scope="module")
def host(fmus, tmp_path_factory) -> list[str]:
    """The compiled C host and its first arguments: the extracted FMU folder and its GUID."""
    fmu, _ = fmus
    folder = tmp_path_factory.mktemp("c_host")
    binary = folder / "fmi2_host"
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's binary and this host"
    subprocess.run(
        [
            compiler,
            "-O1",
            "-Wall",
            f"-I{Path(fmpy.__file__).parent / 'c-code'}",
            str(ROOT / "examples" / "c_host" / "fmi2_host.c"),
            "-ldl",
            "-o",
            str(binary),
        ],
        check=True,
    )
    return [str(binary), extract(str(fmu), unzipdir=str(folder / "fmu")), read_model_description(str(fmu)).guid]


def run_host(host: list[str], fmu: Path, steps: int, fidelity: int, env: dict | None = None):
    vr = {v.name: v.valueReference for v in read_model_description(str(fmu)).modelVariables}
    args = [*host, str(steps), str(fidelity), str(vr["model.fidelity"]), str(vr["theta"])]
    return subprocess.run(args, env=env or {}, capture_output=True, text=True, timeout=300)


def check_run(run) -> list[str]:
    """The run exited with 0, refused the NaN torque with fmi2Error and replayed the state bit for bit."""
    assert run.returncode == 0, f"exit code {run.returncode}\n{run.stderr[-3000:]}"
    lines = run.stdout.split("\n")
    assert "nan-torque-status 3" in lines
    assert "torque = nan is not allowed" in run.stderr  # the error reached the host's logger, logging off
    first = [line.split()[1] for line in lines if line.startswith("pass0")]
    again = [line.split()[1] for line in lines if line.startswith("pass1")]
    assert len(first) == 5 and first == again
    return lines


def test_c_host_without_environment_matches_fmpy(fmus, host):
    fmu, _ = fmus
    lines = check_run(run_host(host, fmu, 300, RIGID))
    c_rows = np.array([[float(x) for x in line.split()] for line in lines if line[:1].isdigit()])
    ref = subprocess.run(
        [sys.executable, MASTER_RUNS, "simulate", str(fmu)], capture_output=True, text=True, check=True
    )
    fmpy_rows = np.array([[float(x) for x in line.split()] for line in ref.stdout.split("\n") if line])
    assert c_rows.shape == fmpy_rows.shape == (300, 2)
    assert np.min(c_rows[:, 1]) < 0.01  # it swung down to the wall in 0.3 s
    assert np.max(np.abs(c_rows - fmpy_rows)) <= 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", [FEM, RIGID], ids=["fem", "rigid"])
def test_c_host_exits_cleanly_every_time(fmus, host, fidelity):
    """pythonfmu's binary alone crashed native hosts at exit (use-after-free, NGSolve's cleanup)."""
    fmu, _ = fmus
    codes = []
    for _ in range(20):
        run = run_host(host, fmu, 10, fidelity)
        codes.append(run.returncode)
        check_run(run)
    assert codes == [0] * 20


def test_host_env_points_the_fmu_at_an_environment(fmus, host):
    fmu, _ = fmus
    check_run(run_host(host, fmu, 10, RIGID, env=host_environment()))


def test_without_a_python_instantiate_fails_with_what_to_set(fmus, host):
    fmu, _ = fmus
    run = run_host(host, fmu, 10, RIGID, env={"FEM_PENDULUM_LIBPYTHON": "/nonexistent/libpython3.so"})
    assert run.returncode == 3, run.stderr  # fmi2Instantiate returned NULL: refused, no crash
    assert "the environment variable FEM_PENDULUM_LIBPYTHON = /nonexistent/libpython3.so cannot be loaded" in run.stderr
    assert "fem-pendulum host-env" in run.stderr


def test_a_wrong_python_executable_is_named_as_such(fmus, host):
    """FEM_PENDULUM_PYTHON pointing at no executable is named as the culprit (it used to surface as
    Python starting without the environment's packages: "ngsolve is not installed")."""
    fmu, _ = fmus
    env = {**host_environment(), "FEM_PENDULUM_PYTHON": "/nonexistent/bin/python"}
    run = run_host(host, fmu, 10, RIGID, env=env)
    assert run.returncode == 3, run.stderr
    assert "FEM_PENDULUM_PYTHON = /nonexistent/bin/python is not an executable file" in run.stderr, run.stderr
    assert "not installed" not in run.stderr


def test_host_env_names_this_environment():
    env = host_environment()
    assert Path(env["FEM_PENDULUM_LIBPYTHON"]).is_file() and "libpython" in env["FEM_PENDULUM_LIBPYTHON"]
    assert env["FEM_PENDULUM_PYTHON"] == sys.executable
    printed = subprocess.run(
        [str(Path(sys.executable).parent / "fem-pendulum"), "host-env"], check=True, capture_output=True, text=True
    ).stdout
    # the command's interpreter may be named python3 where this one is python: the same file
    names = [line.removeprefix("export ").partition("=")[0] for line in printed.splitlines()]
    values = [line.partition("=")[2].strip('"') for line in printed.splitlines()]
    assert names == list(env) and [Path(v).resolve() for v in values] == [Path(v).resolve() for v in env.values()]
