"""One Newton iteration of the energy-momentum step in a single call of the core (femp_iterate, core/fem_elastic.c).

An iteration is one call of five arguments, not six calls of some 60: on
the rubber scene's mesh the kernels' arithmetic (stress, linear terms, the
held factors' solve) takes about 115 us of an iteration, and the Python
between six separate calls (views, numpy copies, converting the
arguments) would add about 35 us more. The struct here holds what those
calls would take, filled once (and its factors' part after each
factorisation). The
kernel makes the same operations in the same order as the separate calls
(the results are the same bit for bit, tests/test_fem_residual.py), then
the secant step: from a Jacobian's second iteration in a solve, the updated
iterate is combined with the last ones (Anderson acceleration of depth
ANDERSON_DEPTH; core/fem_elastic.c, secant_step). The held Jacobian's
iterations contract linearly; on the rubber scene, whose large deformation
the held Jacobian follows least, depth 1 takes 20 % fewer of them than no
acceleration and depth 2 another 8 %.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core import ffi, fields, fill, lib, pointer
from .lu import HeldFactor
from .residual import SplitResidual

ANDERSON_MOST = 4  # core/fem_elastic.c's bound on the depth, the stride of its gram matrix
# past differences the Anderson step combines: 2 takes 8 % fewer rubber iterations than 1, and 3 no fewer than 2
ANDERSON_DEPTH = 2


BODY_FIELDS, FACTOR_FIELDS = fields("struct femp_body"), fields("struct femp_factors")
CSR_FIELDS = fields("struct femp_csr")


class FusedIteration:
    """iterate(contact): one Newton iteration (prepare(turn) first) on the solver's vectors, as HeldJacobianNewton's
    residual and update would make it; returns the correction's largest displacement entry (-1 if not
    finite). The split residual's arrays and the vectors must stay where they are (they do: all are
    allocated once)."""

    def __init__(
        self,
        split: SplitResidual,
        turn_args: tuple,
        factor: HeldFactor,
        vectors: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    ):
        self._split, self._factor = split, factor
        it = self._it = ffi.new("struct femp_iteration *")
        res, turned, corr, w = vectors
        it.size, it.n_disp, it.nS = len(w), 2 * split.elastic.nS, split.elastic.nS
        bodies = split.elastic.kernel_args
        if len(bodies) > 2:
            raise ValueError("femp_iterate takes at most two bodies")
        it.n_bodies = len(bodies)
        for i, ((q, indptr, indices, data, _nS), middle) in enumerate(bodies):
            fill(it.bodies[i], BODY_FIELDS, (q, indptr, indices, data, *middle))
        matrices, (it.constant, it.wv, moved) = split.linear.kernel_arrays()
        for csr, args in zip((it.mass, it.hinge, it.torque), matrices, strict=True):
            fill(csr, CSR_FIELDS, args)
        it.nturn, it.ix, it.iy = turn_args
        it.res, it.moved, it.turned = pointer(res), moved, pointer(turned)
        it.corr, it.w = pointer(corr), pointer(w)
        it.contact = split.compiled_contact_address  # the rigid-wall term made in the call (NULL: none)
        # the secant step's memory of the last iteration (core/fem_elastic.c, secant_step)
        self._last = (np.zeros(it.n_disp), np.zeros(it.size))
        it.f_last, it.g_last = (pointer(a) for a in self._last)
        # the differences the Anderson step combines and their inner products (secant_step)
        depth = ANDERSON_DEPTH
        self._history = (np.zeros(depth * it.n_disp), np.zeros(depth * it.size), np.zeros(ANDERSON_MOST**2))
        it.df, it.dg, it.gram = (pointer(a) for a in self._history)
        it.depth = depth
        self._factor_args: tuple = ()
        self._turn = (0, 1.0, 0.0)  # femp_iterate's turn, cos, sin

    def prepare(self, turn: float) -> None:
        """What stays over a solve's iterations until its Jacobian changes: the factors, the loaded step's
        coefficients, the turn (rad) of the held Jacobian. Before a solve's first iteration and after
        each new Jacobian (about 3 us an iteration that were spent again at every call)."""
        it, factor = self._it, self._factor
        if factor.kernel_args is not self._factor_args:  # factors in new arrays (a new pattern, or SuperLU's)
            self._factor_args = factor.kernel_args
            fill(it.lu, FACTOR_FIELDS, (*factor.kernel_args, factor.work_at))
        it.inertia, it.half_torque = self._split.linear.coefficients
        it.has_last = 0  # a new solve or a new Jacobian: a new fixed-point map, whose first iterate is not combined
        self._turn = (turn != 0.0, math.cos(turn), math.sin(turn))

    def low_rank(self, struct: Any) -> None:
        """The held Jacobian's update for the contact (a struct of fem/contact_update.py; NULL: none)."""
        self._it.low_rank = struct

    def iterate(self, contact: int) -> float:
        """contact: 1 if the residual vector holds the contact term, 0 if none acts, 2 to make the compiled
        rigid-wall term in the call (SplitResidual.fused_contact). From a solve's second iteration with
        a Jacobian on, the updated iterate is combined with the last ones by the secant step."""
        return float(lib.femp_iterate(self._it, contact, *self._turn))
