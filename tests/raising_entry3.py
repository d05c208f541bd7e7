"""Entry script of a test copy of the FMI 3.0 FemPendulum FMU (tests/test_fmu3.py): the FMU's own class,
subclassed so that each of its FMI entry points raises RuntimeError while the environment variable RAISE3
names it ("*": every one of them). The copy carries it as resources/femp3_slave_entry.py.
"""

import os

from fem_pendulum_fmu.fmi.femp3_slave_entry import FemPendulum as _Original

ENTRY_POINTS = (
    "setup_experiment",
    "enter_initialization_mode",
    "exit_initialization_mode",
    "do_step",
    "get_float64",
    "set_float64",
    "get_int64",
    "set_int64",
    "get_boolean",
    "get_string",
    "_get_fmu_state",
    "_set_fmu_state",
    "_fmu_state_to_bytes",
    "terminate",
)


def _raising(name):
    original = getattr(_Original, name)

    def method(self, *args, **kwargs):
        if os.environ.get("RAISE3") in ("*", name):
            raise RuntimeError(f"{name} raised on purpose")
        return original(self, *args, **kwargs)

    method.__name__ = name
    return method


class FemPendulum(_Original):
    """The pendulum, raising on request."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)


for _name in ENTRY_POINTS:
    setattr(FemPendulum, _name, _raising(_name))
