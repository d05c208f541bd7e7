"""A Python host whose C library frees its FMU instances at exit, after the interpreter has been finalised.

The host script (tests/exit_time_host.py) loads tests/exit_time_host.c, compiled here, through ctypes; the
library instantiates, initialises and steps one instance of each FMU (FemPendulum with the rigid fidelity,
PidController) and leaves them alive, and the script ends normally. Python is finalised first; then exit() runs
the library's handler, which terminates and frees both instances, as a C/C++ library's exit-time destructors do:
from an atexit() handler registered after the instances (it runs before the handlers the FMU binaries
registered), one registered before them (it runs after), or the library's ELF destructor (after every atexit()
handler). The FMU binary must answer without touching the finalised Python: fmi2Terminate fmi2Error,
fmi2FreeInstance nothing (docs/reference/fmi2.md); the binary built from pythonfmu's had the process die of SIGSEGV in
PyGILState_Ensure there, in every run. A run takes about a second.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import fmpy
import pytest
from fmpy import extract, read_model_description

HERE = Path(__file__).resolve().parent
RUNS = 5
RIGID, FEM = 2, 4  # model.fidelity items
FMPY_RUNS = 3

HOST = HERE / "exit_time_host.py"


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> str:
    """tests/exit_time_host.c compiled."""
    folder = tmp_path_factory.mktemp("exit_time_host")
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's binary and this host"
    include = Path(fmpy.__file__).parent / "c-code"
    source = HERE / "exit_time_host.c"
    command = [compiler, "-O1", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC", f"-I{include}", str(source), "-ldl"]
    subprocess.run([*command, "-o", str(folder / "exit_time_host.so")], check=True)
    return str(folder / "exit_time_host.so")


@pytest.fixture(scope="module")
def host_arguments(library, fmus, tmp_path_factory) -> list[str]:
    """The compiled library and, after the mode, the host's other arguments: both FMUs unzipped with their GUIDs,
    the value reference of model.fidelity and the rigid fidelity."""
    pendulum_fmu, pid_fmu = fmus
    folder = tmp_path_factory.mktemp("exit_time_fmus")
    pendulum = read_model_description(str(pendulum_fmu))
    vr = {v.name: v.valueReference for v in pendulum.modelVariables}
    return [
        library,
        extract(str(pendulum_fmu), unzipdir=str(folder / "pendulum")),
        pendulum.guid,
        extract(str(pid_fmu), unzipdir=str(folder / "pid")),
        read_model_description(str(pid_fmu)).guid,
        str(vr["model.fidelity"]),
        str(RIGID),
    ]


@pytest.mark.parametrize(
    "mode, handler",
    [("atexit-last", "atexit"), ("atexit-first", "atexit"), ("destructor", "destructor")],
)
def test_instances_freed_after_python_is_finalised(host_arguments, mode, handler):
    library, *rest = host_arguments
    expected = (
        f"exit-time-host {handler}: python initialised 0; "
        "PidController terminate 3 freed; FemPendulum terminate 3 freed"
    )
    for run_number in range(RUNS):
        run = subprocess.run(
            [sys.executable, str(HOST), library, mode, *rest], capture_output=True, text=True, timeout=120
        )
        where = f"run {run_number + 1} of {RUNS}: exit code {run.returncode}\n{run.stderr[-3000:]}"
        assert run.returncode == 0, where
        assert run.stdout.split("\n")[0] == "started 0", where  # both instances initialised and stepped
        handler_lines = [line for line in run.stderr.splitlines() if line.startswith("exit-time-host")]
        assert handler_lines == [expected], where  # the handler ran once, after finalisation, and got fmi2Error
        assert "refused" not in run.stderr, where  # nothing logged once Python was finalised: the logger may be Python


@pytest.fixture(scope="module")
def unzipped(fmus, fmu3, tmp_path_factory) -> dict[str, str]:
    """The FMI 2.0 and FMI 3.0 pendulum FMUs unzipped, by FMI version."""
    folder = tmp_path_factory.mktemp("exit_time_fmpy")
    return {
        "2": extract(str(fmus[0]), unzipdir=str(folder / "fmi2")),
        "3": extract(str(fmu3), unzipdir=str(folder / "fmi3")),
    }


@pytest.mark.parametrize("fmi_version", ["2", "3"])
@pytest.mark.parametrize(
    "mode, handler, fidelity",
    [
        ("atexit-last", "atexit", RIGID),
        ("atexit-first", "atexit", RIGID),
        ("destructor", "destructor", RIGID),
        ("destructor", "destructor", FEM),
    ],
    ids=["atexit-last-rigid", "atexit-first-rigid", "destructor-rigid", "destructor-fem"],
)
def test_fmpy_logger_is_not_called_after_python_is_finalised(library, unzipped, fmi_version, mode, handler, fidelity):
    folder = unzipped[fmi_version]
    label = read_model_description(folder).coSimulation.modelIdentifier
    expected = f"exit-time-host {handler}: python initialised 0; {label} terminate 3 freed"
    command = [sys.executable, str(HOST), "--fmpy", library, mode, fmi_version, folder, str(fidelity)]
    for run_number in range(FMPY_RUNS):
        run = subprocess.run(command, capture_output=True, text=True, timeout=120)
        output = run.stdout[-2000:] + run.stderr[-3000:]
        where = f"run {run_number + 1} of {FMPY_RUNS}: exit code {run.returncode}\n{output}"
        assert run.returncode == 0, where  # not 139: SIGSEGV in PyGILState_Ensure inside fmpy's logger
        assert "started 0" in run.stdout.splitlines(), where  # instantiated, initialised, stepped and held
        handler_lines = [line for line in run.stderr.splitlines() if line.startswith("exit-time-host")]
        assert handler_lines == [expected], where  # the handler ran once, after finalisation, and got fmiXError
        # fmpy's logger printed the doStep refused while Python ran, and nothing after it was finalised
        (refused,) = [line for line in run.stdout.splitlines() if "refused" in line]
        assert refused.startswith(f"[ERROR] fmi{fmi_version}DoStep refused: communication point 1 does not "), where
        assert "refused" not in run.stderr, where
