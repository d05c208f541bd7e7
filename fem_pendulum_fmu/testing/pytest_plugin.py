"""The pytest plugin of fem_pendulum_fmu (entry point `pytest11`): the fixture `pendulum_loop`.

    def test_my_controller(pendulum_loop):
        result = pendulum_loop(my_law, setpoint="step:10deg", fidelity="rigid")
        result.check(settles_within=1.0)

The fixture is `closed_loop` (testing/closed_loop.py) with `fmu` defaulting to the pendulum FMU
of the command-line option --pendulum-fmu, else dist/FemPendulum.fmu under pytest's root folder,
built once if missing. It imports nothing heavy until a test asks for it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest


def pytest_addoption(parser: Any) -> None:
    group = parser.getgroup("fem_pendulum_fmu")
    group.addoption("--pendulum-fmu", default=None, help="the pendulum FMU the fixture pendulum_loop runs")


@pytest.fixture(scope="session")
def pendulum_fmu(pytestconfig: Any) -> Path:
    """The pendulum FMU of this session (built once if missing)."""
    from .fmus import default_fmu

    given = pytestconfig.getoption("--pendulum-fmu")
    if given:
        return Path(given)
    return default_fmu("FemPendulum.fmu", Path(pytestconfig.rootpath) / "dist")


@pytest.fixture
def pendulum_loop(pendulum_fmu: Path) -> Callable[..., Any]:
    """closed_loop(controller, ...) on the session's pendulum FMU; its result has .check(**bounds)."""
    from .closed_loop import closed_loop

    return functools.partial(closed_loop, fmu=pendulum_fmu)
