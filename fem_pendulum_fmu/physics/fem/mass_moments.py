"""The mass's quadratic forms the outputs read at every step, in one pass over the scalar mass.

The kinetic energy v.M v of every step's end, and for the outputs' best-fit
rotation u.M u and the cross form u.C v, were three products with the
assembled 2n x 2n matrices (6 us each on the default mesh, 56 us at 0.005 m).
M is diag(S, S) for the scalar mass S of a two-component field (NGSolve
orders the x components' dofs first), and C is [[0, -S], [S, 0]], so one pass
over S makes them all (core/fem_mass_moments.c). `BlockMass.of` checks that
structure on the assembled matrices and gives None where it does not hold,
for the outputs to keep the plain products.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..core import ffi, lib, pointer
from ..sparse import int32_indices

# how close the assembled blocks must be to diag(S, S) (and C to [[0, -S], [S, 0]]), relative to S's largest
# entry: NGSolve integrates the y block apart from the x block, 2e-16 apart (measured on the default mesh)
SAME_BLOCK = 1e-12


class BlockMass:
    """M = diag(S, S) of a two-component field, by its scalar block S."""

    def __init__(self, scalar: sp.csr_matrix):
        self._s, self._n = scalar, scalar.shape[0]
        self._args = (self._n, pointer(scalar.indptr), pointer(scalar.indices), pointer(scalar.data))
        self._out = np.zeros(3)
        self._out_at = pointer(self._out)

    @staticmethod
    def of(mass: sp.csr_matrix, cross: sp.csr_matrix | None = None) -> BlockMass | None:
        """The block form of an assembled mass (and, given, its cross form), or None where they are not so."""
        n2 = mass.shape[0]
        if n2 % 2 or mass.shape != (n2, n2):
            return None
        n = n2 // 2
        scalar = sp.csr_matrix(mass[:n, :n])
        tol = SAME_BLOCK * max(float(abs(scalar).max()), 1e-300)
        expected = [sp.block_diag((scalar, scalar), format="csr")]
        if cross is not None:
            expected.append(sp.bmat([[None, -scalar], [scalar, None]], format="csr"))
        for assembled, model in zip((mass, cross), expected, strict=False):
            if assembled.shape != model.shape or abs(assembled - model).max() > tol:
                return None
        scalar.sort_indices()
        return BlockMass(int32_indices(scalar))

    def square(self, a: np.ndarray) -> float:
        """a.M a."""
        a = np.ascontiguousarray(a, dtype=np.float64)
        lib.femp_mass_moments(*self._args, pointer(a), ffi.NULL, self._out_at)
        return float(self._out[0])

    def square_and_cross(self, a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
        """(a.M a, a.C b)."""
        a, b = (np.ascontiguousarray(x, dtype=np.float64) for x in (a, b))
        lib.femp_mass_moments(*self._args, pointer(a), pointer(b), self._out_at)
        return float(self._out[0]), float(self._out[2])
