"""The FE model's nonlinear solve of one step: modified Newton with a held Jacobian.

The Jacobian is kept from step to step while the step size stays the same and
the iterations contract fast, and re-assembled (numeric re-factorisation only)
when they do not. Where it was assembled (`JacobianPoint`) is part of the
model's state, so that a restored model re-creates the very same matrix and
continues bit-identically.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from ngsolve import GridFunction

from .fem_space import FemSpace, FemState

NEWTON_MAX_IT = 12


@dataclass
class JacobianPoint:
    """The inputs the held Newton Jacobian was assembled at."""

    u0: np.ndarray
    v0: np.ndarray
    w: np.ndarray
    dt: float
    torque: float
    active: np.ndarray  # head elements with contact assembled (local indices)


# load(u0, v0, dt, torque, active head elements or None): set the step form's inputs
Loader = Callable[[np.ndarray, np.ndarray, float, float, "np.ndarray | None"], None]


class HeldJacobianNewton:
    """Solves a step form for (u1, hinge multipliers), holding its Jacobian.

    `load` sets the form's inputs (and its contact set) to those of a step;
    `active_now` gives the contact set currently assembled."""

    def __init__(self, form: ngs.BilinearForm, space: FemSpace, load: Loader, active_now: Callable[[], np.ndarray]):
        self.form = form  # the ngsolve BilinearForm of the step
        self.w = GridFunction(space.X)
        self._res = self.w.vec.CreateVector()
        self._freedofs = space.X.FreeDofs()
        self._nV = space.nV
        self._load, self._active_now = load, active_now
        self._inverse = self._inverse_of = None
        self._inverse_nze = -1
        self.held: JacobianPoint | None = None
        self.ready = False  # the held Jacobian is assembled and factorised (False after a restore)

    def multipliers(self) -> np.ndarray:
        """The hinge multipliers of the last solve."""
        return self.w.vec.FV().NumPy()[self._nV :].copy()

    def residual(self, u: np.ndarray, lam: float | np.ndarray) -> ngs.BaseVector:
        """The step form's residual at (u, lam) with the inputs as loaded (a vector of the solver's)."""
        wv = self.w.vec.FV().NumPy()
        wv[: self._nV], wv[self._nV :] = u, lam
        self.form.Apply(self.w.vec, self._res)
        return self._res

    def solve(self, xs: FemState, dt: float, torque: float) -> np.ndarray | None:
        """u1 of the step from xs (inputs loaded); None when Newton does not converge."""
        nV = self._nV
        wv = self.w.vec.FV().NumPy()
        wv[:nV] = xs.u + dt * xs.v
        wv[nV:] = xs.lam
        res = self._res
        scale = max(float(np.max(np.abs(dt * xs.v))), 1e-12)
        if self.held is not None and not self.ready:
            self._rebuild_held(self.held, xs, dt, torque)
        # a different step size needs a new Jacobian; round-off in dt (masters compute t + h differently) does not
        refresh = self.held is None or abs(self.held.dt - dt) > 1e-9 * dt
        last = math.inf
        for _ in range(NEWTON_MAX_IT):
            if refresh:
                self._refresh(xs, dt, torque)
                refresh = False
            self.form.Apply(self.w.vec, res)
            corr = (self._inverse * res).Evaluate()
            cv = corr.FV().NumPy()
            if not np.all(np.isfinite(cv)):
                return None
            self.w.vec.data -= corr
            size = float(np.max(np.abs(cv[:nV])))
            if size <= 1e-10 * scale + 1e-15:
                return wv[:nV].copy()
            if size > 0.25 * last:  # slow contraction: refresh the Jacobian
                refresh = True
            last = size
        return None

    def _factorise(self) -> None:
        """Assemble the Jacobian at the current inputs and w, and factorise it."""
        self.form.AssembleLinearization(self.w.vec)
        mat = self.form.mat
        if self._inverse is None or mat is not self._inverse_of or mat.nze != self._inverse_nze:
            # new matrix or new graph (contact pairs of the deformable wall): full factorisation
            self._inverse = mat.Inverse(self._freedofs, inverse="umfpack")
            self._inverse_of, self._inverse_nze = mat, mat.nze
        else:
            self._inverse.Update()  # same graph: numeric re-factorisation only

    def _refresh(self, xs: FemState, dt: float, torque: float) -> None:
        self.held = JacobianPoint(
            xs.u.copy(), xs.v.copy(), self.w.vec.FV().NumPy().copy(), dt, torque, self._active_now()
        )
        self._factorise()
        self.ready = True

    def _rebuild_held(self, jp: JacobianPoint, xs: FemState, dt: float, torque: float) -> None:
        """Re-create the held Jacobian (after a restore) at its recorded inputs, then restore the step's."""
        w_now = self.w.vec.FV().NumPy().copy()
        active_now = self._active_now()
        self._load(jp.u0, jp.v0, jp.dt, jp.torque, jp.active)
        self.w.vec.FV().NumPy()[:] = jp.w
        self._factorise()
        self.ready = True
        self._load(xs.u, xs.v, dt, torque, active_now)
        self.w.vec.FV().NumPy()[:] = w_now
