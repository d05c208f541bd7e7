"""Controller-in-the-loop testing: run a controller against the pendulum FMU and assert on the run.

    from fem_pendulum_fmu.testing import closed_loop, assert_loop

    def pd(t, m):
        return 8.0 * m.error - 0.4 * m.omega

    result = closed_loop(pd, setpoint="step:10deg", stop_time=1.5, fidelity="rigid")
    assert_loop(result, settles_within=1.0, max_contact_force_below=500.0)

`result.series` is a pandas DataFrame (masters/control/series.py), `result.metrics` a mapping of
metric name to value (masters/control/metrics.py). The pytest plugin (pytest_plugin.py, registered
as the `pytest11` entry point) gives tests the fixture `pendulum_loop`: closed_loop with the suite's
FMUs built once. Names load on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "closed_loop": "closed_loop",
    "LoopResult": "closed_loop",
    "Measurements": "..masters.control.controllers",
    "assert_loop": "..masters.control.checks",
    "LoopCheckFailed": "..masters.control.checks",
    "default_fmu": "fmus",
}
__all__ = ["LoopCheckFailed", "LoopResult", "Measurements", "assert_loop", "closed_loop", "default_fmu"]

if TYPE_CHECKING:
    from ..masters.control.checks import LoopCheckFailed, assert_loop
    from ..masters.control.controllers import Measurements
    from .closed_loop import LoopResult, closed_loop
    from .fmus import default_fmu


def __getattr__(name: str) -> Any:
    """The public names, imported from their modules when first asked for."""
    if name not in _EXPORTS:
        raise AttributeError(f"module 'fem_pendulum_fmu.testing' has no attribute {name!r}")
    module = _EXPORTS[name]
    value = getattr(importlib.import_module(module if module.startswith("..") else f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
