"""NGSolve's assembled matrices in scipy's CSR form, for the numpy and compiled code that works on them."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from .core import lib, pointer

if TYPE_CHECKING:
    from ngsolve.la import BaseMatrix


def scipy_matrix(mat: BaseMatrix) -> sp.csr_matrix:
    """The matrix in scipy's CSR form, with the int32 indices the compiled core (core/femp_core.h) reads."""
    rows, cols, vals = mat.COO()
    coo = (np.array(vals), (np.array(rows), np.array(cols)))
    return int32_indices(sp.csr_matrix(coo, shape=(mat.height, mat.width)))


def nonzero_entries(csr: sp.csr_matrix) -> sp.csr_matrix:
    """csr without its stored zeros (int32 indices kept): a product over it adds the same nonzero terms in the
    same order, so the same bits for finite vectors."""
    csr.eliminate_zeros()
    return int32_indices(csr)


def int32_indices(csr: sp.csr_matrix) -> sp.csr_matrix:
    """csr with int32 index arrays, as the compiled kernels (and MatVec) take them."""
    csr.indptr, csr.indices = csr.indptr.astype(np.int32), csr.indices.astype(np.int32)
    return csr


class MatVec:
    """A x for a CSR matrix with int32 indices: the core's row loop (scipy's sums in scipy's order, so the same
    bits) without scipy's dispatch, which costs about 10 us a product, several per step."""

    def __init__(self, mat: sp.csr_matrix):
        self._mat = mat
        if mat.indptr.dtype != np.int32 or mat.indices.dtype != np.int32 or mat.data.dtype != np.float64:
            raise ValueError("MatVec needs int32 indices and float64 entries (scipy_matrix)")
        self._args = (mat.shape[0], pointer(mat.indptr), pointer(mat.indices), pointer(mat.data))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """A x, a new array."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        out = np.zeros(self._args[0])
        lib.femp_csr_axpy(*self._args, 1.0, pointer(x), pointer(out))
        return out


def require_halves_share_columns(matrix: sp.csr_matrix) -> None:
    """Row i and row n/2 + i of the matrix hold the same columns in the same order, for every i: a point's
    d/dx and d/dy rows of a gradient matrix, which the compiled kernels read through the d/dx row's columns
    (core/fem_elastic.c, gradients_at). ValueError where they do not."""
    ptr, idx, q = matrix.indptr, matrix.indices, matrix.shape[0] // 2
    same_lengths = np.array_equal(np.diff(ptr[: q + 1]), np.diff(ptr[q:]))
    if not (same_lengths and np.array_equal(idx[ptr[0] : ptr[q]], idx[ptr[q] : ptr[2 * q]])):
        raise ValueError("the gradient matrix's d/dx and d/dy rows hold different columns")
