"""Full nonlinear FE pendulum (fidelity "fem"): plane-stress Neo-Hookean, hinge, gravity, torque, wall contact.

`FemModel` puts together pieces that each hold one concern:

* fem/space.py        the mesh, the spaces and the bodies on them; the step forms' inputs
                      `StepInputs`; the state `FemState` and its ModelState;
* fem/schemes.py      the step forms, one builder per time integration scheme: the
                      energy-momentum scheme (ours: over every step the change of
                      kinetic + gravity + strain + contact energy equals the work of the
                      torque up to the Newton tolerance, so impacts neither gain nor lose
                      energy) and the seed's Newmark rule (for the benchmarks only);
* fem/step_load.py    a step's inputs as a value (`StepLoad`), and the held Jacobian's point;
* fem/step_loader.py  sets the step form's inputs from a StepLoad;
* fem/newton.py       the nonlinear solve of a step with its held Jacobian;
* fem/head.py         the head boundary's sample points: gap, contact set, meshed-wall contact;
* fem/outputs.py      the outputs of a state.

A step, in order: `advance` hands the state to the step control chosen with the
scheme when the model is built (stepping.py, or fem/seed_stepping.py for the
seed's schemes), which calls `step`; `step` makes the step's `StepLoad` and loads
it (`load_step`), and gives it to the Newton solver with the start iterate.
"""

from __future__ import annotations

import math
from functools import partial

import numpy as np
from ngsolve import CF, x, y

from ..contact_time import contact_time_scale, effective_mass, scene_body_stiffness
from ..output_rates import probe_derivatives
from ..protocol import (
    BodyField,
    ModelState,
    OutputDerivatives,
    Outputs,
    PendulumModel,
    StepFailed,
    StopAt,
    check_advance_args,
    protocol_doc,
    restore_advance_summary,
)
from ..scene import Scene, validate
from ..shared_state import task_manager
from ..stepping import StepControl
from ..torque import Torque, TorqueProfile
from .contact_update import use_contact_update
from .head import HeadBoundary
from .newton import HeldJacobianNewton, Turn
from .outputs import FemOutputs
from .rigid_contact import compiled_contact
from .schemes import newmark_start_acceleration, scheme_for
from .seed_stepping import Stepper
from .space import FIDELITY, FemState, fem_space, step_inputs
from .split_jacobian import SplitJacobian
from .start_iterate import predicted_miss, recorded
from .step_load import StepLoad
from .step_loader import StepLoader

# Compliant bodies: a step whose energy balance misses by more than this share of the energy in
# motion is rejected and halved. The discrete gradient's Gauss rule is exact only to the strain
# increment's 6th power; a crushing rubber hinge otherwise gained 15 % in 0.3 ms (docs/notes/robustness.md).
STEP_ENERGY_TOLERANCE = 1e-3
# The probe steps of output_derivatives (s): Newton's tolerance (NEWTON_RTOL of a step's displacement) leaves
# ~1e-9 |omega| / PROBE_STEP in theta'', 1e-5 of it at 20 degrees; the one-sided differences' truncation,
# (PROBE_STEP / 1 ms)^2 of an elastic vibration of 1 ms period, is 1e-4
PROBE_STEP = 1e-5


class FemModel:
    """The full-fidelity model (fidelity "fem")."""

    fidelity = FIDELITY

    def __init__(self, scene: Scene, refine_like_seed: bool = False):
        self.scene = scene = validate(scene)  # with model.order resolved
        # the meshed wall's contact keeps the phase rule's steps, more per contact than the timing rule's: its pairs
        # are found anew only at each step's start, and an impact in fewer steps loses more energy (1.2e-4 of the
        # swing energy in the timing rule's 18 steps, 8.5e-5 in 31)
        self.control = StepControl.for_scene(scene, timing_rule=scene.wall.kind == "rigid", even_contact_steps=True)
        self.space = fem_space(scene, refine_like_seed)
        self._body_stiffness = scene_body_stiffness(scene)
        self.scheme = scheme_for(scene)
        # the step control of every advance, chosen once: stepping.advance, or a seed scheme's rules
        self._stepper: Stepper[FemState] = self.scheme.stepper
        self.inputs = step_inputs(self.space)
        self.form = self.scheme.build(self.space, self.inputs)
        self.head = HeadBoundary(self.space)
        split, contact = self.form.split, compiled_contact(self.space, self.head)
        strain = None if split is None else split.elastic.strain_energy
        self.measures = FemOutputs(self.space, self.inputs, self.head, strain, contact)
        if split is not None:
            split.use_compiled_contact(contact)
        self.loader = StepLoader(self.inputs, self.form, self.head)
        turn = Turn(self.space, self.measures.rotation_angle)
        residual = split or self.form.form.Apply
        inertia = None if split is None else (split.linear.mass, split.linear.inertia_coefficient)
        # the compiled Jacobian where the contact is the rigid wall's (or none); the meshed wall's is NGSolve's.
        # update: the held factors updated for the rigid wall's contact, which the Jacobian then leaves out
        update = contact is not None and use_contact_update(scene)
        tangent = None
        if split is not None and self.form.wall_residual is None:
            tangent = partial(SplitJacobian, split, with_contact=not update)
        args = (self.loader.load, turn, inertia, tangent, self.form.linearise, update)
        self.newton = HeldJacobianNewton(self.form.form, residual, self.space, *args)
        self.time = 0.0
        self._state = self._start_state()
        self._outputs = self.measures.of(self._state, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    # the mesh and the pendulum's mass measures as meshed (tests and benchmarks read them)
    mesh = property(lambda self: self.space.mesh)
    X = property(lambda self: self.space.X)
    inertia0 = property(lambda self: self.measures.inertia0)
    total_mass = property(lambda self: self.measures.total_mass)
    com_depth = property(lambda self: self.measures.com_depth)

    def _initial_state(self) -> FemState:
        """Rigidly rotated by theta0 and turning at omega0 about the pivot."""
        th, om = self.scene.theta0, self.scene.omega0
        c, s = math.cos(th), math.sin(th)
        pendulum = self.space.mesh.Materials("pendulum")
        gf_u, gf_v = self.space.gf_u, self.space.gf_v
        gf_u.vec[:] = 0.0
        gf_v.vec[:] = 0.0
        gf_u.Set(CF(((c - 1) * x - s * y, s * x + (c - 1) * y)), definedon=pendulum)
        gf_v.Set(CF((-om * (s * x + c * y), om * (c * x - s * y))), definedon=pendulum)
        return FemState(gf_u.vec.FV().NumPy().copy(), gf_v.vec.FV().NumPy().copy(), np.zeros(2), 0.0)

    def _start_state(self) -> FemState:
        """The initial state; the Newmark schemes' with the start acceleration of the equations of motion."""
        state = self._initial_state()
        if self.scheme.carries_acceleration:
            zero = np.zeros(self.space.nV)
            self.load_step(FemState(state.u, zero, state.hinge_multipliers, 0.0, zero.copy()), 1e-3, 0.0)
            # at u = u0, v0 = a0 = 0 the inertia term vanishes: the static residual
            state.a = newmark_start_acceleration(self.space, self.newton.residual(state.u, 0.0))
        return state

    # ------------------------------------------------------------- one step
    def load_step(self, xs: FemState, dt: float, torque: float) -> StepLoad:
        """Load a step of dt from xs, with contact on the head elements that can reach the block."""
        active = self.head.reachable(xs, dt) if self.form.active is not None else None
        step = StepLoad(xs.u, xs.v, dt, torque, active, xs.a)
        self.loader.load(step)
        return step

    def _drift_guess(self, xs: FemState, step: StepLoad) -> np.ndarray | None:
        """u0 + dt times the last step's mean velocity (u0 - u_prev) / dt_prev where no contact can act
        within the step; None where the start iterate is u0 + dt v0 instead. The midpoint rule's end
        velocity v0 carries an alternating part in the modes a step does not resolve, which the mean over
        a step does not: after the first impact, 1 ms steps from u0 + dt v0 missed u1 by 3.7e-3 m (rubber)
        and 1.2e-4 m (steel), from the mean velocity by 7.4e-4 and 5.7e-5 m (medians). Within reach of the
        wall the mean velocity of a step before the contact set changes is the worse guess: across an
        impact in 0.1 s doSteps it moved the energy balance from 1e-7 to 3e-7 of the energy moved. The
        meshed wall is within reach where the step has its pairs (StepForm.update_wall_pairs)."""
        if step.active is not None:
            in_reach = step.active.size > 0
        else:
            in_reach = self.form.wall_contact is not None and not self.form.pairs_empty
        return None if xs.drift is None or in_reach else xs.u + step.dt * xs.drift

    def _start_iterate(self, xs: FemState, step: StepLoad, drift: np.ndarray | None) -> np.ndarray:
        """Newton's start iterate: the drift guess plus the miss its recurrence predicts (fem/start_iterate.py),
        else u0 + dt v0."""
        if drift is None:
            return xs.u + step.dt * xs.v
        miss = predicted_miss(xs.guess_errors, step.dt)
        return drift if miss is None else drift + miss

    def step(self, xs: FemState, dt: float, torque: float) -> FemState | None:
        """One step of the scheme; None when it cannot be taken (the stepper then halves dt)."""
        step = self.load_step(xs, dt, torque)
        drift = self._drift_guess(xs, step)
        u1 = self._solve_covering_contact(xs, step, self._start_iterate(xs, step, drift))
        if u1 is None or self.min_det_F(u1) <= 0.0:
            return None  # no convergence, or an element turned inside out
        v1 = 2.0 / dt * (u1 - xs.u) - xs.v
        a1 = self.scheme.end_acceleration(xs, v1, dt)
        work = self.measures.torque_work_increment(xs.u, u1, torque)
        mean_velocity = None if self.scheme.carries_acceleration else (u1 - xs.u) / dt
        misses = None if drift is None else recorded(xs.guess_errors, dt, u1 - drift)
        x1 = FemState(
            u1, v1, self.newton.multipliers(), xs.torque_work + work, a1, drift=mean_velocity, guess_errors=misses
        )
        if self.scheme.energy_guard:
            (e0, m0), (e1, m1) = self._energy_of(xs), self._energy_of(x1)
            if abs(e1 - e0 - work) > STEP_ENERGY_TOLERANCE * (max(m0, m1) + abs(work)):
                return None  # the Gauss rule of the discrete gradient is off: a smaller step
        return x1

    def _solve_covering_contact(self, xs: FemState, step: StepLoad, start: np.ndarray) -> np.ndarray | None:
        """Solve from `start`; if a head point ends inside the block off the contact set, widen the set once
        and re-solve from u0 + dt v0 (the start of a step with contact in reach: _drift_guess)."""
        for _attempt in range(2):
            u1 = self.newton.solve(step, start, xs.hinge_multipliers)
            if u1 is None:
                return None
            widened = self.loader.covering(step, u1)
            if widened is None:
                return u1
            step, start = widened, xs.u + widened.dt * xs.v
        return None

    def _energy_of(self, s: FemState) -> tuple[float, float]:
        """(total energy, kinetic + strain + contact energy) of a state, counted as the outputs count them."""
        kinetic, potential, strain, contact = self.measures.energies(s)
        return kinetic + potential + strain + contact, kinetic + strain + contact

    def min_det_F(self, u: np.ndarray | None = None) -> float:
        """Smallest det F at the integration points of every element (of the current state by default)."""
        u = self._state.u if u is None else u
        if self.form.split is not None:  # the same points (the forms' rule), counted in the compiled kernel
            return self.form.split.elastic.min_det_F(u)
        return self.measures.min_det_F(u)

    # ----------------------------------------------------- contact geometry
    def gap_and_rate(self, xs: FemState) -> tuple[float, float]:
        closest = self.head.closest_point(xs)
        return closest.gap, closest.rate

    def contact_scales(self, xs: FemState) -> tuple[float, float]:
        """Contact duration and depth estimated from the rigid-body effective mass at the closest point, the
        penalty in series with the bodies' own stiffness (contact_time.body_stiffness)."""
        if not self.space.contact_on and self.form.wall_contact is None:
            return math.inf, 0.0
        closest = self.head.closest_point(xs)
        m_eff = effective_mass(self.inertia0, closest.arm, self.scene.geometry.head_centre_depth)
        return contact_time_scale(
            closest.gaps,
            self.head.weights,
            m_eff,
            closest.rate,
            self.scene.contact.stiffness * self.scene.pendulum.thickness,
            self._body_stiffness,
        )

    def contact_force(self, xs: FemState) -> float:
        """Magnitude of the wall's resultant force on the pendulum at state xs (N)."""
        return float(np.hypot(*self.measures.contact_force_vector(xs.u)))

    def contact_impulse(self, x0: FemState, x1: FemState, dt: float) -> np.ndarray:
        """The step's contact impulse (N.s, vector), as the scheme applies it (FemOutputs.contact_impulse)."""
        trapezoid = self.scheme.carries_acceleration or self.space.wall_contact_on
        return self.measures.contact_impulse(x0.u, x1.u, dt, trapezoid)

    # ---------------------------------------------------------------- protocol
    @protocol_doc(PendulumModel.advance)
    def advance(self, t_end: float, torque: Torque = 0.0, stop: StopAt | None = None) -> Outputs:
        """The scheme of solver.scheme (fem/schemes.py) under the step control of stepping.py; a failed advance
        also puts back the held Jacobian, so that a retry continues as if it had never been tried."""
        check_advance_args(self.time, t_end, torque)
        torque = torque if isinstance(torque, TorqueProfile) else float(torque)
        held = self.newton.held
        try:
            with task_manager(self.scene.model.threads):
                result = self._stepper(self, self._state, self.time, t_end, torque, self.control, stop)
        except StepFailed:
            # the held Jacobian is part of the state: put back the one from before the failed
            # advance, so that a retry continues exactly as if it had never been tried
            self.newton.held, self.newton.ready = held, False
            raise
        self._state = result.state
        self.time = result.end_time(float(t_end))
        self._outputs = self.measures.of(self._state, self.time, result.substeps)
        self.last_min_gap = result.finish(self._outputs)
        return self._outputs

    def outputs(self) -> Outputs:
        return self._outputs

    def output_derivatives(self, torque: TorqueProfile) -> OutputDerivatives:
        """The outputs' time derivatives at the current state from three probe steps of the scheme
        (physics/output_rates.py; the state, held Jacobian included, restored afterwards)."""
        return probe_derivatives(self, torque, PROBE_STEP)

    def fields(self) -> list[BodyField]:
        return self.measures.fields(self._state)

    def get_state(self) -> ModelState:
        return self._state.to_model_state(self.time, self._outputs, self.newton.held)

    def set_state(self, state: ModelState) -> None:
        nV, newmark = self.space.nV, self.scheme.carries_acceleration
        self._state, self.newton.held = FemState.from_model_state(state, nV, newmark)
        self.newton.ready = False
        self.time = state.time
        self._outputs = restore_advance_summary(state, self.measures.of(self._state, self.time, 0))
        self.last_min_gap = self._outputs.gap_min
