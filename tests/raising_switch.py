"""The switch of the raising test copy of FemPendulum.fmu (tests/test_fmi2_contract.py): which of the slave's
entry points raise. The copy carries this file beside its entry script (tests/raising_entry.py); it imports
nothing of the package, so that the test's processes can read it before the FMU loads the package.
"""

from __future__ import annotations

import os

RAISING = (
    "setup_experiment",
    "enter_initialization_mode",
    "exit_initialization_mode",
    "do_step",
    "terminate",
    "get_real",
    "get_integer",
    "get_boolean",
    "get_string",
    "set_real",
    "set_integer",
    "set_boolean",
    "set_string",
    "_get_fmu_state",
    "_set_fmu_state",
    "_fmu_state_to_bytes",
    "_fmu_state_from_bytes",
)
RAISE_SWITCH = "FEMP_TEST_RAISE"  # names the methods that raise, comma-separated; "*": all of RAISING


def planted(method: str) -> None:
    """Raise RuntimeError if RAISE_SWITCH names `method` ("*": every entry point, not __init__)."""
    names = os.environ.get(RAISE_SWITCH, "").split(",")
    if method in names or ("*" in names and method != "__init__"):
        raise RuntimeError("planted failure in " + method)
