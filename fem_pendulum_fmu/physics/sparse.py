"""NGSolve's assembled matrices in scipy's CSR form, for the numpy and compiled code that works on them."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

if TYPE_CHECKING:
    from ngsolve.la import BaseMatrix


def scipy_matrix(mat: BaseMatrix) -> sp.csr_matrix:
    """The matrix in scipy's CSR form, with the int32 indices the compiled kernel (native.py) reads."""
    rows, cols, vals = mat.COO()
    csr = sp.csr_matrix((np.array(vals), (np.array(rows), np.array(cols))), shape=(mat.height, mat.width))
    csr.indptr, csr.indices = csr.indptr.astype(np.int32), csr.indices.astype(np.int32)
    return csr
