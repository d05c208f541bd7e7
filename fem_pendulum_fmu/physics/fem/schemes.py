"""The FE model's two time integration schemes: each a builder of its step form, plus its few rules.

* `EnergyMomentum` (solver.scheme = energy_momentum, the model's own): the
  inertia is the midpoint rule, the elastic stress is the discrete gradient of
  the strain energy in C (material.averaged_pk2_stress pushed forward with F at
  the midpoint), contact is the discrete-gradient penalty force of contact_law.py
  and the follower torque acts at the midpoint configuration. Over every step
  the change of kinetic + gravity + strain + contact energy equals the work of
  the torque up to the Newton tolerance, so impacts neither gain nor lose energy.
* `SeedNewmark` (newmark_fixed, newmark_gap_rule): the seed tutorial's
  trapezoidal Newmark rule (beta 1/4, gamma 1/2; stress, contact and torque at
  the step's end) with the seed's step-size rules (fem/seed_stepping.py), on the
  same mesh, material and contact law: kept only so that the benchmarks can
  compare the seed's schemes with ours on equal terms.

A step form is the residual of one step in the unknowns (u1, hinge
multipliers); its linearisation is the Newton Jacobian (fem/newton.py). It
reads the step's start state, size and torque from `StepInputs` (fem/space.py).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import ngsolve as ngs
import numpy as np
from ngsolve import (
    BND,
    CF,
    BilinearForm,
    CoefficientFunction,
    Cof,
    Grad,
    GridFunction,
    Id,
    InnerProduct,
    specialcf,
)

from .. import compiled_advance, material
from ..scene import Material, Scene
from . import contact_law, seed_stepping
from .head import PairGuard
from .residual import ElasticTerms, LinearTerms, SplitResidual
from .space import FemSpace, FemState, StepInputs
from .wall import (
    NO_PAIRS,
    WALL_CONTACT_INTORDER,
    WALL_SEARCH_DISTANCE,
    WallResidual,
    contact_boundary,
    discrete_gradient_contact,
)


@dataclass
class StepForm:
    """The residual form of one step and its contact parts."""

    form: BilinearForm
    active: ngs.BitArray | None  # head elements with rigid-wall contact assembled (None: no such contact)
    wall_contact: ngs.ContactBoundary | None  # ContactBoundary of the meshed wall (None: not meshed, or k = 0)
    pair_guard: PairGuard | None = None  # with wall_contact: whether the head is out of the pairs' reach
    pairs_empty: bool = True  # the form holds no contact pairs
    split: SplitResidual | None = None  # the same residual, faster (fem/residual.py); None: form.Apply
    wall_residual: WallResidual | None = None  # the wall contact alone, paired with the form (for split)
    # (u0, radius) of the form's own pairing where it is put off until the form is linearised
    _pairing: tuple[GridFunction, float] | None = field(default=None, repr=False)

    def update_wall_pairs(self, u0: GridFunction) -> None:
        """Pair the meshed wall's face with the head at the displacement u0 (nothing without that wall),
        within the radius the step needs (PairGuard); none while the head cannot reach the wall within the
        step, where an update that would leave none is skipped (an update cost 1-2 ms, and a pair's
        evaluation in a residual about 20 us). With the split residual the form itself is only linearised,
        for a new Jacobian (about one in 500 steps against the wall): its pairing waits for `linearise`,
        which saves one of the two updates of a step in reach of the wall (0.7 ms)."""
        if self.wall_contact is None:
            return
        radius = WALL_SEARCH_DISTANCE if self.pair_guard is None else self.pair_guard.radius(u0.vec.FV().NumPy())
        far = radius == 0.0
        if far and self.pairs_empty:
            return
        maxdist = NO_PAIRS if far else radius
        if self.split is None:
            self.wall_contact.Update(u0, self.form, intorder=WALL_CONTACT_INTORDER, maxdist=maxdist)
        else:
            self._pairing = (u0, maxdist)
        self.pairs_empty = far
        if self.wall_residual is not None:
            self.wall_residual.update(u0, maxdist)

    def linearise(self, w: ngs.BaseVector) -> None:
        """The form's linearisation at w into form.mat, its wall pairs made first where they were put off
        (at the step loaded last: its u0 is still in the GridFunction the pairing was given)."""
        if self._pairing is not None and self.wall_contact is not None:
            u0, maxdist = self._pairing
            self.wall_contact.Update(u0, self.form, intorder=WALL_CONTACT_INTORDER, maxdist=maxdist)
            self._pairing = None
        self.form.AssembleLinearization(w)


# ------------------------------------------------------------------ pieces both forms are made of
Terms = tuple[CoefficientFunction, CoefficientFunction]  # (inertia, first Piola-Kirchhoff stress) of a body


def _bodies_form(
    space: FemSpace, du: CoefficientFunction, inertia_and_stress: Callable[[Material], Terms]
) -> BilinearForm:
    """Each body's inertia, elastic stress and gravity; inertia_and_stress(material) -> (inertia, P)."""
    sc = space.scene
    h = sc.pendulum.thickness
    gvec = CF((0.0, -sc.gravity))
    form = BilinearForm(space.X)
    for region, mat in space.bodies:
        inertia, elastic = inertia_and_stress(mat)
        form += (
            mat.rho * h * InnerProduct(inertia, du)
            + h * InnerProduct(elastic, Grad(du))
            - mat.rho * h * InnerProduct(gvec, du)
        ).Compile() * ngs.dx(region)
    return form


def _add_hinge_and_torque(
    form: BilinearForm, trial: tuple, test: tuple, inputs: StepInputs, F_hinge: CoefficientFunction
) -> None:
    """Hinge: mean displacement of the hinge edge is zero (Lagrange multipliers q1, q2). Follower
    torque: line load p(X) * Cof(F) N on the hinge edge, F the scheme's deformation gradient there."""
    (u, q1, q2), (du, p1, p2) = trial, test
    form += (q1 * du[0] + q2 * du[1] + p1 * u[0] + p2 * u[1]) * ngs.ds("hinge")
    N = specialcf.normal(2)
    form += -InnerProduct(inputs.torque_load * inputs.torque_weight * (Cof(F_hinge) * N), du) * ngs.ds("hinge")


def _add_rigid_wall(
    form: BilinearForm,
    space: FemSpace,
    du: CoefficientFunction,
    force: CoefficientFunction,
    active: ngs.BitArray | None = None,
) -> ngs.BitArray:
    """The penalty force on the head's outer boundary, assembled only on head elements that can
    reach the block within the step (the returned BitArray, empty until the step marks them; or
    `active`, shared with another form)."""
    mesh, order = space.mesh, space.scene.model.order
    if active is None:
        active = ngs.BitArray(mesh.GetNE(BND))
        active.Clear()
    form += (-space.scene.pendulum.thickness * InnerProduct(force, du)).Compile() * ngs.ds(
        "head", bonus_intorder=space.contact_order - 2 * order, definedonelements=active
    )
    return active


def _meshed_wall_contact(space: FemSpace, um: CoefficientFunction, um_head: CoefficientFunction) -> ngs.ContactBoundary:
    """The Newmark form's wall contact: penalty energy of the gap at the displacements um (wall side) and
    um_head, integrated on the wall face; pairs are found at the step start. deformed=False: integrated
    on the reference face (with deformed=True an impact gained 9 % energy). The energy is doubled, as when
    the energy-momentum form used it at the midpoint (where d um / d u1 = 1/2 halves it back): at um = u1
    that is twice the penalty stiffness, kept so that the seed-scheme benchmarks stay as measured."""
    return contact_boundary(space, um, um_head, 2.0)


# ------------------------------------------------------------------ the two builders
Builder = Callable[[FemSpace, StepInputs], StepForm]


def _differentiated(builder: Builder) -> Builder:
    """The builder with NGSolve's integrators differentiating the integrand by the test function
    symbolically (ngsglobals.symbolic_integrator_uses_diff, set while the form is built and put back
    after, so that nothing else in the process changes). Otherwise an integrator evaluates the whole
    integrand once per component of the test function and its gradient: the steel step form's
    residual takes 0.14 ms with the derivatives, 0.66 ms without."""

    @functools.wraps(builder)
    def build(space: FemSpace, inputs: StepInputs) -> StepForm:
        before = ngs.ngsglobals.symbolic_integrator_uses_diff
        ngs.ngsglobals.symbolic_integrator_uses_diff = True
        try:
            return builder(space, inputs)
        finally:
            ngs.ngsglobals.symbolic_integrator_uses_diff = before

    return build


def discrete_gradient_points(mat: Material) -> int:
    """Gauss points of the discrete gradient's averaged stress (docs/notes/robustness.md): for steel one point
    lost up to 0.5 % of the energy after violent impacts (strains ~3e-3), two: 4e-4 J of 280 J; rubber
    at 50 % strain drifted 9 % of a pulse's work in 40 ms with two points, 0.8 % with three."""
    return 3 if mat.soft else 2


@_differentiated
def energy_momentum_form(space: FemSpace, inputs: StepInputs) -> StepForm:
    """Midpoint inertia, discrete-gradient stress and contact, torque at the midpoint configuration."""
    trial, test = space.X.TnT()
    u, du = trial[0], test[0]
    u0, v0, dt = inputs.u0, inputs.v0, inputs.dt
    F0, F1 = material.deformation_gradient(u0), material.deformation_gradient(u)
    Fm = 0.5 * (F0 + F1)
    C0, C1 = material.right_cauchy_green(F0), material.right_cauchy_green(F1)

    def inertia_and_stress(mat: Material) -> Terms:
        stress = Fm * material.averaged_pk2_stress(C0, C1, *mat.lame, discrete_gradient_points(mat))
        return (2.0 / (dt * dt)) * (u - u0 - dt * v0), stress

    form = _bodies_form(space, du, inertia_and_stress)
    _add_hinge_and_torque(form, trial, test, inputs, Id(2) + 0.5 * (Grad(u).Trace() + Grad(u0).Trace()))
    active, force = None, None
    if space.contact_on:
        pos, sc = space.pos, space.scene
        force = contact_law.discrete_gradient_force(pos + u0, pos + u, sc.block, sc.contact.stiffness)
        active = _add_rigid_wall(form, space, du, force)
    wall, wall_residual, guard = None, None, None
    if space.wall_contact_on:
        wall, guard = discrete_gradient_contact(space, u0, u, du), PairGuard(space, v0, dt)
        wall_residual = WallResidual(space, discrete_gradient_contact(space, u0, u, du))
    contact, present = None, active
    if force is not None:  # the rigid-wall term alone, on the same contact set, for SplitResidual
        contact = BilinearForm(space.X)
        _add_rigid_wall(contact, space, du, force, active)
    elif wall_residual is not None:  # the meshed wall's term alone, applied while it has pairs
        contact, present = wall_residual.form, wall_residual.present
    elastic = ElasticTerms(space, discrete_gradient_points)
    split = SplitResidual(elastic, LinearTerms(space, inputs.torque_weight), contact, present)
    return StepForm(form, active, wall, guard, split=split, wall_residual=wall_residual)


@_differentiated
def newmark_form(space: FemSpace, inputs: StepInputs) -> StepForm:
    """Trapezoidal Newmark: a1 = 4/dt^2 (u1 - u0 - dt v0) - a0, equilibrium (stress, contact, torque) at the end."""
    trial, test = space.X.TnT()
    u, du = trial[0], test[0]
    u0, v0, a0, dt = inputs.u0, inputs.v0, inputs.a0, inputs.dt
    F1 = material.deformation_gradient(u)
    C1 = material.right_cauchy_green(F1)

    def inertia_and_stress(mat: Material) -> Terms:
        inertia = (4.0 / (dt * dt)) * (u - u0 - dt * v0) - a0
        return inertia, F1 * material.pk2_stress(C1, *mat.lame)

    form = _bodies_form(space, du, inertia_and_stress)
    _add_hinge_and_torque(form, trial, test, inputs, Id(2) + Grad(u).Trace())
    active = None
    if space.contact_on:
        sc = space.scene
        d1, grad1 = contact_law.depth_and_gradient(space.pos + u, sc.block)
        force = -ngs.IfPos(d1, sc.contact.stiffness * d1, 0.0) * grad1
        active = _add_rigid_wall(form, space, du, force)
    if space.wall_contact_on:
        wall = _meshed_wall_contact(space, u, u.Other())
        return StepForm(form, active, wall, PairGuard(space, v0, dt))
    return StepForm(form, active, None)


# ------------------------------------------------------------------ the schemes
class EnergyMomentum:
    """The FE model's own scheme, stepped by the core's step control (stepping.py states its rules)."""

    build = staticmethod(energy_momentum_form)
    stepper = staticmethod(compiled_advance.advance)  # the step control of its advances
    carries_acceleration = False

    def __init__(self, scene: Scene):
        # soft bodies (scene.Material.soft): each step's energy balance is checked (FemModel.step)
        self.energy_guard = scene.pendulum.soft

    def end_acceleration(self, xs: FemState, v1: np.ndarray, dt: float) -> None:
        return None


class SeedNewmark:
    """The seed tutorial's trapezoidal Newmark rule with its step-size rules (`name`: newmark_fixed or
    newmark_gap_rule, fem/seed_stepping.py); its state carries the acceleration."""

    build = staticmethod(newmark_form)
    carries_acceleration = True
    energy_guard = False

    def __init__(self, scene: Scene):
        self.name = scene.solver.scheme
        self.stepper = seed_stepping.stepper(self.name)  # the step control of its advances

    def end_acceleration(self, xs: FemState, v1: np.ndarray, dt: float) -> np.ndarray:
        return 2.0 / dt * (v1 - xs.v) - xs.a


def newmark_start_acceleration(space: FemSpace, static_residual: ngs.BaseVector) -> np.ndarray:
    """Newmark's start acceleration from the equations of motion, M a0 = f(u0) with the hinge held, given the
    Newmark form's residual at u0 with v0 = a0 = 0 (where its inertia term vanishes).

    The seed starts from a0 = 0, an error that the trapezoidal rule never damps; a consistent start
    gives its scheme the fairest comparison. The velocity term of the start (centripetal) is left
    out, as omega0 is 0 in the benchmarks."""
    (u, q1, q2), (du, p1, p2) = space.X.TnT()
    h = space.scene.pendulum.thickness
    mass = BilinearForm(space.X)
    mass += (q1 * du[0] + q2 * du[1] + p1 * u[0] + p2 * u[1]) * ngs.ds("hinge")
    for region, mat in space.bodies:
        mass += mat.rho * h * InnerProduct(u, du) * ngs.dx(region)
    mass.Assemble()
    acc = (mass.mat.Inverse(space.X.FreeDofs(), inverse="umfpack") * static_residual).Evaluate().FV().NumPy()
    return -acc[: space.nV].copy()


def scheme_for(scene: Scene) -> EnergyMomentum | SeedNewmark:
    """The scheme solver.scheme names."""
    return EnergyMomentum(scene) if scene.solver.scheme == "energy_momentum" else SeedNewmark(scene)
