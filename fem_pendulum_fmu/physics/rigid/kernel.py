"""The rigid fidelity's data as the compiled core's struct (struct femp_rigid, core/femp_core.h), and the
core's calls on it: the contact law and gap of the head's arc (core/rigid_model.c) and the whole advance
(core/rigid_advance.c). rigid/arc_contact.py and rigid/solve.py are the same law and step in Python, the
core's test reference (tests/test_rigid_core.py)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core import ffi, lib, pointer
from . import arc_contact


class RigidCore:
    """One rigid model's constants in the core's struct; the arrays it points to are held here."""

    def __init__(self, **fields: Any):
        self._tables = tuple(
            np.ascontiguousarray(table, dtype=np.float64)
            for table in (arc_contact._GL_X, arc_contact._GL_W, arc_contact._S_SERIES, arc_contact._C_SERIES)
        )
        self._limits = np.ascontiguousarray(arc_contact._PHI_LIMITS, dtype=np.float64)
        data = self.data = ffi.new("struct femp_rigid *")
        for name, value in fields.items():
            setattr(data, name, value)
        data.gl_x, data.gl_w, data.s_series, data.c_series = (pointer(t) for t in self._tables)
        data.series_terms, data.phi_limits = len(self._limits), pointer(self._limits)
        self._out = np.zeros(5)
        self._out_at = pointer(self._out)

    def penalty(self, theta: float) -> arc_contact.Penalty:
        """The contact at theta: energy, force and the energy's first two theta-derivatives."""
        lib.femp_rigid_penalty(self.data, theta, self._out_at)
        return arc_contact.new_named(arc_contact.Penalty, tuple(self._out.tolist()))

    def gap(self, theta: float) -> tuple[float, float]:
        """(signed gap, d gap / d theta) of the head's arc at theta."""
        lib.femp_rigid_gap(self.data, theta, self._out_at)
        return float(self._out[0]), float(self._out[1])

    def run_advance(self, x: Any, control: Any, torque: Any, advance: Any, stop: Any, context: Any) -> int:
        """femp_rigid_advance on this model's data (physics/compiled_advance.py makes the arguments)."""
        return int(lib.femp_rigid_advance(self.data, control, torque, x, advance, stop, context))
