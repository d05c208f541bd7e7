"""Shared fixtures: the FMUs are built once per test session, into a temporary folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def fmus(tmp_path_factory) -> tuple[Path, Path]:
    """(FemPendulum.fmu, PidController.fmu) built by `fem-pendulum build` as a user would run it."""
    out = tmp_path_factory.mktemp("dist")
    run = subprocess.run(
        [str(Path(sys.executable).parent / "fem-pendulum"), "build", "--output", str(out / "FemPendulum.fmu")],
        cwd=out,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.split() == [str(out / "FemPendulum.fmu"), str(out / "PidController.fmu")]
    return out / "FemPendulum.fmu", out / "PidController.fmu"


@pytest.fixture(scope="session")
def pd_fmu(tmp_path_factory) -> Path:
    """tests/pd_controller_under_test.py built by pythonfmu's own builder (its binary, not the project's), in a
    child process: in this one, once a pythonfmu FMU has run, `pythonfmu` may be the copy inside that FMU's
    extracted resources, whose builder has no binaries to pack."""
    out = tmp_path_factory.mktemp("pd")
    script = Path(__file__).resolve().parent / "pd_controller_under_test.py"
    run = subprocess.run(
        [sys.executable, "-m", "pythonfmu", "build", "-f", str(script), "-d", str(out)], capture_output=True, text=True
    )
    assert run.returncode == 0, run.stdout + run.stderr
    return out / "PdControllerUnderTest.fmu"


@pytest.fixture(scope="session")
def fmu3(tmp_path_factory) -> Path:
    """The FMI 3.0 FemPendulum FMU, built once per session by `fem-pendulum build --fmi-version 3`."""
    out = tmp_path_factory.mktemp("dist3")
    target = out / "FemPendulum3.fmu"
    command = [str(Path(sys.executable).parent / "fem-pendulum"), "build", "--fmi-version", "3", "--output"]
    run = subprocess.run([*command, str(target)], cwd=out, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.split() == [str(target)]
    return target


# The slow lane's parametrized cases (whole tests carry @pytest.mark.slow in their files): the cases that took
# 4 s or more in a full run of the suite on the 2-core machine while two other suites ran (2026-12-01; about 2 s of
# CPU each), so that `pytest -m "not slow"` stays under 2 minutes. The cheaper cases of the same tests stay fast.
SLOW_CASES = {
    "tests/test_hard_cases.py::test_high_speed_impact[fem-compliant]",  # 102 s
    "tests/test_hard_cases.py::test_violent_square_wave_torque_over_the_top[fem]",  # 68 s
    "tests/test_hard_cases.py::test_grazing_release_at_half_a_degree[fem]",  # 14 s
    "tests/test_hard_cases.py::test_resting_contact_under_constant_torque[fem]",  # 14 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[fem]",  # 12 s
    "tests/test_fidelities.py::test_state_round_trip_and_determinism_are_bit_identical[fem]",  # 12 s
    "tests/test_hard_cases.py::test_at_rest_touching_the_wall_stays_at_rest[fem-compliant]",  # 11 s
    "tests/test_fidelities.py::test_energy_balances_the_torque_work_through_an_impact[fem]",  # 9 s
    "tests/test_hard_cases.py::test_high_speed_impact[reduced-compliant]",  # 9 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[rigid]",  # 6 s
    "tests/test_hard_cases.py::test_resting_contact_under_constant_torque[reduced]",  # 5 s
    "tests/test_hard_cases.py::test_large_communication_steps_across_an_impact[reduced]",  # 5 s
    "tests/test_hard_cases.py::test_high_speed_impact[fem-stiff]",  # 5 s
    "tests/test_hard_cases.py::test_at_rest_touching_the_wall_stays_at_rest[fem-stiff]",  # 4 s
    "tests/test_seed_schemes.py::test_gap_min_sees_the_penetration_between_communication_points[fem]",  # 4 s
}


@pytest.hookimpl(tryfirst=True)  # before -m deselects
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.nodeid in SLOW_CASES:
            item.add_marker(pytest.mark.slow)
