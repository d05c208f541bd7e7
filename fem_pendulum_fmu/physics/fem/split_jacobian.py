"""The energy-momentum step form's Jacobian from the split residual's parts (fem/residual.py), as the
entries of a matrix on the full form's CSC pattern, for the held factors of fem/lu.py."""

from __future__ import annotations

from typing import TYPE_CHECKING

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp

if TYPE_CHECKING:
    from .residual import SplitResidual


class SplitJacobian:
    """The energy-momentum step form's Jacobian at w, as the entries of a matrix on a CSC pattern of the
    free unknowns (the full form's, lu.HeldFactor.pattern_of): the linear terms' matrices scaled by
    the step's factors, the stress term's tangent from the kernel at the residual's own points, NGSolve's
    linearisation only for the rigid-wall contact while head elements are in its set. The stress term is
    nearly all of NGSolve's assembly of the full form, 4.9-5.7 ms on the rubber scene's mesh."""

    def __init__(
        self,
        split: SplitResidual,
        free: np.ndarray,
        indptr: np.ndarray,
        indices: np.ndarray,
        with_contact: bool = True,
    ):
        """with_contact False: the contact term left out (the solver updates the held Jacobian for it,
        fem/contact_update.py)."""
        self._split, self._with_contact = split, with_contact
        n = len(indptr) - 1
        self._keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices  # column, then row
        self._local = np.full(split.linear.mass.shape[0], -1, dtype=np.int64)
        self._local[free] = np.arange(len(free))
        self._n = n
        lin = split.linear
        self._mass, self._hinge, self._torque = (self._on_pattern(m) for m in (lin.mass, lin.hinge, lin.torque_grad))
        self._slots = [
            (start, _int32(self._positions(pairs[:, 0], pairs[:, 1])))
            for start, pairs in split.elastic.local_unknowns()
        ]
        # the contact matrix's (row, column) keys, its entries on free unknowns and their positions
        self._contact_at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        split.allocate_contact_matrix()

    def _positions(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The positions in the pattern's entries of the (row, column) pairs of unknowns (all free)."""
        r, c = self._local[rows], self._local[cols]
        if np.any(r < 0) or np.any(c < 0):
            raise ValueError("a stress or linear term acts on a fixed unknown")
        keys = c * self._n + r
        at = np.minimum(np.searchsorted(self._keys, keys), len(self._keys) - 1)
        if not np.array_equal(self._keys[at], keys):
            raise ValueError("a term's entry is outside the form's pattern")
        return at

    def _on_pattern(self, mat: sp.csr_matrix) -> np.ndarray:
        coo = mat.tocoo()
        entries = np.zeros(len(self._keys))
        np.add.at(entries, self._positions(coo.row, coo.col), coo.data)
        return entries

    def __call__(self, w: ngs.BaseVector) -> np.ndarray:
        """The Jacobian's entries at w with the inputs as loaded."""
        inertia, half_torque = self._split.linear.coefficients
        out = inertia * self._mass + self._hinge
        if half_torque != 0.0:
            out += half_torque * self._torque
        self._split.elastic.add_tangent(np.ascontiguousarray(w.FV().NumPy()), self._slots, out)
        contact = self._split.contact_linearisation(w) if self._with_contact else None
        if contact is not None:
            rows, cols, vals = (np.array(a) for a in contact.COO())
            if self._contact_at is None or not np.array_equal(self._contact_at[0], rows * self._n + cols):
                kept = np.flatnonzero((self._local[rows] >= 0) & (self._local[cols] >= 0))
                self._contact_at = (rows * self._n + cols, kept, self._positions(rows[kept], cols[kept]))
            _, kept, at = self._contact_at
            np.add.at(out, at, vals[kept])
        return out


def _int32(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32)
