"""The held Newton Jacobian's LU factors and their solve.

Factorised by SuperLU (scipy's splu) on the free unknowns; the solve runs in
the compiled kernel (native.py), where one costs about a tenth of an ngsolve
UMFPACK inverse's Mult on the 302 unknowns of the steel scene's mesh: that
Mult, not the arithmetic, was the larger half of a Newton iteration once the
residual was compiled (docs/fem.md, "Profile and speed-up"). Without the
kernel, SuperLU's own solve.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .. import native


def _splu(matrix: sp.csc_matrix) -> spl.SuperLU:
    """SuperLU in its mode for matrices of symmetric pattern: a minimum-degree ordering of A + A^T and
    the diagonal as pivot unless it is under 0.1 of its column's largest entry (the hinge multipliers'
    zero diagonal is pivoted away). Against the default (COLAMD, partial pivoting) the factors hold 9.8k
    instead of 15.8k entries on the steel scene's mesh and 26k instead of 59k on the rubber one; the
    matrix must be equilibrated (`_scaling`) for the diagonal to qualify."""
    return spl.splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1, options={"SymmetricMode": True})


def _scaling(matrix: sp.csc_matrix) -> np.ndarray:
    """S with the rows and columns of S A S of largest entry about 1. In rubber contact the penalty rows
    are 1e3-1e4 times the others: unscaled, half the diagonal fell under the pivot threshold and the
    factors grew from 26k to 194k entries."""
    largest = abs(matrix).max(axis=1).toarray().ravel()
    return 1.0 / np.sqrt(np.where(largest > 0.0, largest, 1.0))


def _int32(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32)


class HeldFactor:
    """LU factors of a matrix's free block; solve(b, x) sets x = A^-1 b on the free unknowns."""

    def __init__(self, free: np.ndarray, mass: sp.csr_matrix | None = None):
        self.free = _int32(np.flatnonzero(free))
        # the inertia term's matrix on the free block, for factorise_shifted
        self._mass = None if mass is None else mass[self.free][:, self.free].tocsc()
        self._assembled: sp.csc_matrix | None = None
        self._lib = native.kernels()
        self._lu: spl.SuperLU | None = None
        self.kernel_args: tuple = ()  # the kernel's LU arguments (addresses of the factors' arrays)
        self.work_at = 0
        self._work = np.zeros(len(self.free))
        self._scale = np.ones(len(self.free))  # S of the factorised S A S

    def factorise(self, mat: ngs.BaseMatrix) -> None:
        """Factorise the free block of an assembled ngsolve matrix."""
        rows, cols, vals = mat.COO()
        full = sp.csr_matrix((np.array(vals), (np.array(rows), np.array(cols))), shape=(mat.height, mat.width))
        self._assembled = full[self.free][:, self.free].tocsc()
        self._use(self._assembled)

    def factorise_shifted(self, shift: float) -> None:
        """Factorise the last assembled matrix plus shift times the inertia term's matrix."""
        assert self._assembled is not None and self._mass is not None
        self._use((self._assembled + shift * self._mass).tocsc())

    def _use(self, matrix: sp.csc_matrix) -> None:
        self._scale = _scaling(matrix)
        scale = sp.diags(self._scale)
        lu = _splu((scale @ matrix @ scale).tocsc())
        self._lu = lu
        if self._lib is None:
            return
        L, U = lu.L.tocsc(), lu.U.tocsc()
        # the arrays the kernel reads, kept alive with the addresses handed to it
        self._keep: tuple[np.ndarray, ...] = (_int32(lu.perm_r), _int32(lu.perm_c), _int32(L.indptr))
        self._keep += (_int32(L.indices), L.data.copy(), _int32(U.indptr), _int32(U.indices), U.data.copy())
        self._keep += (U.diagonal().copy(),)
        self._keep += (self._scale,)
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
