"""The FE model's nonlinear solve of one step: modified Newton with a held Jacobian.

The Jacobian is kept from step to step while the step size stays within
HELD_DT_CHANGE of the one it was assembled for and the iterations contract
fast, and re-assembled (numeric re-factorisation only) when they do not.

The held Jacobian is turned with the pendulum: the step forms are
frame-indifferent (elastic stress, follower torque; inertia, hinge and gravity
are isotropic or constant), so the Jacobian at a configuration turned rigidly
by d about the pivot is Q(d) J Q(d)^T, Q turning every nodal vector of the
pendulum (and the hinge multipliers) by d. Without the turn the swinging steel
pendulum's held Jacobian contracted too slowly after one step (its stiffness
is 65 times its inertia at 1 ms steps) and was re-assembled in 228 of 330
steps; with it, in 35 (docs/fem.md, "Profile and speed-up").

Where the Jacobian was assembled (`JacobianPoint`) is part of the model's
state, so that a restored model re-creates the very same matrix (and turns it
by the same angle) and continues bit-identically.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import ngsolve as ngs
import numpy as np
from ngsolve import GridFunction

from .fem_space import FemSpace, FemState

NEWTON_MAX_IT = 12
# A step size farther than this share from the held Jacobian's needs a new one (its inertia part goes as
# 1/dt^2); closer, the contraction test decides. In contact the steps change by a few per mille each: on the
# steel scene's impact this took 13 re-assemblies where an exact match took 40, for 2 % more residuals.
HELD_DT_CHANGE = 0.02


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


class Turn:
    """Turns the pendulum's nodal vectors (and the hinge multipliers) of a vector of X by an angle.

    VectorH1 numbers the x components of all basis functions first, then the y components."""

    def __init__(self, space: FemSpace, angle: Callable[[np.ndarray], float]):
        half = space.nV // 2
        dofs = space.V.GetDofs(space.mesh.Materials("pendulum"))
        ix = np.array([i for i in range(half) if dofs[i]], dtype=int)
        self.ix = np.concatenate([ix, [space.nV]])  # the multipliers (q1, q2) turn as a vector too
        self.iy = np.concatenate([ix + half, [space.nV + 1]])
        self.angle = angle  # best-fit rigid rotation of a displacement about the pivot

    def apply(self, vec: np.ndarray, d: float) -> None:
        """Turn vec in place by d (rad)."""
        c, s = math.cos(d), math.sin(d)
        vx, vy = vec[self.ix], vec[self.iy]
        vec[self.ix] = c * vx - s * vy
        vec[self.iy] = s * vx + c * vy


def too_slow(size: float, last: float, tol: float, left: int) -> bool:
    """Whether to refresh the Jacobian after a correction of `size` that followed one of `last`: when the
    iterations contract by less than 4x, or when at their rate they would not reach `tol` within the `left`
    iterations there are. The second: a Jacobian assembled at a poor first iterate (the start of a rubber
    contact step) contracts steadily by 5-10x and the step failed after NEWTON_MAX_IT, to be halved and
    retried (97 of 923 solves in the compliant scene's first 0.4 s); re-assembled, it converges in two."""
    if size > 0.25 * last:
        return True
    if not math.isfinite(last) or size <= 0.0:
        return False
    return math.log(tol / size) / math.log(size / last) > left


class HeldJacobianNewton:
    """Solves a step form for (u1, hinge multipliers), holding its Jacobian.

    `load` sets the form's inputs (and its contact set) to those of a step;
    `active_now` gives the contact set currently assembled."""

    def __init__(
        self, form: ngs.BilinearForm, space: FemSpace, load: Loader, active_now: Callable[[], np.ndarray], turn: Turn
    ):
        self.form = form  # the ngsolve BilinearForm of the step
        self.w = GridFunction(space.X)
        self._res = self.w.vec.CreateVector()
        self._turned = self.w.vec.CreateVector()
        self._corr = self.w.vec.CreateVector()
        # numpy views of the vectors, made once (a view per use cost as much as the turn itself)
        self._res_np, self._turned_np = self._res.FV().NumPy(), self._turned.FV().NumPy()
        self._corr_np = self._corr.FV().NumPy()
        self._turn = turn
        self._freedofs = space.X.FreeDofs()
        self._nV = space.nV
        self._load, self._active_now = load, active_now
        self._inverse: Any = None  # UMFPACK inverse of the held Jacobian (an ngsolve BaseMatrix)
        self._inverse_of: Any = None  # the matrix it was factorised from
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
        refresh = self.held is None or abs(self.held.dt - dt) > HELD_DT_CHANGE * dt
        # the pendulum's rotation since the start of the step the held Jacobian was assembled in
        turn = 0.0 if self.held is None else self._turn.angle(xs.u) - self._turn.angle(self.held.u0)
        last, tol = math.inf, 1e-10 * scale + 1e-15
        for it in range(NEWTON_MAX_IT):
            if refresh:
                self._refresh(xs, dt, torque)
                refresh = False
                turn = 0.0
            self.form.Apply(self.w.vec, res)
            cv = self._correction(turn)
            if not np.all(np.isfinite(cv)):
                return None
            wv -= cv
            size = float(np.max(np.abs(cv[:nV])))
            if size <= tol:
                return wv[:nV].copy()
            refresh = too_slow(size, last, tol, NEWTON_MAX_IT - it - 1)
            last = size
        return None

    def _correction(self, turn: float) -> np.ndarray:
        """The Newton correction Q J^-1 Q^T res of the held Jacobian J turned by `turn`, for the residual
        in self._res (a view of the solver's correction vector, valid until the next call)."""
        inverse = self._inverse
        if turn == 0.0:
            inverse.Mult(self._res, self._corr)
            return self._corr_np
        self._turned_np[:] = self._res_np
        self._turn.apply(self._turned_np, -turn)
        inverse.Mult(self._turned, self._corr)
        self._turn.apply(self._corr_np, turn)
        return self._corr_np

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
