"""Entry script of a test copy of FemPendulum.fmu (tests/test_fmi2_contract.py): the FMU's own class,
subclassed so that each FMI entry point, and __init__, raises RuntimeError while the environment variable
tests/raising_switch.py's RAISE_SWITCH names it ("*": every entry point, not __init__).

The copy carries it as resources/femp_slave_entry.py, with resources/raising_switch.py beside it.
"""

import inspect

from raising_switch import RAISING, planted

from fem_pendulum_fmu.fmi.femp_slave_entry import FemPendulum as _Original


def _raising(name):
    original = inspect.getattr_static(_Original, name)
    static = isinstance(original, staticmethod)
    function = original.__func__ if static else original

    def method(*args, **kwargs):
        planted(name)
        return function(*args, **kwargs)

    method.__name__ = name
    return staticmethod(method) if static else method


class FemPendulum(_Original):
    """The pendulum, raising on request."""

    def __init__(self, **kwargs):
        planted("__init__")
        super().__init__(**kwargs)


for _name in RAISING:
    setattr(FemPendulum, _name, _raising(_name))
