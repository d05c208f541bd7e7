"""The held Newton Jacobian's LU factors and their solve.

The solve runs in the compiled core (femp_lu_solve), where one costs about a
tenth of an ngsolve UMFPACK inverse's Mult on the 302 unknowns of the steel
scene's mesh, where that Mult, not the arithmetic, would be the larger half of a
Newton iteration.

A matrix is factorised without pivoting on a fill-reducing
order and structure computed once per sparsity pattern (`Symbolic`), in one
compiled call: a rubber run refactorises about 1300 times in 2 s, and
SuperLU takes 1.5 ms a time plus 0.8 ms of Python around it (equilibration,
copying its factors out), the core 0.3 ms. Where a pivot nearly vanishes (PIVOT_MIN) the matrix goes
to SuperLU instead; either way the factors are a function of the matrix
alone, so a restored model refactorises bit-identically. The kernel's own
factors are solved by supernodes (`supernodes`): runs of columns that share
the rows below them, read once for the whole run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from ..core import ffi, lib, pointer
from ..sparse import scipy_matrix

# The kernel's factors (`Symbolic`) refuse a pivot under this share of the largest entry below it, a guard
# against breakdown only: the matrices are nearly symmetric positive definite but for the multipliers, ordered
# last, and where the rubber's later impacts gave pivots of 1e-4 to 0.1 of their column the kernel's solves
# were as accurate as SuperLU's (75 such matrices: residuals up to 6.5e-11 of b against SuperLU's 1.1e-10)
PIVOT_MIN = 1e-6


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


def _fill_columns(lower: sp.csc_matrix) -> list[np.ndarray]:
    """The rows below the diagonal of each column of L for a matrix of symmetric pattern factorised without
    pivoting (its strictly lower part given): a column's own rows and those of its children in the
    elimination tree, less itself."""
    n = lower.shape[0]
    children: list[list[int]] = [[] for _ in range(n)]
    columns: list[np.ndarray] = []
    for j in range(n):
        rows = set(lower.indices[lower.indptr[j] : lower.indptr[j + 1]].tolist())
        for c in children[j]:
            rows.update(columns[c].tolist())
        rows.discard(j)
        column = np.array(sorted(rows), dtype=np.int32)
        columns.append(column)
        if len(column):
            children[int(column[0])].append(j)
    return columns


SUPERNODE_MOST = 64  # the widest supernode, as core/fem_elastic.c's femp_lu_solve takes them


def supernodes(Lp: np.ndarray, Li: np.ndarray) -> np.ndarray:
    """The runs of columns [s, e) of L (CSC, strict, rows sorted) in which column j holds row j + 1 and then
    the rows of column j + 1, so that each holds rows j + 1 .. e - 1 and then column e - 1's (femp_lu_solve
    reads the rows below a run once for all its columns), as long as they go, cut every SUPERNODE_MOST
    columns: their count, then their first columns and n. A node's x and y unknowns make runs of two at least
    (the 0.005 m mesh: 1319 runs of 3.7 columns on average)."""
    starts = _run_starts(Lp, Li)
    return _int32(np.array([len(starts) - 1, *starts]))


def _run_starts(Lp: np.ndarray, Li: np.ndarray) -> list[int]:
    """supernodes' first columns, then n."""
    n = len(Lp) - 1
    if n == 0:
        return [0, 0]
    lengths = np.diff(Lp).astype(np.int64)
    j = np.arange(n - 1)
    joins = (lengths[:-1] == lengths[1:] + 1) & (lengths[:-1] > 0)  # column j + 1 may continue column j's run
    joins[joins] = Li[Lp[:-2][joins]] == j[joins] + 1
    column = np.repeat(np.arange(n), lengths)  # each entry's column
    entry = np.flatnonzero(column >= 1)
    entry = entry[joins[column[entry] - 1]]  # the entries of the columns that may continue the last one
    c = column[entry]
    differs = Li[entry] != Li[entry - Lp[c] + Lp[c - 1] + 1]  # against the last column's rows after its first
    joins[np.unique(c[differs] - 1)] = False
    first = np.concatenate(([0], j[~joins] + 1))  # the runs as long as they go, then cut every SUPERNODE_MOST
    pieces = -(-(np.append(first[1:], n) - first) // SUPERNODE_MOST)
    piece = np.arange(pieces.sum()) - np.repeat(np.cumsum(pieces) - pieces, pieces)  # the piece's number in its run
    return [*(np.repeat(first, pieces) + SUPERNODE_MOST * piece).tolist(), n]


@dataclass
class Symbolic:
    """A pattern's fill-reducing order and the structure of its factors without pivoting, with the arrays
    the core writes the factors into (femp_lu_factor)."""

    Ap: np.ndarray  # the pattern's CSC arrays as int32
    Ai: np.ndarray
    pos: np.ndarray  # the factored position of each free unknown
    order: np.ndarray  # the free unknown at each position
    Lp: np.ndarray  # L's strict lower part, CSC
    Li: np.ndarray
    Up: np.ndarray  # U's strict upper part, CSC, rows increasing
    Ui: np.ndarray
    Lx: np.ndarray
    Ux: np.ndarray
    u_diag: np.ndarray
    scale: np.ndarray
    work: np.ndarray  # the kernel's dense column, all zero between calls
    sn: np.ndarray  # the supernodes: their count, then their first columns and n (supernodes())
    u_rows: np.ndarray  # where each entry of U (CSC) goes in Ur
    Ur: np.ndarray  # U's strict part by rows, row i at Lp[i] in the columns Li[Lp[i]:Lp[i + 1]]
    # the pointers femp_lu_factor and femp_lu_solve take, made once per pattern: the arrays stay where they are
    factor_at: tuple[tuple[Any, ...], tuple[Any, ...], Any] = field(init=False)
    solve_at: tuple[Any, ...] = field(init=False)
    solve_args: tuple = field(init=False, default=())
    solve_free: np.ndarray | None = field(init=False, default=None)  # the free unknowns solve_args hold

    def __post_init__(self) -> None:
        pattern = (self.Ap, self.Ai)
        factors: tuple[np.ndarray, ...] = (self.pos, self.order, self.Lp, self.Li, self.Lx, self.Up, self.Ui, self.Ux)
        factors += (self.u_diag, self.scale, self.u_rows, self.Ur)
        at = (tuple(pointer(a) for a in pattern), tuple(pointer(a) for a in factors), pointer(self.work))
        self.factor_at = at
        solved: tuple[np.ndarray, ...] = (self.scale, self.pos, self.pos, self.Lp, self.Li, self.Lx, self.Up, self.Ui)
        solved += (self.Ux, self.u_diag, self.sn, self.Ur)
        self.solve_at = tuple(pointer(a) for a in solved)

    @staticmethod
    def of(pattern: Pattern, last: np.ndarray) -> Symbolic:
        """The minimum-degree order of A + A^T (SuperLU's, on the pattern with a dominant diagonal) over the
        unknowns not in `last`, then those in `last` (the hinge multipliers: their zero diagonal gets its
        pivot only once the displacements they tie are eliminated)."""
        n = len(pattern.indptr) - 1
        ones = sp.csc_matrix((np.ones(len(pattern.indices)), pattern.indices, pattern.indptr), (n, n))
        both = (ones + ones.T).tocsc()
        lead = np.flatnonzero(~last)
        block = (both[lead][:, lead] + len(lead) * sp.identity(len(lead))).tocsc()
        perm_c = _splu(block).perm_c
        order = np.concatenate([lead[np.argsort(perm_c)], np.flatnonzero(last)]).astype(np.int32)
        pos = np.empty(n, dtype=np.int32)
        pos[order] = np.arange(n, dtype=np.int32)
        lower = sp.tril(both[order][:, order], k=-1).tocsc()
        columns = _fill_columns(lower)
        Lp = np.concatenate([[0], np.cumsum([len(c) for c in columns])]).astype(np.int32)
        Li = np.concatenate(columns).astype(np.int32)
        L = sp.csc_matrix((np.arange(1.0, len(Li) + 1.0), Li, Lp), (n, n))  # each entry's position, plus one
        U = L.T.tocsc()
        U.sort_indices()
        Up, Ui, u_rows = _int32(U.indptr), _int32(U.indices), _int32(U.data - 1.0)  # U[i, j] is L[j, i]'s place
        Ap, Ai, zeros = _int32(pattern.indptr), _int32(pattern.indices), np.zeros
        values = (zeros(len(Li)), zeros(len(Ui)), zeros(n), zeros(n), zeros(n))
        return Symbolic(Ap, Ai, pos, order, Lp, Li, Up, Ui, *values, supernodes(Lp, Li), u_rows, zeros(len(Li)))

    def factorise(self, entries: np.ndarray) -> bool:
        """Factorise the matrix with these entries on its pattern into the arrays here; False where a pivot
        is refused (the arrays are then not factors)."""
        (pattern, factors, work), n = self.factor_at, len(self.pos)
        return lib.femp_lu_factor(n, *pattern, pointer(entries), *factors, PIVOT_MIN, work) == 0.0

    def kernel_args(self, free: np.ndarray) -> tuple:
        """femp_lu_solve's LU arguments for these factors (positions as both row and column permutation): the
        same tuple at every call for the same `free`, so that the fused iteration keeps the struct it made of it."""
        if self.solve_free is not free:
            self.solve_args, self.solve_free = (len(free), pointer(free), *self.solve_at), free
        return self.solve_args


class HeldFactor:
    """LU factors of a matrix's free block; solve(b, x) sets x = A^-1 b on the free unknowns."""

    def __init__(self, free: np.ndarray, mass: sp.csr_matrix | None = None, last: np.ndarray | None = None):
        """free, last: masks over all unknowns; last (the hinge multipliers) are ordered last, and without
        it every factorisation is SuperLU's."""
        self.free = _int32(np.flatnonzero(free))
        self._last = None if last is None else np.asarray(last, dtype=bool)[self.free]
        self._symbolic: Symbolic | None = None  # of the last pattern, for the kernel's factorisation
        self.by_superlu = 0  # factorisations SuperLU made
        # the inertia term's matrix on the free block, for factorise_shifted
        self._mass = None if mass is None else mass[self.free][:, self.free].tocsc()
        self._pattern: Pattern | None = None  # of the last assembled matrix
        self._assembled = np.zeros(0)  # its entries
        self._mass_entries: np.ndarray | None = None  # the inertia term's entries on that pattern
        self._lu: spl.SuperLU | None = None
        self.kernel_args: tuple = ()  # the core's LU arguments (pointers to the factors' arrays)
        self._work = np.zeros(len(self.free))
        self.work_at = pointer(self._work)
        self._scale = np.ones(len(self.free))  # S of the factorised S A S
        self.version = 0  # counts the factorisations: what was solved with the factors is stale once it moves

    def factorise(self, mat: ngs.BaseMatrix) -> None:
        """Factorise the free block of an assembled ngsolve matrix."""
        self.factorise_entries(self._adopt(mat))

    def pattern_of(self, mat: ngs.BaseMatrix) -> Pattern:
        """The pattern of an assembled ngsolve matrix's free block, adopted for factorise_entries."""
        self._adopt(mat)
        assert self._pattern is not None
        return self._pattern

    def factorise_entries(self, entries: np.ndarray) -> None:
        """Factorise the matrix with these entries on the adopted pattern (float64, contiguous)."""
        self._assembled = entries
        self._use(entries)

    def _adopt(self, mat: ngs.BaseMatrix) -> np.ndarray:
        """The free block's entries of an assembled matrix; its pattern, if new, adopted with what depends on it."""
        assembled = scipy_matrix(mat)[self.free][:, self.free].tocsc()
        assembled.sort_indices()
        if self._pattern is None or not self._same_pattern(assembled):
            self._pattern = pattern = Pattern.of(assembled)
            self._mass_entries = None if self._mass is None else self._on_pattern(self._mass, pattern)
            if self._last is not None:
                self._symbolic = Symbolic.of(pattern, self._last)
        return assembled.data

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
        self.version += 1
        symbolic = self._symbolic
        if symbolic is not None and symbolic.factorise(entries):
            self._lu = None
            self.kernel_args = symbolic.kernel_args(self.free)
            return
        self.by_superlu += 1
        scaled, self._scale = self._pattern.equilibrated(entries)
        lu = _splu(scaled)
        self._lu = lu
        # the kernel's solve reads strict factors (its own are): SuperLU's unit diagonal of L and U's diagonal dropped
        L, U = sp.tril(lu.L, -1).tocsc(), sp.triu(lu.U, 1).tocsc()
        # the arrays the kernel reads, kept alive with the pointers handed to it
        self._keep: tuple[np.ndarray, ...] = (_int32(lu.perm_r), _int32(lu.perm_c), _int32(L.indptr))
        self._keep += (_int32(L.indices), L.data.copy(), _int32(U.indptr), _int32(U.indices), U.data.copy())
        self._keep += (lu.U.diagonal().copy(), self._scale)
        at = [pointer(a) for a in self._keep]
        # no supernodes (NULL): SuperLU's factors are solved column by column
        self.kernel_args = (len(self.free), pointer(self.free), at[-1], *at[:-1], ffi.NULL, ffi.NULL)

    def solve(self, b: np.ndarray, x: np.ndarray) -> None:
        """x[free] = (A^-1 b)[free] (b and x contiguous, over all unknowns; x elsewhere untouched)."""
        lib.femp_lu_solve(*self.kernel_args, pointer(b), self.work_at, pointer(x))
