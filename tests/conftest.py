"""Shared fixtures: the FMUs are built once per test session (for all pytest-xdist workers together), into a
temporary folder."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def built_once(tmp_path_factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]) -> Path:
    """The folder `build` filled, once per test session. Under pytest-xdist each worker process runs the
    session fixtures: the first to come builds into a folder of the session's temporary root that all
    workers share, holding a lock on it; the others wait for the lock and use what it built (a build
    that failed is tried again, and fails again, in the next worker)."""
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        folder = tmp_path_factory.mktemp(name)
        build(folder)
        return folder
    folder = tmp_path_factory.getbasetemp().parent / name
    with open(folder.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (folder / ".built").exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            build(folder)
            (folder / ".built").touch()
    return folder


def fem_pendulum_build(out: Path, *options: str) -> list[str]:
    """`fem-pendulum build OPTIONS` as a user runs it, in `out`; what it printed: the FMUs it wrote."""
    command = [str(Path(sys.executable).parent / "fem-pendulum"), "build", *options]
    run = subprocess.run(command, cwd=out, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout.split()


def build_fmi2(out: Path) -> None:
    written = fem_pendulum_build(out, "--output", str(out / "FemPendulum.fmu"))
    assert written == [str(out / "FemPendulum.fmu"), str(out / "PidController.fmu")]


def build_fmi3(out: Path) -> None:
    written = fem_pendulum_build(out, "--fmi-version", "3", "--output", str(out / "FemPendulum3.fmu"))
    assert written == [str(out / "FemPendulum3.fmu")]


@pytest.fixture(scope="session")
def fmus(tmp_path_factory) -> tuple[Path, Path]:
    """(FemPendulum.fmu, PidController.fmu) built by `fem-pendulum build` as a user would run it."""
    out = built_once(tmp_path_factory, "dist", build_fmi2)
    return out / "FemPendulum.fmu", out / "PidController.fmu"


def pythonfmu_build(out: Path) -> None:
    script = Path(__file__).resolve().parent / "pd_controller_under_test.py"
    run = subprocess.run(
        [sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(out)], capture_output=True, text=True
    )
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.fixture(scope="session")
def pd_fmu(tmp_path_factory) -> Path:
    """tests/pd_controller_under_test.py built by pythonfmu's own builder (its binary, not the project's), in a
    child process: in this one, once a pythonfmu FMU has run, `pythonfmu` may be the copy inside that FMU's
    extracted resources, whose builder has no binaries to pack."""
    return built_once(tmp_path_factory, "pd", pythonfmu_build) / "PdControllerUnderTest.fmu"


@pytest.fixture(scope="session")
def fmu3(tmp_path_factory) -> Path:
    """The FMI 3.0 FemPendulum FMU, built once per session by `fem-pendulum build --fmi-version 3`."""
    return built_once(tmp_path_factory, "dist3", build_fmi3) / "FemPendulum3.fmu"


# The slow lane's parametrized cases (whole tests carry @pytest.mark.slow in their files), so that
# `pytest -m "not slow" -n 2` stays under 2 minutes on the 2-core machine. The cheaper cases of the same tests
# stay fast. The figures: the case's time in a full run of the suite, in one process, while other suites ran
# (the first group 2026-12-01, 4 s or more; the second 2.4 s or more in a run of `pytest -m "not slow"` with
# a load average of 2.3-3 from other jobs).
SLOW_CASES = {
    "tests/test_hard_cases.py::test_high_speed_impact[fem-compliant]",  # 102 s
    "tests/test_hard_cases.py::test_violent_square_wave_torque_over_the_top[fem]",  # 68 s
    "tests/test_hard_cases.py::test_grazing_release_at_half_a_degree[fem]",  # 14 s
    "tests/test_hard_cases.py::test_resting_contact_under_constant_torque[fem]",  # 14 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[fem]",  # 12 s
    "tests/test_hard_cases.py::test_at_rest_touching_the_wall_stays_at_rest[fem-compliant]",  # 11 s
    "tests/test_hard_cases.py::test_high_speed_impact[reduced-compliant]",  # 9 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[rigid]",  # 6 s
    "tests/test_hard_cases.py::test_resting_contact_under_constant_torque[reduced]",  # 5 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[reduced]",  # 5 s
    "tests/test_hard_cases.py::test_high_speed_impact[fem-stiff]",  # 5 s
    "tests/test_hard_cases.py::test_at_rest_touching_the_wall_stays_at_rest[fem-stiff]",  # 4 s
    "tests/test_seed_schemes.py::test_gap_min_sees_the_penetration_between_communication_points[fem]",  # 4 s
    # the second group
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[destructor-fem-3]",  # 4.7
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[destructor-fem-2]",  # 4.2
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[destructor-rigid-3]",
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[atexit-first-rigid-2]",
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[destructor-rigid-2]",
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[atexit-first-rigid-3]",
    "tests/test_exit_time_host.py::test_instances_freed_after_python_is_finalised[destructor-destructor]",  # 3.7 s
    "tests/test_exit_time_host.py::test_instances_freed_after_python_is_finalised[atexit-first-atexit]",  # 3.5 s
    "tests/test_exit_time_host.py::test_instances_freed_after_python_is_finalised[atexit-last-atexit]",  # 3.2 s
    "tests/test_readme_examples.py::test_readme_bash_block_runs[fmi3_build]",  # 3.9 s
    "tests/test_readme_examples.py::test_readme_bash_block_runs[my_controller]",  # 3.1 s
    "tests/test_readme_examples.py::test_readme_bash_block_runs[field_output]",  # 2.8 s
    "tests/test_ecos_host.py::test_python_api_matches_fmpy_bit_for_bit[fem]",  # 3.9 s
    "tests/test_ecos_host.py::test_python_api_matches_fmpy_bit_for_bit[rigid]",  # 3.0 s
    "tests/test_command_failures.py::test_an_fmu_of_another_version_than_the_installed_package_is_refused_in_one_line"
    "[sweep]",  # 3.4 s
    "tests/test_concurrent_instances.py::test_native_threads_build_and_step_instances_at_once[2]",  # 3.3 s
    "tests/test_concurrent_instances.py::test_native_threads_build_and_step_instances_at_once[3]",  # 2.7 s
    "tests/test_fmu3.py::test_default_scene_gives_the_fmi2_fmus_results[reduced]",  # 2.6 s
    # the third group: 2 s or more in a run of `pytest -m "not slow" -n 2 --dist loadfile` (load average under 3)
    "tests/test_ecos_host.py::test_c_api_program_matches_fmpy_bit_for_bit[fem-empty-environment]",  # 3.0 s
    "tests/test_ecos_host.py::test_c_api_program_matches_fmpy_bit_for_bit[fem]",  # 2.7 s
    "tests/test_exit_time_host.py::test_fmpy_logger_is_not_called_after_python_is_finalised[atexit-last-rigid-3]",
    "tests/test_hosts.py::test_a_fresh_instance_started_from_a_saved_state_continues_bit_identically[fem]",  # 2.3 s
    "tests/test_concurrent_instances.py::test_fmpy_threads_build_and_step_instances_at_once[3]",  # 2.3 s
}


@pytest.hookimpl(tryfirst=True)  # before -m deselects
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid in SLOW_CASES:
            item.add_marker(pytest.mark.slow)
