"""Rigid pendulum (fidelity "rigid"): one rotation about the pivot, the same wall law as the FE model.

Mass, centre of mass and moment of inertia come from mass_properties.py, integrated over the very mesh
geometry the FE model uses (geometry.make_mesh, fine and highly curved), so
the two fidelities describe the same body. Contact is the penalty law of
contact.py on the head's outer arc, integrated exactly (core/rigid_model.c; in
Python in rigid/arc_contact.py, the core's test reference).

Time integration is the one-DOF discrete gradient (energy-consistent
midpoint) rule, with q = theta, V = gravity + contact energy:

    (omega1 + omega0) / 2 = (q1 - q0) / dt
    I (omega1 - omega0) / dt = T - (V(q1) - V(q0)) / (q1 - q0)

so that kinetic + V changes by exactly T (q1 - q0) per step: impacts neither
gain nor lose energy whatever the step, and the rebound angle is the release
angle. The whole advance runs in the compiled core (core/rigid_advance.c): a
single free-flight step where the head provably stays off the block, else the
shared step control (core/stepping.c, whose rules stepping.py states) over the
step's scalar equation and its Newton solves. rigid/solve.py and the Steppable
methods here are the same in Python, stepped by stepping.py: the core's test
reference. The state is in rigid/state.py.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..compiled_advance import CoreRun
from ..contact_time import effective_mass
from ..mass_properties import gravity_moment, mass_properties
from ..output_rates import flow_derivatives, flow_step
from ..protocol import (
    BodyField,
    ModelState,
    OutputDerivatives,
    Outputs,
    StopAt,
    restore_advance_summary,
)
from ..scene import Scene, refuse_deformable_wall, validate
from ..stepped_model import SteppedModel
from ..stepping import AdvanceResult, StepControl
from ..torque import Torque, TorqueProfile
from . import arc_contact as rigid_contact
from .kernel import RigidCore
from .solve import Contact, StepSolver
from .state import FIDELITY, RigidState

if TYPE_CHECKING:
    from ..fields import VertexSampler

APPROACH_SPEED_FLOOR = 1e-3  # m/s: a head at rest near the block is assumed to approach at least this fast
_SPEED_FLOOR2 = APPROACH_SPEED_FLOOR**2
NEAR_FRACTION = 1.0  # contact scales are reported while the gap is below this many head radii
NO_CONTACT = rigid_contact.Penalty(0.0, 0.0, 0.0, 0.0, 0.0)
TWO_PI = 2.0 * math.pi
# new_state(RigidState, (theta, omega, work)): RigidState(...) at about half its cost (NamedTuple's __new__ is
# a Python function; this is tuple's own), at every step
new_state = tuple.__new__


class RigidModel(SteppedModel[RigidState]):
    """The rigid fidelity (fidelity "rigid").

    State: a RigidState (rigid/state.py). Outputs: energy_strain and
    stress_von_mises_max are always 0 (a rigid body neither stores strain energy nor
    has a stress field worth reporting). theta is reported wrapped to
    [-pi, pi] like the FE model's atan2 proxy; the internal angle is
    continuous, so energies and steps do not notice the wrap.

    wall.kind "none" (or contact.stiffness 0): no contact force; `gap` still
    reports the geometric signed distance to the block so that a master sees
    where the wall would be. wall.kind "deformable" is not offered (fidelity.create
    rejects it); constructing one directly raises ValueError.
    """

    fidelity = FIDELITY

    def __init__(self, scene: Scene):
        self.scene = scene = validate(scene)  # with model.order resolved
        refuse_deformable_wall(scene, self.fidelity)
        geo, mat = scene.geometry, scene.pendulum
        body = mass_properties(scene)
        self.total_mass, self.com_depth, self.inertia = body.total_mass, body.com_depth, body.inertia
        self._mgd = gravity_moment(scene)
        self.block = scene.block
        self.contact_on = scene.wall.kind == "rigid" and scene.contact.stiffness > 0.0
        self._hk = mat.thickness * scene.contact.stiffness
        self._depth, self._radius = geo.head_centre_depth, geo.head_radius
        self._reach = self._depth + self._radius  # farthest arc point from the pivot: how far a rotation sweeps it
        if not 0.0 < geo.rod_half_width < geo.head_radius:
            raise ValueError(
                f"geometry: rod_half_width {geo.rod_half_width!r} must lie in (0, head_radius {geo.head_radius!r})"
            )
        half_gap = math.asin(geo.rod_half_width / geo.head_radius)  # rod joint, seen from the head centre
        self._arc_offset = 0.5 * math.pi + half_gap
        self._arc_length = 2.0 * math.pi - 2.0 * half_gap
        # energy law E = C delta^2.5 of a circle pressed into a flat face (delta << R)
        self._flat_law = 8.0 / 15.0 * self._hk * math.sqrt(2.0 * self._radius)
        self.control = StepControl.for_scene(scene)
        self._memo: dict[float, Contact] = {}  # pure functions of the angle, so caching keeps runs deterministic
        self.solver = StepSolver(self.inertia, self._mgd, self._contact)
        self._core = RigidCore(
            inertia=self.inertia,
            mgd=self._mgd,
            hk=self._hk,
            depth=self._depth,
            radius=self._radius,
            reach=self._reach,
            arc_offset=self._arc_offset,
            arc_length=self._arc_length,
            flat_law=self._flat_law,
            contact_on=int(self.contact_on),
            x_min=self.block.x_min,
            x_max=self.block.x_max,
            y_min=self.block.y_min,
            y_max=self.block.y_max,
        )
        self._core_run = CoreRun(self._core.run_advance, self.control, 3)
        self._load = (self._mgd, self._depth)  # the held-contact test's load: m g d and the head centre's depth
        self._sampler: VertexSampler | None = None  # the mesh's vertices, for fields()
        self.time = 0.0
        self._x = self.state(scene.theta0, scene.omega0)
        self.last_min_gap = math.inf
        self._outputs = self._compute_outputs(self._x, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    @staticmethod
    def state(theta: float, omega: float, torque_work: float = 0.0) -> RigidState:
        """The model's state at angle theta (rad) and angular velocity omega (rad/s): what `step`,
        `gap_and_rate` and `contact_scales` take."""
        return RigidState(float(theta), float(omega), float(torque_work))

    # -------------------------------------------------------------- geometry
    def arc(self, theta: float) -> rigid_contact.Arc:
        """The head's outer boundary (without the rod joint) at angle theta."""
        D = self._depth
        return rigid_contact.new_named(
            rigid_contact.Arc,
            (D * math.sin(theta), -D * math.cos(theta), self._radius, theta + self._arc_offset, self._arc_length),
        )

    def _contact(self, q: float) -> Contact:
        """(pieces, Penalty) at angle q, memoised: Newton and the stepper revisit the same angles."""
        hit = self._memo.get(q)
        if hit is not None:
            return hit
        arc = self.arc(q)
        pieces = rigid_contact.inside_pieces(arc, self.block)  # [] at once for a circle clear of the block
        result: Contact = (
            pieces,
            rigid_contact.penalty(arc, self.block, self._hk, pieces) if pieces else NO_CONTACT,
        )
        if len(self._memo) > 64:
            self._memo.clear()
        self._memo[q] = result
        return result

    def contact_energy(self, theta: float) -> rigid_contact.Penalty:
        """Contact energy, force and its theta-derivatives at angle theta (zeros without a wall), by the core."""
        if not self.contact_on:
            return NO_CONTACT
        return self._core.penalty(float(theta))

    def geometric_gap(self, theta: float) -> tuple[float, float]:
        """(signed gap, d gap / d theta) between the head's arc and the block, by the core."""
        return self._core.gap(float(theta))

    def python_gap(self, theta: float) -> tuple[float, float]:
        """geometric_gap by rigid/arc_contact.py, the core's reference."""
        pieces = list(self._contact(theta)[0]) if self.contact_on else None
        return rigid_contact.signed_gap(self.arc(theta), self.block, pieces)

    # ------------------------------------------------------------- stepping
    def step(self, x: RigidState, dt: float, torque: float) -> RigidState | None:
        """One discrete-gradient step; None when the scalar solve fails (the stepper halves dt)."""
        q0, w0, work = x
        u = self.solver.solve(q0, w0, dt, torque, self.contact_on)
        if u is None:
            return None
        return new_state(RigidState, (q0 + u, 2.0 * u / dt - w0, work + torque * u))

    def contact_force(self, x: RigidState) -> float:
        """Magnitude of the wall's force on the head at state x (N)."""
        pen = self._contact(float(x[0]))[1] if self.contact_on else NO_CONTACT
        return math.hypot(pen.fx, pen.fy)

    def contact_impulse(self, x0: RigidState, x1: RigidState, dt: float) -> np.ndarray:
        """The step's contact impulse (N.s, vector). The scheme applies the contact torque
        -(E(q1) - E(q0)) / (q1 - q0); the force is the penalty force at the midpoint angle scaled to
        that torque (its line of action the midpoint's), so the impulse's moment about the pivot is
        exactly the scheme's contact angular impulse. A step whose midpoint is out of contact (the
        step onto the wall, aimed at the onset): the force at the end in contact, scaled the same way."""
        if not self.contact_on:
            return np.zeros(2)
        q0, q1 = x0[0], x1[0]
        qc, _ = self.solver.contact_quotient(q0, q1 - q0, self._contact(q0)[1].energy)
        for q in (0.5 * (q0 + q1), q1, q0):
            fx, fy, moment = self._force_line(q)
            if moment != 0.0:
                scale = dt * (qc / moment)
                return np.array((scale * fx, scale * fy))
        return np.zeros(2)

    def _force_line(self, q: float) -> tuple[float, float, float]:
        """The contact force at angle q up to a positive factor: (fx, fy, dE/dtheta), all 0 out of contact.
        For the head on one face (a whole segment) that is (-g, g . J centre) (rigid_contact._segment_penalty),
        which needs the pieces but not the energy's series: the impulse's midpoint asks it at a new angle."""
        hit = self._memo.get(q)
        if hit is None:
            arc = self.arc(q)
            pieces = rigid_contact.inside_pieces(arc, self.block)
            if len(pieces) == 1 and pieces[0].whole:
                _, gx, gy = rigid_contact.face_depths(self.block)[pieces[0].face]
                return -gx, -gy, gy * arc.cx - gx * arc.cy
            hit = self._contact(q)
        pen = hit[1]
        return pen.fx, pen.fy, pen.d_energy

    # ------------------------------------------------------------- advance
    def _stepped(self, t_end: float, torque: Torque, stop: StopAt | None) -> AdvanceResult[RigidState]:
        """The advance in the compiled core (core/rigid_advance.c): one free-flight step where the head
        provably stays off the block during it, else the shared step control."""
        run = self._core_run.advance(self._x, self.time, t_end, torque, self._outputs, self._load, stop)
        stepped = new_state(RigidState, tuple(run.state.tolist()))
        return AdvanceResult(stepped, run.substeps, run.rejected, run.min_gap, run.contact, run.stopped_at)

    def gap_and_rate(self, x: RigidState) -> tuple[float, float]:
        """Signed gap and its rate for the stepper; (inf, 0) when there is no contact law to resolve."""
        if not self.contact_on:
            return math.inf, 0.0
        q, w, _ = x
        gap, slope = self.python_gap(q)
        return gap, slope * w

    def contact_scales(self, x: RigidState) -> tuple[float, float]:
        """(contact duration, largest penetration) of the contact in view; (inf, 0) when none.

        Energy available along the contact normal: contact energy + 1/2 m_eff rate^2 with
        m_eff = I / lever^2 (lever = d gap/d theta, the normal's moment arm about the pivot).
        The energy law of the current contact is E = C delta^2.5 (a circle on a flat face),
        with C fitted to the present contact energy when in contact; then
        delta_max = (E_avail / C)^0.4 and duration = pi sqrt(m_eff / K_sec),
        K_sec = 2 E(delta_max) / delta_max^2. A resting contact keeps its energy, so its
        duration is the local oscillation's half period: finite, contact-sized steps."""
        if not self.contact_on:
            return math.inf, 0.0
        q, w, _ = x
        gap, slope = self.python_gap(q)
        rate = slope * w
        if gap > NEAR_FRACTION * self._radius and rate >= 0.0:
            return math.inf, 0.0  # far and not approaching
        m_eff = effective_mass(self.inertia, slope, self._depth)
        energy = self._contact(q)[1].energy
        law = energy / (-gap) ** 2.5 if gap < 0.0 and energy > 0.0 else self._flat_law
        speed2 = rate * rate if rate * rate > _SPEED_FLOOR2 else _SPEED_FLOOR2  # not builtin max: every substep
        available = energy + 0.5 * m_eff * speed2
        delta = (available / law) ** 0.4
        k_sec = 2.0 * law * math.sqrt(delta)
        return math.pi * math.sqrt(m_eff / k_sec), delta

    # ------------------------------------------------------------- protocol
    def output_derivatives(self, torque: TorqueProfile) -> OutputDerivatives:
        """The outputs' time derivatives at the current state (physics/output_rates.py): the flow
        d(theta, omega, work)/dt = (omega, (T - V'(theta)) / I, T omega), V gravity + contact energy."""
        t = self.time

        def flow(x: np.ndarray, T: float) -> np.ndarray:
            q, w = float(x[0]), float(x[1])
            dV = self._mgd * math.sin(q) + self.contact_energy(q).d_energy
            return np.array((w, (T - dV) / self.inertia, T * w))

        def observe(x: np.ndarray) -> Outputs:
            return self._compute_outputs(RigidState(float(x[0]), float(x[1]), float(x[2])), t, 0)

        x = np.array(self._x)
        step = flow_step(self.contact_scales(self._x)[0])
        return flow_derivatives(x, flow, observe, torque, t, step)

    def get_state(self) -> ModelState:
        return self._x.to_model_state(self.time, self._outputs)

    def set_state(self, state: ModelState) -> None:
        self._x, self.time = RigidState.from_model_state(state), float(state.time)
        self._outputs = restore_advance_summary(state, self._compute_outputs(self._x, self.time, 0))
        self.last_min_gap = self._outputs.gap_min

    def fields(self) -> list[BodyField]:
        """Nodal fields of the rigid motion on the FE model's mesh of the pendulum: displacement and
        velocity of the rotation by theta at omega about the pivot; no stress (a rigid body)."""
        from ..fields import VertexSampler, body_field, rigid_motion
        from ..geometry import make_mesh

        if self._sampler is None:
            geo, settings = self.scene.geometry, self.scene.model
            self._sampler = VertexSampler(make_mesh(geo, settings.mesh_size, settings.order), "pendulum")
        q, w, _ = self._x
        displacement, velocity = rigid_motion(self._sampler.points, q, w)
        return [body_field(self._sampler, displacement, velocity, np.zeros(len(self._sampler.points)))]

    # -------------------------------------------------------------- outputs
    def _compute_outputs(self, x: RigidState, t: float, substeps: int) -> Outputs:
        """The outputs at state x."""
        q, w, work = x
        pen = self.contact_energy(q)
        gap, _ = self.geometric_gap(q)
        kinetic = 0.5 * self.inertia * w * w
        potential = -self._mgd * math.cos(q)
        total = kinetic + potential + pen.energy
        # positional, in the order of Outputs' fields (half the cost of keywords, at every doStep):
        # time, theta, omega, gap, contact_force, energy_kinetic, energy_potential, energy_strain,
        # energy_contact, energy_total, energy_torque_work, stress_von_mises_max, solver_substeps, gap_min
        return Outputs(
            t,
            math.remainder(q, TWO_PI),
            w,
            gap,
            math.hypot(pen.fx, pen.fy),
            kinetic,
            potential,
            0.0,
            pen.energy,
            total,
            work,
            0.0,
            substeps,
            gap,
        )
