"""A trivial slave with FemPendulum's variables: the cost floor of a Python FMU (benchmarks/rigid_floor.py).

benchmarks/rigid_floor.py builds it into an FMU with VARIABLES_FILE beside it in the FMU's resources:
FemPendulum's inputs, parameters and Real outputs as [name, type, causality, variability, start], read from
the package's interface at build time. The slave imports nothing of the package.
"""

import json
from pathlib import Path

from pythonfmu import Fmi2Slave
from pythonfmu.enums import Fmi2Causality, Fmi2Initial, Fmi2Variability
from pythonfmu.variables import Boolean, Integer, Real, String

VARIABLES_FILE = "rigid_floor_variables.json"
TYPES = {"Real": Real, "Integer": Integer, "Enumeration": Integer, "Boolean": Boolean, "String": String}


class RigidFloor(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.values = {}
        self.torque = 0.0
        self.theta = 0.0
        variables = json.loads((Path(__file__).parent / VARIABLES_FILE).read_text())
        for name, typ, causality, variability, start in variables:
            self._add(name, typ, causality, variability, start)

    def _add(self, name, typ, causality, variability, start):
        extra = {}
        if causality == "parameter":
            self.values[name] = start
            extra = dict(initial=Fmi2Initial.exact, setter=lambda v, n=name: self.values.__setitem__(n, v))
            getter = lambda n=name: self.values[n]  # noqa: E731
        elif causality == "input":
            getter, extra["setter"] = (lambda: self.torque), self._set_torque
        elif name == "theta":
            getter = lambda: self.theta  # noqa: E731
        else:
            getter = lambda: 0.0  # noqa: E731
        if start is not None:
            extra["start"] = start
        var = TYPES[typ](
            name, causality=Fmi2Causality[causality], variability=Fmi2Variability[variability], getter=getter, **extra
        )
        self.register_variable(var, nested=False)

    def _set_torque(self, value):
        self.torque = float(value)

    def do_step(self, current_time, step_size):
        self.theta += self.torque * step_size
        return True
