"""Instances built, initialised, stepped, rolled back and freed at the same moment on several threads give, to the
last bit, what the same instances give one after another in the same process.

Three hosts, each in a process of its own per run (the first round of a process builds the geometry, meshes and
models where none exist yet, the moment most exposed to sharing): tests/concurrent_host.c compiled for FMI 2.0 and
for FMI 3.0 (pthreads, started with no environment at all, no lock of its own), and fmpy's FMU2Slave and FMU3Slave
on Python threads (tests/concurrent_fmpy.py). Every round runs three fem instances (two of them the same scene),
one reduced and one rigid, all released at once from a barrier in front of instantiation, with a rollback of
three steps halfway; then the host compares each with its sequential run. What they guard against is written in
fem_pendulum_fmu/physics/shared_state.py.

Before that lock, 4 of 10 native FMI 2.0 processes and 4 of 10 FMI 3.0 ones (3 rounds each) crashed ("double free
or corruption", SIGSEGV) or gave an instance whose results differed (a Discard, fmi2Error "Factor is exactly
singular"); through fmpy 7 of 10 (FMI 2.0) and 5 of 10 (FMI 3.0). The fast lane runs one process per host and FMI
version; the slow lane 50 rounds of each native host in 25 processes.
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
SPECS = (
    "4:0.2",
    "4:0.3",
    "4:0.2",
    "3:0.2",
    "2:0.2",
)  # fidelity:theta0, model.fidelity's items 4 fem, 3 reduced, 2 rigid
STEPS = 100
OUTPUTS = ("theta", "omega", "gap")
SLOW_PROCESSES, SLOW_ROUNDS = 25, 2


@pytest.fixture(scope="module")
def native_hosts(tmp_path_factory) -> dict[int, str]:
    """tests/concurrent_host.c compiled for FMI 2.0 and for FMI 3.0."""
    folder = tmp_path_factory.mktemp("concurrent_host")
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's binary and this host"
    hosts = {}
    for version in (2, 3):
        binary = folder / f"concurrent_host{version}"
        headers = Path(fmpy.__file__).parent / "c-code"
        source = HERE / "concurrent_host.c"
        command = [compiler, "-O1", "-Wall", "-Werror", f"-DFMI_VERSION={version}", f"-I{headers}", str(source)]
        subprocess.run([*command, "-ldl", "-lpthread", "-o", str(binary)], check=True)
        hosts[version] = str(binary)
    return hosts


@pytest.fixture(scope="module")
def fmu_of(fmus, fmu3) -> dict[int, Path]:
    return {2: fmus[0], 3: fmu3}


def native_arguments(host: str, fmu: Path, folder: Path, rounds: int) -> list[str]:
    """The host's command line: the FMU unzipped, its token, the steps and rounds, the value references, SPECS."""
    description = read_model_description(str(fmu))
    vr = {v.name: str(v.valueReference) for v in description.modelVariables}
    token = description.instantiationToken if description.fmiVersion.startswith("3") else description.guid
    unzipped = folder / "fmu"
    if not unzipped.exists():
        extract(str(fmu), unzipdir=str(unzipped))
    references = [vr[name] for name in ("model.fidelity", "theta0", *OUTPUTS)]
    return [host, str(unzipped), token, str(STEPS), str(rounds), *references, *SPECS]


def check_run(run: subprocess.CompletedProcess, rounds: int) -> None:
    """Exit 0 (no crash), every instance of every round the same as alone, and the summary says so."""
    detail = f"exit {run.returncode}\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    assert run.returncode == 0, detail
    verdicts = [line for line in run.stdout.splitlines() if line.startswith("round ")]
    assert len(verdicts) == rounds * len(SPECS), detail
    assert all(": same" in line for line in verdicts), detail
    assert f"rounds: {rounds}, instances differing from the sequential run: 0" in run.stdout, detail


def run_native(host: str, fmu: Path, folder: Path, rounds: int) -> subprocess.CompletedProcess:
    args = native_arguments(host, fmu, folder, rounds)
    return subprocess.run(args, env={}, capture_output=True, text=True, timeout=600)


def run_fmpy(fmu: Path, version: int, rounds: int) -> subprocess.CompletedProcess:
    script = str(HERE / "concurrent_fmpy.py")
    args = [sys.executable, script, str(fmu), str(version), str(STEPS), str(rounds), *SPECS]
    return subprocess.run(args, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("version", [2, 3])
def test_native_threads_build_and_step_instances_at_once(native_hosts, fmu_of, version, tmp_path) -> None:
    rounds = 3
    check_run(run_native(native_hosts[version], fmu_of[version], tmp_path, rounds), rounds)


@pytest.mark.parametrize("version", [2, 3])
def test_fmpy_threads_build_and_step_instances_at_once(fmu_of, version) -> None:
    rounds = 2
    check_run(run_fmpy(fmu_of[version], version, rounds), rounds)


@pytest.mark.slow
@pytest.mark.parametrize("version", [2, 3])
def test_fifty_rounds_of_native_threads(native_hosts, fmu_of, version, tmp_path) -> None:
    failed = []
    for process in range(SLOW_PROCESSES):
        run = run_native(native_hosts[version], fmu_of[version], tmp_path, SLOW_ROUNDS)
        try:
            check_run(run, SLOW_ROUNDS)
        except AssertionError as failure:
            failed.append(f"process {process}: {str(failure)[:400]}")
    assert not failed, f"{len(failed)} of {SLOW_PROCESSES} processes failed:\n" + "\n".join(failed)


def test_the_host_sees_a_difference(native_hosts, fmu_of, tmp_path) -> None:
    """The comparison can fail: an instance whose sequential run is of another scene (theta0 1e-12 rad apart) is
    reported as differing, and the host exits 1."""
    args = native_arguments(native_hosts[2], fmu_of[2], tmp_path, 1)
    specs_at = len(args) - len(SPECS)
    run = subprocess.run([*args[:specs_at], "4:0.2", "4:0.2:0.200000000001"], env={}, capture_output=True, text=True)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "round 0 instance 0 fidelity 4: same" in run.stdout
    assert "round 0 instance 1 fidelity 4: DIFFERENT" in run.stdout
    assert "instances differing from the sequential run: 1" in run.stdout
