"""The reduced fidelity's compiled step and terms (core/reduced_step.c), bound to one model's data.

The reduced model's step (reduced/step.py), contact (reduced/contact.py), gap (reduced/head.py) and
NeoHookeanStrain (reduced/strain.py) call these; tests/test_reduced_native.py holds them to the model's
NGSolve-built data.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core import ffi, lib, pointer
from ..core import fields as struct_fields


class ReducedKernel:
    """One model's data as the C struct (struct femp_reduced), and the core's calls on it. The arrays the
    struct points into are held here (C-contiguous copies), so they live as long as the struct."""

    def __init__(self, **fields: Any):
        self._arrays: list[np.ndarray] = []
        data = ffi.new("struct femp_reduced *")
        unknown = set(fields) - set(struct_fields("struct femp_reduced"))
        if unknown:
            raise TypeError(f"not fields of the reduced kernel's struct: {', '.join(sorted(unknown))}")
        for name, value in fields.items():
            if isinstance(value, np.ndarray):
                dtype = np.int32 if value.dtype.kind in "iu" else np.float64
                array = np.ascontiguousarray(value, dtype=dtype)
                self._arrays.append(array)
                setattr(data, name, pointer(array))
            else:
                setattr(data, name, value)
        # the potential energy of the last step's end, which the next advance starts from (femp_core.h)
        self._potential_memo = np.zeros(int(fields["m"]) + 3)
        data.potential_memo = pointer(self._potential_memo)
        self._ref = data
        self.n = n = int(fields["m"]) + 1
        # fixed buffers, their pointers taken once: (z0, p0) in, (z1, p1, work and energies) out
        self._in, self._out = np.empty(2 * n), np.empty(2 * n + 4)
        self._in_at, self._out_at = pointer(self._in), pointer(self._out)
        self._contact = np.empty(4 + n + n * n)

    def step(
        self, z0: np.ndarray, p0: np.ndarray, V0: float, dt: float, torque: float
    ) -> tuple[np.ndarray, np.ndarray, float, tuple[float, float, float]] | None:
        """(z1, p1, the step's torque work, (gravity, contact, strain) energies at z1), or None when
        Newton does not converge."""
        n, buffer, out = self.n, self._in, self._out
        buffer[:n] = z0
        buffer[n:] = p0
        at, out_at = self._in_at, self._out_at
        if not lib.femp_reduced_step(self._ref, at, at + n, V0, dt, torque, out_at, out_at + n, out_at + 2 * n):
            return None
        work, gravity, contact, strain = out[2 * n :].tolist()
        return out[:n].copy(), out[n : 2 * n].copy(), work, (gravity, contact, strain)

    def run_advance(self, x: Any, control: Any, torque: Any, advance: Any, stop: Any, context: Any) -> int:
        """femp_reduced_advance on this model's data (physics/compiled_advance.py makes the arguments)."""
        return int(lib.femp_reduced_advance(self._ref, control, torque, x, advance, stop, context))

    def gap(self, z: np.ndarray) -> float:
        return float(lib.femp_reduced_gap(self._ref, pointer(z)))

    def contact(self, z: np.ndarray) -> tuple | None:
        """(energy, gradient, Gauss-Newton Hessian, force (2,)), or None with no head point inside."""
        out = self._contact
        lib.femp_reduced_contact(self._ref, pointer(z), pointer(out))
        if out[0] == 0.0:
            return None
        n = self.n
        return float(out[1]), out[4 : 4 + n].copy(), out[4 + n :].reshape(n, n).copy(), out[2:4].copy()

    def strain_energy(self, q: np.ndarray) -> float:
        return float(lib.femp_reduced_strain_energy(self._ref, pointer(np.ascontiguousarray(q))))

    def strain_gradient(self, q: np.ndarray) -> np.ndarray:
        grad = np.empty(self.n - 1)
        lib.femp_reduced_strain_gradient(self._ref, pointer(np.ascontiguousarray(q)), pointer(grad))
        return grad

    def strain_hessian(self, q: np.ndarray) -> np.ndarray:
        hess = np.empty((self.n - 1, self.n - 1))
        lib.femp_reduced_strain_hessian(self._ref, pointer(np.ascontiguousarray(q)), pointer(hess))
        return hess


def reduced_kernel(**fields: Any) -> ReducedKernel:
    """The core bound to these fields (struct femp_reduced's names)."""
    return ReducedKernel(**fields)
