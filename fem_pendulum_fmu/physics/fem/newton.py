"""The FE model's nonlinear solve of one step: modified Newton with a held Jacobian.

The Jacobian is kept from step to step while the iterations contract fast
enough, and re-assembled and factorised when they do not. A new step size
(farther than HELD_DT_CHANGE from the one it was factorised for) changes only
its inertia term: where the step form says what that is (`Inertia`), the held
matrix is refactorised with the term rescaled instead of re-assembled.

The held Jacobian is turned with the pendulum: the step forms are
frame-indifferent (elastic stress, follower torque; inertia, hinge and gravity
are isotropic or constant), so the Jacobian at a configuration turned rigidly
by d about the pivot is Q(d) J Q(d)^T, Q turning every nodal vector of the
pendulum (and the hinge multipliers) by d. Without the turn the swinging steel
pendulum's held Jacobian contracts too slowly after one step (its stiffness
is 65 times its inertia at 1 ms steps) and is re-assembled in 228 of 330
steps; with it, in 35.

On soft bodies with the compiled rigid-wall contact the held Jacobian leaves
the contact out, and each iteration adds the contact's own Jacobian at the
iterate by a low-rank update of the held factors (fem/contact_update.py): a
contact set that changes needs no new Jacobian.

The solver is given each step's inputs as a value (`StepLoad`, loaded into the
step form before the solve). Where the Jacobian was assembled (`JacobianPoint`,
fem/step_load.py) is part of the model's state, so that a restored model
re-creates the very same matrix (and turns it by the same angle) and continues
bit-identically: the solver loads that step again (its loader, fem/step_loader.py)
only to do so.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from ngsolve import GridFunction

from ..core import lib, pointer
from .contact_update import ContactUpdate
from .iteration import FusedIteration
from .lu import HeldFactor
from .residual import SplitResidual
from .space import FemSpace
from .step_load import JacobianPoint, StepLoad

# With the residual compiled (fem/residual.py) an iteration costs about 0.16 ms on the rubber scene's mesh,
# a re-assembly and factorisation about 8 ms: the held Jacobian is kept while the corrections shrink by at
# least 1 / SLOWEST_CONTRACTION and would converge within NEWTON_MAX_IT iterations. Rubber, 2 s (four
# impacts): 2x and 20 iterations take 349 re-assemblies (28369 iterations) from FemModel._drift_guess, 1.4x and
# 30 take 190 (33687 iterations) and 6 % less time. With the Jacobian and its factors compiled
# (split_jacobian.SplitJacobian, lu.Symbolic) a new one costs about 1.5 ms, nine iterations; refreshing it also
# where the rate predicts more than 12 or 15 iterations saves 13 % of them for twice the Jacobians, no faster.
NEWTON_MAX_IT = 30
SLOWEST_CONTRACTION = 0.7
# A solve re-assembles its Jacobian at most this many times; one that would need more fails, and the step
# control halves the step. In the rubber's held contacts (1 ms steps, head points entering and leaving the
# wall within a step) refreshed Jacobians did not contract better: single doSteps re-assembled 86-110 times
# in 6 steps (108-130 ms). Rubber, 2 s: 272 Jacobians instead of 616, the slowest doStep 37 instead of 92
# times the median; theta up to the second impact the same.
MAX_REFRESHES = 3
# Converged when the error left (converged()) is under this share of the step's displacement (largest
# |dt v|), plus 1e-15 m. 1e-9 took 7 % fewer iterations on the steel swing, but with the mean-velocity start
# guess (FemModel._drift_guess) the energy balance across an impact in 0.1 s doSteps moved to 3.5e-7 of the
# energy moved (tests/test_hard_cases.py bounds it at 1e-7); with 1e-10 it stays under it.
NEWTON_RTOL = 1e-10
# The least contraction converged() credits a correction with. Taking the last correction itself as the error
# left costs one more iteration wherever the held Jacobian contracts by 1e-3 (free flight at 1 ms steps). Lower
# floors take fewer iterations (0.1 against none: 23 % fewer on the 0.005 m mesh, 15 % on the steel swing, 7 %
# on rubber; 0.01 against 0.03: 3.6 % and 4.2 % fewer) for a larger energy error (steel: 1.8e-9 of the swing at
# 0.1, 1.3e-8 at 0.01, 1.3e-7 at 0, where the secant step's uneven contraction makes one ratio an
# underestimate); 0.01 keeps it within the steel scene's 1e-4 bound with room.
RATE_FLOOR = 0.01
# A step size farther than this share from the held Jacobian's needs a new one (its inertia part goes as
# 1/dt^2); closer, the contraction test decides. In contact the steps change by a few per mille each: on the
# steel scene's impact this took 13 re-assemblies where an exact match took 40, for 2 % more residuals.
HELD_DT_CHANGE = 0.02


@dataclass
class NewtonCounts:
    """What the solver did, for benchmarks/fem_cpu.py (load-independent measures of its cost)."""

    iterations: int = 0  # residuals and corrections
    jacobians: int = 0  # Jacobians assembled and factorised
    rescaled: int = 0  # refactorisations with the inertia term rescaled to a new step size


# The step form's inertia term, (mass matrix over X, its coefficient as a function of dt), where the
# Jacobian of a new step size is the held one with the inertia term rescaled; None: re-assembled
Inertia = tuple[sp.csr_matrix, Callable[[float], float]]
# tangent(free unknowns, pattern's CSC indptr, indices) -> jacobian(w): the step form's Jacobian at w as the
# entries on that pattern (split_jacobian.SplitJacobian); None: NGSolve assembles the form's linearisation
Tangent = Callable[[np.ndarray, np.ndarray, np.ndarray], Callable[[ngs.BaseVector], np.ndarray]]
# residual(w, res): the step form's residual at w into res (ngsolve vectors)
Residual = Callable[[ngs.BaseVector, ngs.BaseVector], None]
# load(step): set the step form's inputs to a step's (fem/step_loader.py)
Loader = Callable[[StepLoad], None]


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
        self.ix, self.iy = self.ix.astype(np.int32), self.iy.astype(np.int32)
        # femp_turned_solve's leading arguments
        self.kernel_args = (len(self.ix), pointer(self.ix), pointer(self.iy))


def converged(size: float, last: float, tol: float) -> bool:
    """Whether a correction of `size` after one of `last` leaves an error under `tol`. At the contraction
    r = size / last the error left after a linear contraction is r / (1 - r) times the correction (more
    than the correction itself once r > 1/2: a held Jacobian may contract that slowly, SLOWEST_CONTRACTION);
    r is taken no smaller than RATE_FLOOR, as one ratio of two corrections is only an estimate of it. A
    solve's first correction has no rate: it must be under `tol` itself."""
    if not last < math.inf:
        return size <= tol
    rate = size / last if last > 0.0 else 0.0
    return size * max(rate, RATE_FLOOR) <= tol * max(1.0 - rate, 0.0)


def too_slow(size: float, last: float, tol: float, left: int, rate_only: bool = False) -> bool:
    """Whether to refresh the Jacobian after a correction of `size` that followed one of `last`: when the
    iterations contract by less than 1 / SLOWEST_CONTRACTION, or (unless rate_only) when at their rate they
    would not reach `tol` within the `left` iterations there are. The second: a Jacobian assembled at a poor
    first iterate (the start of a rubber contact step) contracts steadily by 5-10x and the step failed
    after NEWTON_MAX_IT, to be halved and retried (97 of 923 solves in the compliant scene's first 0.4 s);
    re-assembled, it converges in two. rate_only: the held factors are updated for the contact at each
    iterate (fem/contact_update.py), so that a slow start comes from head points crossing the wall's face
    between iterates, which no new Jacobian changes: on rubber, 2 s, 99 Jacobians instead of 182 for 0.6 %
    more iterations, and no step halved."""
    if size > SLOWEST_CONTRACTION * last:
        return True
    if rate_only or not math.isfinite(last) or size <= 0.0:
        return False
    return math.log(tol / size) / math.log(size / last) > left


class HeldJacobianNewton:
    """Solves a step form for (u1, hinge multipliers), holding its Jacobian.

    `load` sets the form's inputs (and its contact set) to those of a step: used only to rebuild a
    restored Jacobian at the step it was assembled at."""

    def __init__(
        self,
        form: ngs.BilinearForm,
        residual: Residual,
        space: FemSpace,
        load: Loader,
        turn: Turn,
        inertia: Inertia | None = None,
        tangent: Tangent | None = None,
        linearise: Callable[[ngs.BaseVector], None] | None = None,
        contact_update: bool = False,
    ):
        self.form = form  # the ngsolve BilinearForm of the step: its linearisation is the Jacobian
        # linearise(w): form.mat = the form's linearisation at w (StepForm.linearise)
        self._linearise = form.AssembleLinearization if linearise is None else linearise
        self._apply = residual
        self.w = GridFunction(space.X)
        self._res = self.w.vec.CreateVector()
        self._turned = self.w.vec.CreateVector()
        self._corr = self.w.vec.CreateVector()
        # numpy views of the vectors, made once (a view per use cost as much as the turn itself)
        self._res_np, self._turned_np = self._res.FV().NumPy(), self._turned.FV().NumPy()
        self._corr_np = self._corr.FV().NumPy()
        self._corr_np[:] = 0.0  # the fixed unknowns' corrections stay 0
        self._turn = turn
        self._nV = space.nV
        self._w_np = self.w.vec.FV().NumPy()  # the GridFunction's vector stays put
        self._at = tuple(pointer(a) for a in (self._res_np, self._turned_np, self._corr_np, self._w_np))
        self._load = load
        free, multipliers = np.array(space.X.FreeDofs(), dtype=bool), np.arange(space.X.ndof) >= space.nV
        self._factor = HeldFactor(free, None if inertia is None else inertia[0], multipliers)
        self._inertia_coeff = None if inertia is None else inertia[1]
        self._jacobian = None if tangent is None else self._compiled_jacobian(tangent)
        self._split, self._fused = None, None  # one kernel call an iteration where the residual is the split one
        if isinstance(residual, SplitResidual):
            vectors = (self._res_np, self._turned_np, self._corr_np, self._w_np)
            self._split = residual
            self._fused = FusedIteration(residual, turn.kernel_args, self._factor, vectors)
        # contact_update: the held Jacobian, assembled without the rigid wall's contact (the tangent's
        # with_contact False), is updated for it in each iteration (fem/contact_update.py)
        self._contact_update: ContactUpdate | None = None
        contact = None if self._split is None else self._split.compiled_contact
        if contact_update and self._fused is not None and self._jacobian is not None and contact is not None:
            self._contact_update = ContactUpdate(contact, self._factor, len(self._w_np), self._fused)
        self.counts = NewtonCounts()
        self.held: JacobianPoint | None = None
        self.ready = False  # the held Jacobian is assembled and factorised (False after a restore)
        self._held_at: JacobianPoint | None = None  # the held point whose angle _held_turn is
        self._held_turn = 0.0

    @property
    def by_superlu(self) -> int:
        """Factorisations left to SuperLU (a pivot the kernel refused, or no kernel)."""
        return self._factor.by_superlu

    def multipliers(self) -> np.ndarray:
        """The hinge multipliers of the last solve."""
        return self._w_np[self._nV :].copy()

    def residual(self, u: np.ndarray, multipliers: float | np.ndarray) -> ngs.BaseVector:
        """The step form's residual at (u, hinge multipliers) with the inputs as loaded (a vector of the solver's)."""
        wv = self.w.vec.FV().NumPy()
        wv[: self._nV], wv[self._nV :] = u, multipliers
        self._apply(self.w.vec, self._res)
        return self._res

    def solve(self, step: StepLoad, guess: np.ndarray, multipliers: np.ndarray) -> np.ndarray | None:
        """u1 of the step (loaded) from the start iterate (guess of u1, hinge multipliers); None when
        Newton does not converge."""
        nV, dt = self._nV, step.dt
        wv = self._w_np
        wv[:nV] = guess
        wv[nV:] = multipliers
        res = self._res
        # dt max|v0|: the same bits as max|dt v0| (rounding is monotone), without two arrays of nV
        scale = max(dt * float(np.max(np.abs(step.v0))), 1e-12)
        if self.held is not None and not self.ready:
            self._rebuild_held(self.held, step)
        refresh = self.held is None
        if self.held is not None and abs(self.held.serves - dt) > HELD_DT_CHANGE * dt:
            refresh = not self._rescale(dt)
        # the pendulum's rotation since the step the held Jacobian was assembled in (_mid_angle)
        turn = 0.0 if self.held is None else self._mid_angle(step.u0, guess) - self._held_angle(self.held)
        last, tol, refreshes = math.inf, NEWTON_RTOL * scale + 1e-15, 0
        fused, split = self._fused, self._split
        self._prepare(turn)
        update = self._contact_update
        for it in range(NEWTON_MAX_IT):
            if refresh:
                if refreshes == MAX_REFRESHES:
                    return None  # new Jacobians do not help this step: a shorter one (MAX_REFRESHES)
                refreshes += 1
                self._refresh(step)
                refresh = False
                turn = 0.0
                self._prepare(turn)
            if fused is not None and split is not None:
                size = fused.iterate(split.fused_contact(self.w.vec, res))
            else:
                self._apply(self.w.vec, res)
                size = self._update(turn)
            self.counts.iterations += 1
            if size < 0.0:
                return None  # not finite
            if converged(size, last, tol):
                return wv[:nV].copy()
            refresh = too_slow(size, last, tol, NEWTON_MAX_IT - it - 1, update is not None and update.in_use)
            last = size
        return None

    def _prepare(self, turn: float) -> None:
        """The fused iteration's inputs for iterations from here with the held Jacobian turned by `turn`."""
        if self._fused is not None:
            self._fused.prepare(turn)
        if self._contact_update is not None:
            self._contact_update.prepare()

    def _mid_angle(self, u0: np.ndarray, u1: np.ndarray) -> float:
        """The pendulum's angle halfway through a step from u0 to (about) u1. The step form's Jacobian
        depends on both ends: turned by the rotation of the start alone, the held one is off by the turn
        the pendulum makes within a step (omega dt, up to 1e-3 rad at 1 ms steps), and its iterations
        contract by 1e-2 instead of 1e-3 on the steel swing."""
        return 0.5 * (self._turn.angle(u0) + self._turn.angle(u1))

    def _held_angle(self, held: JacobianPoint) -> float:
        """The pendulum's angle halfway through the held Jacobian's step (from its start to the iterate it
        was assembled at), computed once per held point."""
        if self._held_at is not held:
            self._held_at, self._held_turn = held, self._mid_angle(held.load.u0, held.w[: self._nV])
        return self._held_turn

    def _update(self, turn: float) -> float:
        """w -= the Newton correction for the residual in self._res; its largest displacement entry
        (-1 if it is not finite)."""
        res_at, turned_at, corr_at, w_at = self._at
        factor, n = self._factor, len(self._w_np)
        if turn == 0.0:
            lib.femp_lu_solve(*factor.kernel_args, res_at, factor.work_at, corr_at)
        else:
            lu = (*factor.kernel_args, res_at, turned_at, factor.work_at, corr_at, n)
            lib.femp_turned_solve(*self._turn.kernel_args, math.cos(turn), math.sin(turn), *lu)
        return float(lib.femp_update(n, self._nV, corr_at, w_at))

    def _compiled_jacobian(self, tangent: Tangent) -> Callable[[ngs.BaseVector], np.ndarray]:
        """The Jacobian on the full form's pattern, learnt from one assembly here (its entries unused): every
        Jacobian then comes from `tangent`, so that a restored model rebuilds the same one."""
        self._linearise(self.w.vec)
        pattern = self._factor.pattern_of(self.form.mat)
        return tangent(self._factor.free, pattern.indptr, pattern.indices)

    def _factorise(self) -> None:
        """Assemble the Jacobian at the current inputs and w, and factorise it."""
        self.counts.jacobians += 1
        if self._jacobian is not None:
            self._factor.factorise_entries(self._jacobian(self.w.vec))
            return
        self._linearise(self.w.vec)
        self._factor.factorise(self.form.mat)

    def _rescale(self, dt: float) -> bool:
        """Factorise the held Jacobian with its inertia term for the step size dt instead of re-assembling
        it (its stiffness part does not depend on dt); False where the form has no such term."""
        if self._inertia_coeff is None or self.held is None:
            return False
        if not self._factor.factorise_shifted(self._inertia_coeff(dt) - self._inertia_coeff(self.held.load.dt)):
            return False
        self.counts.rescaled += 1
        # a new point, not a changed one: a failed advance puts back the one from before (FemModel.advance)
        self.held = replace(self.held, dt_factorised=dt)
        return True

    def _refresh(self, step: StepLoad) -> None:
        """Assemble and factorise the Jacobian at the loaded step and the current iterate, and hold it there
        (a0 left out: the Jacobian does not depend on it, and a state does not carry it)."""
        at = replace(step, u0=step.u0.copy(), v0=step.v0.copy(), a0=None)
        self.held = JacobianPoint(at, self.w.vec.FV().NumPy().copy())
        self._factorise()
        self.ready = True

    def _rebuild_held(self, jp: JacobianPoint, step: StepLoad) -> None:
        """Re-create the held Jacobian (after a restore) at its recorded step, then load `step` again."""
        w_now = self.w.vec.FV().NumPy().copy()
        self._load(jp.load)
        self.w.vec.FV().NumPy()[:] = jp.w
        self._factorise()
        if jp.dt_factorised:
            self._rescale(jp.dt_factorised)
        self.ready = True
        self._load(step)
        self.w.vec.FV().NumPy()[:] = w_now
