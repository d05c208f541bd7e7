"""Reduced pendulum (fidelity "reduced"): exact rotation about the hinge plus a few elastic modes.

Floating frame of reference: a material point X of the pendulum is at

    x = R(theta) (X + sum_j phi_j(X) q_j)

with a mass-normalised basis phi_j of the hinged pendulum's elastic motion
(reduced/modes.py: eigenmodes and static corrections for the loads). The modes are
mass-orthogonal to the rigid rotation, so theta is the FE model's best-fit angle
and p_theta its angular momentum about the pivot.
Energies, with z = (theta, q) and momenta p = M(q) dz/dt:

* kinetic  1/2 p^T M(q)^-1 p,  M(q) = [[I0 + 2 a.q + q.q, (G^T q)^T], [G^T q, Id]]
  (G: gyroscopic coupling of the modes);
* strain   in the rotating frame, so any rotation is exact: the FE model's
  Neo-Hookean energy of the field phi q for soft bodies, its quadratic part
  1/2 sum omega_j^2 q_j^2 for stiff ones (uses_linear_strain);
* gravity  g (sin theta S_x(q) + cos theta S_y(q)), S the first mass moment;
* contact  the penalty law of fem/contact_law.py, summed over points on the head
  boundary in the deformed configuration.

Time integration is a discrete gradient scheme for H(z, p): kinetic energy is
split exactly into its p and q differences, and gravity + contact + strain get
Gonzalez's correction in the mass metric. Over every step H changes by exactly
the torque's work tau (d theta + beta . dq), so impacts neither gain nor lose
energy. Step sizes come from stepping.py, as for the other fidelities.

The step, the contact terms and the gap run in the compiled core
(physics/core/reduced_step.c, bound by reduced/kernel.py); the numpy forms of
the same computation are its test reference (tests/test_reduced_native.py).

This class puts the pieces together and implements the protocol: dynamics.py (M(q), gravity),
potential.py, head.py (the head points and their culling), contact.py (the penalty terms and the
step's impulse), approach.py (the gap, rate and contact scales the step control asks for),
step.py (the Newton step, numpy or compiled), modal_field.py (stress and fields), state.py.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled_advance import CoreRun
from ..mass_properties import gravity_moment
from ..output_rates import flow_derivatives, flow_step
from ..protocol import BodyField, ModelState, OutputDerivatives, Outputs, StopAt, restore_advance_summary
from ..scene import Scene, refuse_deformable_wall, validate
from ..stepped_model import SteppedModel
from ..stepping import AdvanceResult, StepControl
from ..torque import Torque, TorqueProfile
from .approach import WallApproach
from .contact import WallContact
from .dynamics import Gravity, ModalMass, inverse_form, inverse_times
from .head import HeadPoints
from .modal_field import ModalField
from .modes import ModalBasis, modal_basis
from .potential import Potential
from .state import FIDELITY, ReducedState
from .step import CompiledStep, NewtonStep, bind_kernel
from .strain import strain_energy, uses_linear_strain


class ReducedModel(SteppedModel[ReducedState]):
    """The reduced fidelity (fidelity "reduced").

    State: ReducedState, z = (theta, q), the momenta p and the torque work. wall.kind
    "deformable" is not offered (fidelity.create rejects it); "none" or a zero
    contact stiffness switch contact off, `gap` still reports the geometric
    distance to the block.
    """

    fidelity = FIDELITY

    def __init__(self, scene: Scene, basis: ModalBasis | None = None):
        self.scene = scene = validate(scene)  # with model.order resolved
        refuse_deformable_wall(scene, self.fidelity)
        self.basis = b = basis if basis is not None else modal_basis(scene)
        self.m = b.count
        self.n = self.m + 1
        self.inertia0 = b.inertia0
        self.contact_on = scene.wall.kind == "rigid" and scene.contact.stiffness > 0.0
        self.block = scene.block
        # soft bodies (outside this model's accurate range) keep the phase rule's steps per contact: there the
        # angle after an impact moved by 0.5-2.7 degrees between 16 and 116 steps per contact, unconverged
        self.control = StepControl.for_scene(scene, timing_rule=uses_linear_strain(scene))
        hk = scene.pendulum.thickness * scene.contact.stiffness
        self._torque_unit = torque_unit = np.concatenate([[1.0], b.torque_modes])  # generalised force of a unit torque
        self._strain = strain = strain_energy(scene, b)
        self._mass = mass = ModalMass(b)
        gravity = Gravity(scene.gravity, b)
        self._head = head = HeadPoints(b, scene.geometry.head_centre_depth, scene.block)
        self._kernel = kernel = bind_kernel(strain, mass, gravity, head, hk, torque_unit, self.contact_on)
        compiled_contact = None if kernel is None else kernel.contact
        self._contact = contact = WallContact(head, mass, hk, self.contact_on, compiled_contact)
        self._potential = potential = Potential(gravity, contact, strain)
        exact_gap = head.gap if kernel is None else kernel.gap
        self._approach = WallApproach(head, mass, exact_gap, hk, self.control.max_step, self.contact_on)
        self._newton = NewtonStep(mass, gravity, potential, contact, strain, torque_unit, b.omega2)  # numpy form
        self._step = self._newton.step if kernel is None else CompiledStep(kernel, potential).step
        self._field = ModalField(scene, b.phi)
        self._load = (gravity_moment(scene), scene.geometry.head_centre_depth)  # the held-contact test's load
        self._core_run = None if kernel is None else CoreRun(kernel.run_advance, self.control, 2 * self.n + 1)
        z0 = np.zeros(self.n)
        z0[0] = float(scene.theta0)
        p0 = self.mass_matrix(z0) @ np.concatenate([[float(scene.omega0)], np.zeros(self.m)])
        self.time = 0.0
        self._x = ReducedState(z0, p0, 0.0)
        self._outputs = self._compute_outputs(self._x, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    def _stepped(self, t_end: float, torque: Torque, stop: StopAt | None) -> AdvanceResult[ReducedState]:
        """The advance's steps in the compiled core (core/reduced_advance.c); in numpy by stepping.py on the
        model without a core, the core's test reference."""
        if self._core_run is None:
            return super()._stepped(t_end, torque, stop)
        x, n = self._x, self.n
        state = np.concatenate([x.z, x.p, [x.torque_work]])
        run = self._core_run.advance(state, self.time, t_end, torque, self._outputs, self._load, stop)
        s = run.state
        stepped = ReducedState(s[:n].copy(), s[n : 2 * n].copy(), float(s[2 * n]))
        return AdvanceResult(stepped, run.substeps, run.rejected, run.min_gap, run.contact, run.stopped_at)

    def mass_matrix(self, z: np.ndarray) -> np.ndarray:
        return self._mass.matrix(z)

    def potential_energy(self, z: np.ndarray) -> float:
        """Gravity + contact + strain energy."""
        return self._potential.energy(z)

    def energy(self, x: ReducedState) -> float:
        """The Hamiltonian at x: kinetic plus potential energy."""
        _, c, s = self._mass.parts(x.z[1:])
        return 0.5 * inverse_form(c, s, x.p) + self.potential_energy(x.z)

    # ------------------------------------------------------------ stepping.Steppable
    def step(self, x: ReducedState, dt: float, torque: float) -> ReducedState | None:
        """One discrete-gradient step (step.py); None when Newton does not converge (the stepper halves dt)."""
        return self._step(x, dt, torque)

    def gap_and_rate(self, x: ReducedState) -> tuple[float, float]:
        return self._approach.gap_and_rate(x)

    def contact_scales(self, x: ReducedState) -> tuple[float, float]:
        return self._approach.contact_scales(x)

    def contact_force(self, x: ReducedState) -> float:
        return self._contact.force(x.z)

    def contact_impulse(self, x0: ReducedState, x1: ReducedState, dt: float) -> np.ndarray:
        return self._contact.impulse(x0.z, x1.z, dt)

    # ---------------------------------------------------------------- protocol
    def output_derivatives(self, torque: TorqueProfile) -> OutputDerivatives:
        """The outputs' time derivatives at the current state (physics/output_rates.py), along the
        Hamiltonian flow the step discretises: dz/dt = M(q)^-1 p, dp/dt = -dH/dz + T Q, the torque
        work's rate T Q . dz/dt. -dH/dz is -dV/dz plus the kinetic energy's q-gradient at fixed
        velocity, theta'^2 (a + q) + theta' G q' (from M's border: m00 = I0 + 2 a.q + q.q, c = G^T q)."""
        n, t, mass = self.n, self.time, self._mass

        def flow(x: np.ndarray, T: float) -> np.ndarray:
            z, p = x[:n], x[n : 2 * n]
            q = z[1:]
            _, c, s = mass.parts(q)
            zdot = inverse_times(c, s, p)
            w, qdot = zdot[0], zdot[1:]
            pdot = T * self._torque_unit - self._potential.gradient(z)
            pdot[1:] += (w * w) * (mass.a + q) + w * (mass.gyro @ qdot)
            return np.concatenate([zdot, pdot, [T * float(self._torque_unit @ zdot)]])

        def observe(x: np.ndarray) -> Outputs:
            return self._compute_outputs(ReducedState(x[:n].copy(), x[n : 2 * n].copy(), float(x[-1])), t, 0)

        x0 = self._x
        state = np.concatenate([x0.z, x0.p, [x0.torque_work]])
        return flow_derivatives(state, flow, observe, torque, t, flow_step(self.contact_scales(x0)[0]))

    def get_state(self) -> ModelState:
        return self._x.to_model_state(self.time, self._outputs)

    def set_state(self, state: ModelState) -> None:
        self._x = x = ReducedState.from_model_state(state, self.n)
        self.time = float(state.time)
        self._outputs = restore_advance_summary(state, self._compute_outputs(x, self.time, 0))
        self.last_min_gap = self._outputs.gap_min

    def _compute_outputs(self, x: ReducedState, t: float, substeps: int) -> Outputs:
        z, p, work = x
        m00, c, s = self._mass.parts(z[1:])
        kinetic = 0.5 * inverse_form(c, s, p)
        potential, c_energy, strain = self._potential.parts(z)
        force = self._contact.terms(z).force
        gap = self._approach.output_gap(x)
        vm = self._field.von_mises_max(z) if self.scene.model.compute_stress else 0.0
        return Outputs(
            time=t,
            theta=math.remainder(float(z[0]), 2.0 * math.pi),
            omega=float(p[0] / m00),
            gap=gap,
            contact_force=float(np.hypot(*force)),
            energy_kinetic=kinetic,
            energy_potential=potential,
            energy_strain=strain,
            energy_contact=c_energy,
            energy_total=kinetic + potential + strain + c_energy,
            energy_torque_work=work,
            stress_von_mises_max=vm,
            solver_substeps=substeps,
            gap_min=gap,
        )

    def von_mises_max(self, z: np.ndarray) -> float:
        """Largest von Mises stress of the modal displacement field (frame-invariant), on the FE mesh."""
        return self._field.von_mises_max(z)

    def fields(self) -> list[BodyField]:
        """Nodal fields of the modal field (modal_field.py)."""
        x = self._x
        return self._field.body_fields(x.z, self._mass.velocity(x.z, x.p))
