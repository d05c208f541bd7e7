"""The FE model's outputs of a state: energies, the rigid-body proxy angle and rate, gap, contact
force, stress; and the two per-step measures the step needs (torque work, smallest det F).

The linear functionals and matrices are assembled once; a state's u and v are
loaded into the space's evaluation fields.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import ngsolve as ngs
import numpy as np
from ngsolve import BND, VOL, BilinearForm, Cof, Grad, Id, InnerProduct, Integrate, IntegrationRule, LinearForm, x, y

from .. import material
from ..fields import VertexSampler, body_field
from ..protocol import BodyField, Outputs
from ..sparse import MatVec, scipy_matrix
from . import contact_law
from .head import HeadBoundary
from .mass_moments import BlockMass
from .rigid_contact import RigidContactKernel
from .space import FemSpace, FemState, StepInputs
from .wall import CLEAR_OF_FACE, WallContact

# The head's sample points are the Gauss points of the contact integrals' rule (fem/head.py): when the
# closest is farther from the block than this (1 nm, far above round-off), every penalty integrand is 0
CLEAR_OF_BLOCK = 1e-9


class FemOutputs:
    """Outputs of FE states (with the mass measures of the pendulum as meshed)."""

    def __init__(
        self,
        space: FemSpace,
        inputs: StepInputs,
        head: HeadBoundary,
        strain_energy: Callable[[np.ndarray], float] | None = None,
        compiled_contact: RigidContactKernel | None = None,
    ):
        """strain_energy(u): the step form's own strain energy of u (residual.ElasticTerms), where
        the model has one; else the energy density is integrated here, by the same rule. compiled_contact:
        the rigid-wall term's kernel (fem/rigid_contact.py), which then sums the contact force and impulse
        of the step control's tally at the head points instead of NGSolve's Integrate."""
        self._space, self._head, self._compiled = space, head, compiled_contact
        self._strain_energy = strain_energy
        sc, mesh, V = space.scene, space.mesh, space.V
        h, g = sc.pendulum.thickness, sc.gravity
        uu, vv = V.TnT()
        mass_form = BilinearForm(V)
        pot_form = LinearForm(V)
        for region, mat in space.bodies:
            mass_form += mat.rho * h * InnerProduct(uu, vv) * ngs.dx(region)
            pot_form += mat.rho * h * g * vv[1] * ngs.dx(region)
        self.mass = scipy_matrix(mass_form.Assemble().mat)
        self.l_pot = pot_form.Assemble().vec.FV().NumPy().copy()
        rho = sc.pendulum.rho
        dxp = ngs.dx("pendulum")
        self.mass_p = scipy_matrix(BilinearForm(rho * h * InnerProduct(uu, vv) * dxp).Assemble().mat)
        self.cross = scipy_matrix(BilinearForm(rho * h * (uu[0] * vv[1] - uu[1] * vv[0]) * dxp).Assemble().mat)
        self._mass_of, self._mass_p_of, self._cross_of = MatVec(self.mass), MatVec(self.mass_p), MatVec(self.cross)
        # the same forms in one pass over the scalar mass, where the matrices have its block form (else None)
        self._kinetic_mass, self._rotation_mass = BlockMass.of(self.mass), BlockMass.of(self.mass_p, self.cross)
        self.l_pos = LinearForm(rho * h * InnerProduct(space.pos, vv) * dxp).Assemble().vec.FV().NumPy().copy()
        self.l_rot = LinearForm(rho * h * (x * vv[1] - y * vv[0]) * dxp).Assemble().vec.FV().NumPy().copy()
        self.pot0 = sum(Integrate(mat.rho * h * g * y, mesh, definedon=mesh.Materials(r)) for r, mat in space.bodies)
        self.inertia0 = Integrate(rho * h * (x * x + y * y), mesh, definedon=mesh.Materials("pendulum"))
        self.total_mass = Integrate(rho * h, mesh, definedon=mesh.Materials("pendulum"))
        self.com_depth = -Integrate(rho * h * y, mesh, definedon=mesh.Materials("pendulum")) / self.total_mass
        self._build_fields(space, inputs)
        self._wall = WallContact(space) if space.wall_contact_on else None
        self._samplers: list[tuple[VertexSampler, ngs.CoefficientFunction]] | None = None  # built by fields()

    def _build_fields(self, space: FemSpace, inputs: StepInputs) -> None:
        """Coefficient functions of the evaluation fields gf_u (configuration) and gf_v."""
        sc, gf_u = space.scene, space.gf_u
        h = sc.pendulum.thickness
        # work of a unit torque's follower load at the configuration gf_u over the displacement gf_v
        N = ngs.specialcf.normal(2)
        unit_load = inputs.unit_torque_weight * (Cof(Id(2) + Grad(gf_u).Trace()) * N)
        # compiled (.Compile()): the integrals of the outputs cost a quarter as interpreted trees
        self._unit_torque_work_cf = InnerProduct(unit_load, space.gf_v).Compile()
        F = material.deformation_gradient(gf_u)
        C = material.right_cauchy_green(F)
        self._strain_cf = [(r, (h * material.energy_density(C, *mat.lame)).Compile()) for r, mat in space.bodies]
        self._von_mises_cf = material.von_mises_plane_stress(F, *sc.pendulum.lame)
        # det F at the volume integration points of the forms (psi depends on det C = det F^2 only,
        # so an inverted element has finite energy and Newton can converge to it: checked per step)
        self._det_F_cf = ngs.Det(F).Compile()
        self._volume_points = space.mesh.MapToAllElements(IntegrationRule(ngs.TRIG, 2 * sc.model.order), VOL)
        if space.contact_on:
            k = sc.contact.stiffness
            d, grad = contact_law.depth_and_gradient(space.pos + gf_u, sc.block)
            self._contact_energy_cf = (h * contact_law.penalty_energy(d, k)).Compile()
            self._contact_force_cf = (h * ngs.IfPos(d, k * d, 0.0) * (-grad)).Compile()
            # the energy-momentum form's contact term of a step from gf_u0 to gf_u (fem/schemes.py)
            self._gf_u0 = ngs.GridFunction(space.V)
            self._dg_force_cf = (
                h * contact_law.discrete_gradient_force(space.pos + self._gf_u0, space.pos + gf_u, sc.block, k)
            ).Compile()

    def torque_work_increment(self, u0: np.ndarray, u1: np.ndarray, torque: float) -> float:
        """Work of the follower load at the midpoint configuration over the step."""
        if torque == 0.0:
            return 0.0
        space = self._space
        space.gf_u.vec.FV().NumPy()[:] = 0.5 * (u0 + u1)
        space.gf_v.vec.FV().NumPy()[:] = u1 - u0
        # exact for the integrand's degree 2 order (Cof F, x and u); the default rule (order 5) lost
        # up to 15 % of the work when the rubber hinge edge deformed strongly (docs/notes/robustness.md)
        order = 2 * space.scene.model.order + 2
        return torque * float(
            Integrate(self._unit_torque_work_cf, space.mesh, BND, order=order, definedon=space.mesh.Boundaries("hinge"))
        )

    def min_det_F(self, u: np.ndarray) -> float:
        """Smallest det F of the displacement u at the integration points of every element."""
        self._space.gf_u.vec.FV().NumPy()[:] = u
        return float(np.min(self._det_F_cf(self._volume_points)))

    def rotation_angle(self, u: np.ndarray) -> float:
        """Best-fit rigid rotation of the displacement u about the pivot (rad)."""
        return math.atan2(float(self.l_rot @ u), self.inertia0 + float(self.l_pos @ u))

    def _rotation(self, u: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """Best-fit rigid rotation of the displacement, and angular velocity about the pivot."""
        theta = self.rotation_angle(u)
        if self._rotation_mass is not None:
            uMu, uCv = self._rotation_mass.square_and_cross(u, v)
        else:
            uMu, uCv = float(u @ self._mass_p_of(u)), float(u @ self._cross_of(v))
        ang_mom = float(self.l_rot @ v) - uCv  # u @ (cross v) = -int rho h (u x v): rows are test functions
        inertia = self.inertia0 + 2.0 * float(self.l_pos @ u) + uMu
        return theta, ang_mom / inertia

    def _contact(self, s: FemState, light: bool, energy: bool = True) -> tuple[float, float]:
        """(contact energy, contact force); light: the energy only (force 0) for the rigid wall; not energy:
        the force only (energy 0) for the rigid wall."""
        space, c_force = self._space, 0.0
        if self._wall is not None:
            return self._wall_contact(s)
        if not space.contact_on or self._head.closest_point(s).gap > CLEAR_OF_BLOCK:
            return 0.0, c_force  # no rule point in the block: the integrals are exactly zero
        mesh, order = space.mesh, space.contact_order
        head = mesh.Boundaries("head")
        space.gf_u.vec.FV().NumPy()[:] = s.u  # the integrands' field (of() sets it only where it is read)
        c_energy = float(Integrate(self._contact_energy_cf, mesh, BND, order=order, definedon=head)) if energy else 0.0
        if not light:
            fvec = Integrate(self._contact_force_cf, mesh, BND, order=order, definedon=head)
            c_force = float(math.hypot(fvec[0], fvec[1]))
        return c_energy, c_force

    def _wall_contact(self, s: FemState) -> tuple[float, float]:
        """(energy, force) against the meshed wall as the step forms count them; zero, without pairing,
        when the head is clear of the deformed face (every penalty integrand is 0 then)."""
        assert self._wall is not None
        if self._head.closest_point(s).gap > CLEAR_OF_FACE:
            return 0.0, 0.0
        return self._wall.energy_and_force(s.u)

    def contact_force_vector(self, u: np.ndarray) -> np.ndarray:
        """Resultant force of the wall on the pendulum at displacement u (N, vector). The meshed wall
        pushes along its face normal +x, with the magnitude the outputs report."""
        space = self._space
        if self._wall is not None:
            return np.array([self._wall.energy_and_force(u)[1], 0.0])
        if not space.contact_on:
            return np.zeros(2)
        if self._compiled is not None:
            p = self._head.distances(u)[0]
            return self._compiled.resultant(p, p)
        space.gf_u.vec.FV().NumPy()[:] = u
        mesh = space.mesh
        head = mesh.Boundaries("head")
        return np.array(Integrate(self._contact_force_cf, mesh, BND, order=space.contact_order, definedon=head))

    def contact_impulse(self, u0: np.ndarray, u1: np.ndarray, dt: float, trapezoid: bool) -> np.ndarray:
        """Contact impulse of a step u0 -> u1 (N.s, vector) as the scheme applies it: the discrete-gradient
        force of the energy-momentum form times dt, integrated by the form's own rule on the head; with
        `trapezoid` (the Newmark schemes, and the meshed wall, whose pairing force is not exposed) the
        mean of the end forces times dt."""
        space = self._space
        if trapezoid or not space.contact_on:
            return 0.5 * dt * (self.contact_force_vector(u0) + self.contact_force_vector(u1))
        if self._compiled is not None:
            return dt * self._compiled.resultant(self._head.distances(u0)[0], self._head.distances(u1)[0])
        self._gf_u0.vec.FV().NumPy()[:] = u0
        space.gf_u.vec.FV().NumPy()[:] = u1
        mesh = space.mesh
        head = mesh.Boundaries("head")
        force = Integrate(self._dg_force_cf, mesh, BND, order=space.contact_order, definedon=head)
        return dt * np.array(force)

    def fields(self, s: FemState) -> list[BodyField]:
        """Nodal displacement, velocity and von Mises stress of a state, the pendulum first (then the meshed wall)."""
        space = self._space
        if self._samplers is None:
            F = material.deformation_gradient(space.gf_u)
            self._samplers = [
                (VertexSampler(space.mesh, region), material.von_mises_plane_stress(F, *mat.lame))
                for region, mat in space.bodies
            ]
        space.gf_u.vec.FV().NumPy()[:] = s.u
        space.gf_v.vec.FV().NumPy()[:] = s.v
        return [
            body_field(sampler, sampler.values(space.gf_u), sampler.values(space.gf_v), sampler.values(vm))
            for sampler, vm in self._samplers
        ]

    def energies(self, s: FemState) -> tuple[float, float, float, float]:
        """(kinetic, potential, strain, contact) energy of a state, kept on it: the energy guard asks for a
        step's end, the advance's outputs then for the same state."""
        if s.energies is None:
            self.of(s, 0.0, 0, light=True)
        assert s.energies is not None
        return s.energies

    def _strain(self, u: np.ndarray) -> float:
        """The forms' own rule (2 order): the scheme conserves the strain energy integrated so; a finer
        rule differed by up to 3 % of the work in the crushed rubber hinge (docs/notes/robustness.md)."""
        if self._strain_energy is not None:
            return self._strain_energy(u)
        space, mesh = self._space, self._space.mesh
        space.gf_u.vec.FV().NumPy()[:] = u  # the integrands' field
        return sum(
            float(Integrate(cf, mesh, order=2 * space.scene.model.order, definedon=mesh.Materials(region)))
            for region, cf in self._strain_cf
        )

    def of(self, s: FemState, t: float, substeps: int, light: bool = False) -> Outputs:
        """All outputs of a state; light: the energies only (for the energy guard). The energies are kept on
        the state (`energies`) and taken from it when it has them."""
        space = self._space
        mesh, u, v = space.mesh, s.u, s.v
        c_force = 0.0
        if s.energies is None:
            mass = self._kinetic_mass
            kinetic = 0.5 * (mass.square(v) if mass is not None else float(v @ self._mass_of(v)))
            potential = self.pot0 + float(self.l_pot @ u)
            strain = self._strain(u)
            c_energy, c_force = self._contact(s, light)
            s.energies = (kinetic, potential, strain, c_energy)
        else:
            kinetic, potential, strain, c_energy = s.energies
            c_force = 0.0 if light else self._contact(s, False, energy=False)[1]
        theta, omega = (0.0, 0.0) if light else self._rotation(u, v)
        gap = self._head.closest_point(s).gap if not light else 0.0
        vm = 0.0
        if space.scene.model.compute_stress and not light:
            space.gf_u.vec.FV().NumPy()[:] = u
            vm = float(np.max(self._von_mises_cf(mesh.MapToAllElements(IntegrationRule(ngs.TRIG, 4), VOL))))
        total = kinetic + potential + strain + c_energy
        return Outputs(
            time=t,
            theta=theta,
            omega=omega,
            gap=gap,
            contact_force=c_force,
            energy_kinetic=kinetic,
            energy_potential=potential,
            energy_strain=strain,
            energy_contact=c_energy,
            energy_total=total,
            energy_torque_work=s.torque_work,
            stress_von_mises_max=vm,
            solver_substeps=substeps,
            gap_min=gap,
        )
