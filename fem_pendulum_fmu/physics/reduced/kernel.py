"""The reduced fidelity's compiled step and terms (physics/reduced/reduced_kernel.c), bound to one model's data.

The reduced model's step (reduced/step.py), contact (reduced/contact.py), gap (reduced/head.py)
and NeoHookeanStrain (reduced/strain.py) keep their numpy forms of the same computations; where
native.kernels() finds a C compiler they call these instead (equal up to round-off, each run
deterministic either way; tests/test_reduced_native.py compares them).
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from .. import native

_I, _D, _P = ctypes.c_int, ctypes.c_double, ctypes.c_void_p


class KernelData(ctypes.Structure):
    """The C struct `Reduced` of physics/reduced/reduced_kernel.c, field for field."""

    _fields_ = [
        ("m", _I),
        ("inertia0", _D),
        ("g", _D),
        ("hk", _D),
        ("gyro", _P),
        ("a", _P),
        ("first_moment", _P),
        ("moment_modes", _P),
        ("q_unit", _P),
        ("omega2", _P),
        ("neo", _I),
        ("nqp", _I),
        ("GT", _P),
        ("qw", _P),
        ("k_mu", _P),
        ("lame_lambda", _D),
        ("mu", _D),
        ("work", _P),
        ("contact_on", _I),
        ("x_min", _D),
        ("x_max", _D),
        ("y_min", _D),
        ("y_max", _D),
        ("head_cx", _D),
        ("head_cy", _D),
        ("head_radius", _D),
        ("phi_peak", _P),
        ("P", _I),
        ("head_X", _P),
        ("head_phi", _P),
        ("head_w", _P),
        ("groups", _I),
        ("group_start", _P),
        ("group_centre", _P),
        ("group_radius", _P),
        ("group_peak", _P),
        ("max_it", _I),
        ("update_tol", _D),
        ("energy_tol", _D),
        ("stall_tol", _D),
    ]


def _pointer(array: np.ndarray) -> int:
    return int(array.ctypes.data)


class ReducedKernel:
    """One model's data as the C struct, and the kernel's calls on it. The arrays the struct points
    into are held here (C-contiguous copies), so they live as long as the struct."""

    def __init__(self, lib: ctypes.CDLL, **fields: Any):
        self._lib = lib
        self._arrays: list[np.ndarray] = []
        data = KernelData()
        unknown = set(fields) - {field[0] for field in KernelData._fields_}
        if unknown:  # ctypes would keep them as plain attributes, and the C side would read zeros
            raise TypeError(f"not fields of the reduced kernel's struct: {', '.join(sorted(unknown))}")
        for name, value in fields.items():
            if isinstance(value, np.ndarray):
                dtype = np.int32 if value.dtype.kind in "iu" else np.float64
                array = np.ascontiguousarray(value, dtype=dtype)
                self._arrays.append(array)
                setattr(data, name, _pointer(array))
            else:
                setattr(data, name, value)
        self._data = data
        self._ref = ctypes.byref(data)
        self.n = n = int(fields["m"]) + 1
        # fixed buffers, their addresses taken once: (z0, p0) in, (z1, p1, work and energies) out
        self._in, self._out = np.empty(2 * n), np.empty(2 * n + 4)
        self._in_at, self._out_at = _pointer(self._in), _pointer(self._out)
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
        if not self._lib.femp_reduced_step(
            self._ref, at, at + 8 * n, V0, dt, torque, out_at, out_at + 8 * n, out_at + 16 * n
        ):
            return None
        work, gravity, contact, strain = out[2 * n :].tolist()
        return out[:n].copy(), out[n : 2 * n].copy(), work, (gravity, contact, strain)

    def gap(self, z: np.ndarray) -> float:
        return float(self._lib.femp_reduced_gap(self._ref, _pointer(z)))

    def contact(self, z: np.ndarray) -> tuple | None:
        """(energy, gradient, Gauss-Newton Hessian, force (2,)), or None with no head point inside."""
        out = self._contact
        self._lib.femp_reduced_contact(self._ref, _pointer(z), _pointer(out))
        if out[0] == 0.0:
            return None
        n = self.n
        return float(out[1]), out[4 : 4 + n].copy(), out[4 + n :].reshape(n, n).copy(), out[2:4].copy()

    def strain_energy(self, q: np.ndarray) -> float:
        return float(self._lib.femp_reduced_strain_energy(self._ref, _pointer(np.ascontiguousarray(q))))

    def strain_gradient(self, q: np.ndarray) -> np.ndarray:
        grad = np.empty(self.n - 1)
        self._lib.femp_reduced_strain_gradient(self._ref, _pointer(np.ascontiguousarray(q)), _pointer(grad))
        return grad

    def strain_hessian(self, q: np.ndarray) -> np.ndarray:
        hess = np.empty((self.n - 1, self.n - 1))
        self._lib.femp_reduced_strain_hessian(self._ref, _pointer(np.ascontiguousarray(q)), _pointer(hess))
        return hess


def reduced_kernel(**fields: Any) -> ReducedKernel | None:
    """The kernel bound to these fields (KernelData's names), or None where nothing compiled."""
    lib = native.kernels()
    return None if lib is None else ReducedKernel(lib, **fields)
