"""The held Newton Jacobian's LU factors and their solve.

Factorised by SuperLU (scipy's splu) on the free unknowns; the solve runs in
the compiled kernel (native.py), where one costs about a tenth of an ngsolve
UMFPACK inverse's Mult on the 302 unknowns of the steel scene's mesh: that
Mult, not the arithmetic, was the larger half of a Newton iteration once the
residual was compiled (docs/fem.md, "Profile and speed-up"). Without the
kernel, SuperLU's own solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .. import native
from ..sparse import scipy_matrix


def _splu(matrix: sp.csc_matrix) -> spl.SuperLU:
    """SuperLU in its mode for matrices of symmetric pattern: a minimum-degree ordering of A + A^T and
    the diagonal as pivot unless it is under 0.1 of its column's largest entry (the hinge multipliers'
    zero diagonal is pivoted away). Against the default (COLAMD, partial pivoting) the factors hold 9.8k
    instead of 15.8k entries on the steel scene's mesh and 26k instead of 59k on the rubber one; the
    matrix must be equilibrated (`Pattern.equilibrated`) for the diagonal to qualify."""
    return spl.splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1, options={"SymmetricMode": True})


@dataclass
class Pattern:
    """A CSC matrix's sparsity pattern, with each entry's column, so that matrices on it are data arrays."""

    indptr: np.ndarray
    indices: np.ndarray
    columns: np.ndarray  # the column of each entry

    @staticmethod
    def of(matrix: sp.csc_matrix) -> Pattern:
        n = matrix.shape[1]
        return Pattern(matrix.indptr, matrix.indices, np.repeat(np.arange(n), np.diff(matrix.indptr)))

    def equilibrated(self, data: np.ndarray) -> tuple[sp.csc_matrix, np.ndarray]:
        """(S A S, S) for the matrix with these entries, S scaling every column's (and, the pattern and
        nearly the values being symmetric, every row's) largest entry to about 1. In rubber contact the
        penalty rows are 1e3-1e4 times the others: unscaled, half the diagonal fell under the pivot
        threshold and the factors grew from 26k to 194k entries."""
        largest = np.maximum.reduceat(np.abs(data), self.indptr[:-1])
        scale = 1.0 / np.sqrt(np.where(largest > 0.0, largest, 1.0))
        n = len(self.indptr) - 1
        scaled = sp.csc_matrix((data * scale[self.indices] * scale[self.columns], self.indices, self.indptr), (n, n))
        return scaled, scale


def _int32(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32)


class HeldFactor:
    """LU factors of a matrix's free block; solve(b, x) sets x = A^-1 b on the free unknowns."""

    def __init__(self, free: np.ndarray, mass: sp.csr_matrix | None = None):
        self.free = _int32(np.flatnonzero(free))
        # the inertia term's matrix on the free block, for factorise_shifted
        self._mass = None if mass is None else mass[self.free][:, self.free].tocsc()
        self._pattern: Pattern | None = None  # of the last assembled matrix
        self._assembled = np.zeros(0)  # its entries
        self._mass_entries: np.ndarray | None = None  # the inertia term's entries on that pattern
        self._lib = native.kernels()
        self._lu: spl.SuperLU | None = None
        self.kernel_args: tuple = ()  # the kernel's LU arguments (addresses of the factors' arrays)
        self.work_at = 0
        self._work = np.zeros(len(self.free))
        self._scale = np.ones(len(self.free))  # S of the factorised S A S

    def factorise(self, mat: ngs.BaseMatrix) -> None:
        """Factorise the free block of an assembled ngsolve matrix."""
        assembled = scipy_matrix(mat)[self.free][:, self.free].tocsc()
        assembled.sort_indices()
        if self._pattern is None or not self._same_pattern(assembled):
            self._pattern = pattern = Pattern.of(assembled)
            self._mass_entries = None if self._mass is None else self._on_pattern(self._mass, pattern)
        self._assembled = assembled.data
        self._use(self._assembled)

    def _same_pattern(self, matrix: sp.csc_matrix) -> bool:
        p = self._pattern
        return p is not None and np.array_equal(p.indptr, matrix.indptr) and np.array_equal(p.indices, matrix.indices)

    @staticmethod
    def _on_pattern(mass: sp.csc_matrix, pattern: Pattern) -> np.ndarray | None:
        """The mass matrix's entries on the assembled matrix's pattern (None if that does not hold it)."""
        n = len(pattern.indptr) - 1
        mass = mass.tocsc()
        mass.sort_indices()
        keys = pattern.columns.astype(np.int64) * n + pattern.indices  # sorted: columns, then rows
        mass_keys = Pattern.of(mass).columns.astype(np.int64) * n + mass.indices
        at = np.searchsorted(keys, mass_keys)
        if np.any(at >= len(keys)) or not np.array_equal(keys[np.minimum(at, len(keys) - 1)], mass_keys):
            return None
        entries = np.zeros(len(keys))
        entries[at] = mass.data
        return entries

    def factorise_shifted(self, shift: float) -> bool:
        """Factorise the last assembled matrix plus shift times the inertia term's matrix; False where that
        is not known (no inertia term given, or it is not on the assembled pattern)."""
        if self._mass_entries is None:
            return False
        self._use(self._assembled + shift * self._mass_entries)
        return True

    def _use(self, entries: np.ndarray) -> None:
        assert self._pattern is not None
        scaled, self._scale = self._pattern.equilibrated(entries)
        lu = _splu(scaled)
        self._lu = lu
        if self._lib is None:
            return
        L, U = lu.L.tocsc(), lu.U.tocsc()
        # the arrays the kernel reads, kept alive with the addresses handed to it
        self._keep: tuple[np.ndarray, ...] = (_int32(lu.perm_r), _int32(lu.perm_c), _int32(L.indptr))
        self._keep += (_int32(L.indices), L.data.copy(), _int32(U.indptr), _int32(U.indices), U.data.copy())
        self._keep += (U.diagonal().copy(), self._scale)
        addresses = [a.ctypes.data for a in self._keep]
        self.kernel_args = (len(self.free), self.free.ctypes.data, addresses[-1], *addresses[:-1])
        self.work_at = self._work.ctypes.data

    def solve(self, b: np.ndarray, x: np.ndarray) -> None:
        """x[free] = (A^-1 b)[free] (b and x contiguous, over all unknowns; x elsewhere untouched)."""
        if self._lib is not None:
            self._lib.femp_lu_solve(*self.kernel_args, b.ctypes.data, self.work_at, x.ctypes.data)
            return
        assert self._lu is not None
        x[self.free] = self._scale * self._lu.solve(self._scale * b[self.free])
