"""Full nonlinear FE pendulum: plane-stress Neo-Hookean, hinge, gravity, torque, wall contact.

Time integration is an energy-momentum midpoint scheme: the inertia is the
midpoint rule, the elastic stress is the discrete gradient of the strain
energy in C (material.averaged_pk2_stress pushed forward with F at the
midpoint), contact is the discrete-gradient penalty force of contact.py and
the follower torque acts at the midpoint configuration. Over every step the
change of kinetic + gravity + strain + contact energy equals the work of the
torque up to the Newton tolerance, so impacts neither gain nor lose energy.
Step sizes come from stepping.py.

`solver.scheme` = newmark_fixed or newmark_gap_rule replaces that scheme by
the seed tutorial's trapezoidal Newmark rule (beta 1/4, gamma 1/2; stress,
contact and torque at the step's end) with the seed's step-size rules
(seed_stepping.py), on the same mesh, material and contact law: kept only so
that the benchmarks can compare the seed's schemes with ours on equal terms.
"""
from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass, replace

import numpy as np
import ngsolve as ngs
from ngsolve import (BND, CF, VOL, BilinearForm, Cof, Grad, GridFunction, Id, InnerProduct, IntegrationRule,
                     Integrate, LinearForm, NumberSpace, Norm, Parameter, SEGM, VectorH1, specialcf, x, y)

from .. import contact as wall_contact
from .. import material
from ..geometry import make_mesh
from ..scene import Scene, validate
from .. import seed_stepping
from ..contact_time import ClosestPoint, contact_time_scale, effective_mass
from ..fe_boundary import head_points, hinge_torque_load
from ..stepping import StepControl, advance as advance_steps
from ..protocol import ModelState, Outputs, StepFailed, check_advance_args, restored_min_gap

NEWTON_MAX_IT = 12
DEFORMABLE_WALL_FACE_SIZE = 0.005  # m; contact zone on the wall face is ~5 mm wide
WALL_SEARCH_DISTANCE = 0.005  # m; ContactBoundary pairing radius
WALL_CONTACT_INTORDER = 6
# Compliant bodies: a step whose energy balance misses by more than this share of the energy in
# motion is rejected and halved. The discrete gradient's Gauss rule is exact only to the strain
# increment's 6th power; a crushing rubber hinge otherwise gained 15 % in 0.3 ms (docs/robustness.md).
STEP_ENERGY_TOLERANCE = 1e-3


@dataclass
class FemState:
    """Displacement, velocity (numpy copies) and the energy bookkeeping of one instant."""

    u: np.ndarray
    v: np.ndarray
    lam: np.ndarray
    torque_work: float
    a: np.ndarray | None = None  # acceleration, carried by the Newmark schemes only
    energy: tuple[float, float] | None = None  # (total, in motion), computed when the energy guard asks


@dataclass
class JacobianPoint:
    """The inputs the held Newton Jacobian was assembled at: kept with the state so
    that a restored model re-creates the very same matrix and continues bit-identically."""

    u0: np.ndarray
    v0: np.ndarray
    w: np.ndarray
    dt: float
    torque: float
    active: np.ndarray  # head elements with contact assembled (local indices)


class FemModel:
    """The full-fidelity model (fidelity "fem")."""

    fidelity = "fem"

    def __init__(self, scene: Scene, refine_like_seed: bool = False):
        self.scene = validate(scene)
        self._refine_like_seed = refine_like_seed
        ngs.SetNumThreads(scene.model.threads)
        self.control = StepControl.for_scene(scene)
        self._build()
        self.time = 0.0
        self._state = self._initial_state()
        self._substeps = 0
        self._outputs = self._compute_outputs(self._state, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    # ------------------------------------------------------------------ set-up
    def _build(self) -> None:
        sc = self.scene
        order = sc.model.order
        self.deformable_wall = sc.wall.kind == "deformable"
        block = sc.block if self.deformable_wall else None
        self.mesh = mesh = make_mesh(sc.geometry, sc.model.mesh_size, order, block=block,
                                     wall_face_size=DEFORMABLE_WALL_FACE_SIZE,
                                     refine_like_seed=self._refine_like_seed)
        h, g = sc.pendulum.thickness, sc.gravity
        self.V = V = VectorH1(mesh, order=order, dirichlet="wall_fixed" if self.deformable_wall else "")
        Q = NumberSpace(mesh, definedon=mesh.Boundaries("hinge"))
        self.X = X = V * Q * Q
        (u, q1, q2), (du, p1, p2) = X.TnT()
        self.w = GridFunction(X)
        self.u0 = GridFunction(V)
        self.v0 = GridFunction(V)
        self.a0 = GridFunction(V)  # Newmark schemes only
        self.newmark = sc.solver.scheme != "energy_momentum"
        self._energy_guard = not self.newmark and any(m.E / m.rho <= 1e5 for m in (sc.pendulum,))
        self.dt = Parameter(1e-3)
        self.torque_load = Parameter(0.0)
        # bodies: (region, material); the wall, when meshed, is a steel plate of the same thickness
        bodies = [("pendulum", sc.pendulum)]
        if self.deformable_wall:
            bodies.append(("wall", replace(sc.pendulum, E=sc.wall.E, nu=sc.wall.nu, rho=sc.wall.rho)))

        F0 = material.deformation_gradient(self.u0)
        F1 = material.deformation_gradient(u)
        Fm = 0.5 * (F0 + F1)
        C0, C1 = material.right_cauchy_green(F0), material.right_cauchy_green(F1)
        gvec = CF((0.0, -g))
        dt = self.dt
        a = BilinearForm(X)
        for region, mat in bodies:
            lam, mu = mat.lame
            # Gauss points of the discrete gradient (docs/robustness.md): for steel one point lost up to
            # 0.5 % of the energy after violent impacts (strains ~3e-3), two: 4e-4 J of 280 J; rubber at
            # 50 % strain drifted 9 % of a pulse's work in 40 ms with two points, 0.8 % with three
            dg_points = 2 if mat.E / mat.rho > 1e5 else 3
            if self.newmark:  # trapezoidal Newmark: a1 = 4/dt^2 (u1 - u0 - dt v0) - a0, equilibrium at the end
                inertia = (4.0 / (dt * dt)) * (u - self.u0 - dt * self.v0) - self.a0
                elastic = F1 * material.pk2_stress(C1, lam, mu)
            else:
                inertia = (2.0 / (dt * dt)) * (u - self.u0 - dt * self.v0)
                elastic = Fm * material.averaged_pk2_stress(C0, C1, lam, mu, dg_points)
            a += (mat.rho * h * InnerProduct(inertia, du)
                  + h * InnerProduct(elastic, Grad(du))
                  - mat.rho * h * InnerProduct(gvec, du)).Compile() * ngs.dx(region)
        # hinge: mean displacement of the hinge edge is zero (Lagrange multipliers q1, q2)
        a += (q1 * du[0] + q2 * du[1] + p1 * u[0] + p2 * u[1]) * ngs.ds("hinge")
        # follower torque: line load p(X) * Cof(F_mid) N on the hinge edge, moment = torque
        N = specialcf.normal(2)
        weight, self._torque_scale = hinge_torque_load(mesh, sc.geometry)
        if self.newmark:
            Fm_b = Id(2) + Grad(u).Trace()
        else:
            Fm_b = Id(2) + 0.5 * (Grad(u).Trace() + Grad(self.u0).Trace())
        a += -InnerProduct(self.torque_load * weight * (Cof(Fm_b) * N), du) * ngs.ds("hinge")
        # wall contact on the head's outer boundary
        k = sc.contact.stiffness
        self.contact_on = sc.wall.kind == "rigid" and k > 0
        pos = CF((x, y))
        self._contact_order = 2 * order + 40
        if self.contact_on:
            if self.newmark:  # the penalty force at the step's end
                d1, grad1 = wall_contact.depth_and_gradient(pos + u, sc.block)
                force = -ngs.IfPos(d1, k * d1, 0.0) * grad1
            else:
                force = wall_contact.discrete_gradient_force(pos + self.u0, pos + u, sc.block, k)
            # assembled only on head elements that can reach the block within the step
            self._active = ngs.BitArray(mesh.GetNE(BND))
            self._active.Clear()
            a += (-h * InnerProduct(force, du)).Compile() * ngs.ds(
                "head", bonus_intorder=self._contact_order - 2 * order, definedonelements=self._active)
        self._wall_contact = None
        if self.deformable_wall and k > 0:
            # penalty on the midpoint gap, integrated on the wall face; pairs found at the step start.
            # deformed=False: integrated on the reference face (the energy must not depend on the
            # configuration through the measure; with deformed=True an impact gained 9 % energy).
            # Phi(g) = k/2 g^2 is quadratic, so the midpoint force is the exact discrete gradient
            # while a point stays in contact; only the entry and exit of a point are approximate.
            cb = ngs.ContactBoundary(mesh.Boundaries("wall_face"), mesh.Boundaries("head"))
            um = u if self.newmark else 0.5 * (u + self.u0)
            um_head = u.Other() if self.newmark else 0.5 * (u.Other() + self.u0.Other())
            pen = InnerProduct((pos + um) - (pos.Other() + um_head), N)
            cb.AddEnergy(ngs.IfPos(pen, 2.0 * h * 0.5 * k * pen * pen, 0.0), deformed=False)
            self._wall_contact = cb
        self.a = a
        self.freedofs = X.FreeDofs()
        self._inverse = self._inverse_of = None
        self._inverse_nze = -1
        self._jac: JacobianPoint | None = None
        self._jac_ready = False
        self._active_local: set[int] = set()
        self._closest = None  # (state, closest-point answer) of the last state asked about
        self._res = self.w.vec.CreateVector()

        # linear functionals and matrices for outputs (assembled once)
        self.gf_u = GridFunction(V)
        self.gf_v = GridFunction(V)
        uu, vv = V.TnT()
        mass_form = BilinearForm(V)
        pot_form = LinearForm(V)
        for region, mat in bodies:
            mass_form += mat.rho * h * InnerProduct(uu, vv) * ngs.dx(region)
            pot_form += mat.rho * h * g * vv[1] * ngs.dx(region)
        self.mass = mass_form.Assemble().mat
        self.l_pot = pot_form.Assemble().vec.FV().NumPy().copy()
        rho = sc.pendulum.rho
        dxp = ngs.dx("pendulum")
        self.mass_p = BilinearForm(rho * h * InnerProduct(uu, vv) * dxp).Assemble().mat
        self.cross = BilinearForm(rho * h * (uu[0] * vv[1] - uu[1] * vv[0]) * dxp).Assemble().mat
        self.l_pos = LinearForm(rho * h * InnerProduct(pos, vv) * dxp).Assemble().vec.FV().NumPy().copy()
        self.l_rot = LinearForm(rho * h * (x * vv[1] - y * vv[0]) * dxp).Assemble().vec.FV().NumPy().copy()
        self.pot0 = sum(Integrate(mat.rho * h * g * y, mesh, definedon=mesh.Materials(r)) for r, mat in bodies)
        self.inertia0 = Integrate(rho * h * (x * x + y * y), mesh, definedon=mesh.Materials("pendulum"))
        self.total_mass = Integrate(rho * h, mesh, definedon=mesh.Materials("pendulum"))
        self.com_depth = -Integrate(rho * h * y, mesh, definedon=mesh.Materials("pendulum")) / self.total_mass
        # work of a unit torque's follower load at the configuration gf_u over the displacement gf_v
        unit_load = self._torque_scale * weight * (Cof(Id(2) + Grad(self.gf_u).Trace()) * N)
        self._unit_torque_work_cf = InnerProduct(unit_load, self.gf_v)
        F = material.deformation_gradient(self.gf_u)
        C = material.right_cauchy_green(F)
        self._strain_cf = [(r, h * material.energy_density(C, *mat.lame)) for r, mat in bodies]
        self._von_mises_cf = material.von_mises_plane_stress(F, *sc.pendulum.lame)
        # det F at the volume integration points of the forms (psi depends on det C = det F^2 only,
        # so an inverted element has finite energy and Newton can converge to it: checked per step)
        self._det_F_cf = ngs.Det(F)
        self._volume_points = mesh.MapToAllElements(IntegrationRule(ngs.TRIG, 2 * order), VOL)
        if self.contact_on:
            d, grad = wall_contact.depth_and_gradient(pos + self.gf_u, sc.block)
            self._contact_energy_cf = h * wall_contact.penalty_energy(d, k)
            self._contact_force_cf = h * ngs.IfPos(d, k * d, 0.0) * (-grad)
        # points on the head boundary for the gap: positions X + u evaluated vectorised
        head = head_points(mesh, self._contact_order)
        self._head_points = head.points
        self._head_X = pos(self._head_points)
        self._head_weights = head.weights
        self._head_elements = head.elements
        self._point_element = np.repeat(np.arange(len(head.elements)), len(head.rule))
        self._nV = V.ndof

    def _initial_state(self) -> FemState:
        th, om = self.scene.theta0, self.scene.omega0
        c, s = math.cos(th), math.sin(th)
        pendulum = self.mesh.Materials("pendulum")
        self.gf_u.vec[:] = 0.0
        self.gf_v.vec[:] = 0.0
        self.gf_u.Set(CF(((c - 1) * x - s * y, s * x + (c - 1) * y)), definedon=pendulum)
        self.gf_v.Set(CF((-om * (s * x + c * y), om * (c * x - s * y))), definedon=pendulum)
        state = FemState(self.gf_u.vec.FV().NumPy().copy(), self.gf_v.vec.FV().NumPy().copy(), np.zeros(2), 0.0)
        if self.newmark:
            state.a = self._consistent_acceleration(state)
        return state

    def _consistent_acceleration(self, xs: FemState) -> np.ndarray:
        """Newmark's start acceleration from the equations of motion (M a0 = f(u0), hinge held).

        The seed starts from a0 = 0, an error that the trapezoidal rule never damps;
        a consistent start gives its scheme the fairest comparison. The velocity
        term of the start (centripetal) is left out, as omega0 is 0 in the benchmarks."""
        nV = self._nV
        zero = np.zeros(nV)
        self._set_step_inputs(xs.u, zero, 1e-3, 0.0)
        self.a0.vec[:] = 0.0
        if self.contact_on:
            self._mark_active_contact(FemState(xs.u, zero, xs.lam, 0.0), 1e-3)
        if self._wall_contact is not None:
            self._wall_contact.Update(self.u0, self.a, intorder=WALL_CONTACT_INTORDER, maxdist=WALL_SEARCH_DISTANCE)
        wv = self.w.vec.FV().NumPy()
        wv[:nV], wv[nV:] = xs.u, 0.0
        self.a.Apply(self.w.vec, self._res)  # at u = u0, v0 = a0 = 0 the inertia term vanishes: static residual
        (u, q1, q2), (du, p1, p2) = self.X.TnT()
        h = self.scene.pendulum.thickness
        mass = BilinearForm(self.X)
        mass += (q1 * du[0] + q2 * du[1] + p1 * u[0] + p2 * u[1]) * ngs.ds("hinge")
        mass += self.scene.pendulum.rho * h * InnerProduct(u, du) * ngs.dx("pendulum")
        if self.deformable_wall:
            mass += self.scene.wall.rho * h * InnerProduct(u, du) * ngs.dx("wall")
        mass.Assemble()
        acc = (mass.mat.Inverse(self.freedofs, inverse="umfpack") * self._res).Evaluate().FV().NumPy()
        return -acc[:nV].copy()

    # ------------------------------------------------------------- one step
    def step(self, xs: FemState, dt: float, torque: float) -> FemState | None:
        """One energy-momentum midpoint step; None when Newton does not converge.

        Modified Newton: the Jacobian is kept from step to step while the step
        size stays the same and the iterations contract fast, and re-assembled
        (numeric re-factorisation only) when they do not."""
        nV = self._nV
        self._set_step_inputs(xs.u, xs.v, dt, torque)
        if self.contact_on:
            self._mark_active_contact(xs, dt)
        if self._wall_contact is not None:
            self._wall_contact.Update(self.u0, self.a, intorder=WALL_CONTACT_INTORDER, maxdist=WALL_SEARCH_DISTANCE)
        if self.newmark:
            self.a0.vec.FV().NumPy()[:] = xs.a
        for _attempt in range(2):
            u1 = self._solve(xs, dt, torque)
            if u1 is None:
                return None
            if not self.contact_on or self._contact_set_covers(u1):
                break
        else:
            return None
        if self.min_det_F(u1) <= 0.0:
            return None  # an element turned inside out: rejected, the stepper halves the step (or StepFailed)
        v1 = 2.0 / dt * (u1 - xs.u) - xs.v
        a1 = 2.0 / dt * (v1 - xs.v) - xs.a if self.newmark else None
        work = self._torque_work_increment(xs.u, u1, torque)
        x1 = FemState(u1, v1, self.w.vec.FV().NumPy()[nV:].copy(), xs.torque_work + work, a1)
        if self._energy_guard:
            (e0, m0), (e1, m1) = self._energy_of(xs), self._energy_of(x1)
            if abs(e1 - e0 - work) > STEP_ENERGY_TOLERANCE * (max(m0, m1) + abs(work)):
                return None  # the Gauss rule of the discrete gradient is off: a smaller step
        return x1

    def _energy_of(self, s: FemState) -> tuple[float, float]:
        """(total energy, kinetic + strain + contact energy) of a state, counted as the outputs count them; cached."""
        if s.energy is None:
            out = self._compute_outputs(s, 0.0, 0, light=True)
            s.energy = (out.total, out.kinetic + out.strain + out.contact)
        return s.energy

    def min_det_F(self, u: np.ndarray | None = None) -> float:
        """Smallest det F at the integration points of every element (of the current state by default)."""
        self.gf_u.vec.FV().NumPy()[:] = self._state.u if u is None else u
        return float(np.min(self._det_F_cf(self._volume_points)))

    def _set_step_inputs(self, u0: np.ndarray, v0: np.ndarray, dt: float, torque: float) -> None:
        self.dt.Set(dt)
        self.torque_load.Set(torque * self._torque_scale)
        self.u0.vec.FV().NumPy()[:] = u0
        self.v0.vec.FV().NumPy()[:] = v0

    def _factorise(self) -> None:
        """Assemble the Jacobian at the current inputs and w, and factorise it."""
        self.a.AssembleLinearization(self.w.vec)
        mat = self.a.mat
        if self._inverse is None or mat is not self._inverse_of or mat.nze != self._inverse_nze:
            # new matrix or new graph (contact pairs of the deformable wall): full factorisation
            self._inverse = mat.Inverse(self.freedofs, inverse="umfpack")
            self._inverse_of, self._inverse_nze = mat, mat.nze
        else:
            self._inverse.Update()  # same graph: numeric re-factorisation only

    def _refresh_jacobian(self, xs: FemState, dt: float, torque: float) -> None:
        self._jac = JacobianPoint(xs.u.copy(), xs.v.copy(), self.w.vec.FV().NumPy().copy(), dt, torque,
                                  np.array(sorted(self._active_local), dtype=int))
        self._factorise()
        self._jac_ready = True

    def _rebuild_held_jacobian(self, xs: FemState, dt: float, torque: float) -> None:
        """Re-create the held Jacobian (after set_state) at its recorded inputs, then restore the step's."""
        jp = self._jac
        w_now = self.w.vec.FV().NumPy().copy()
        active_now = np.array(sorted(self._active_local), dtype=int)
        self._set_step_inputs(jp.u0, jp.v0, jp.dt, jp.torque)
        if self.contact_on:
            self._set_active(jp.active)
        if self._wall_contact is not None:
            self._wall_contact.Update(self.u0, self.a, intorder=WALL_CONTACT_INTORDER, maxdist=WALL_SEARCH_DISTANCE)
        self.w.vec.FV().NumPy()[:] = jp.w
        self._factorise()
        self._jac_ready = True
        self._set_step_inputs(xs.u, xs.v, dt, torque)
        if self.contact_on:
            self._set_active(active_now)
        if self._wall_contact is not None:
            self._wall_contact.Update(self.u0, self.a, intorder=WALL_CONTACT_INTORDER, maxdist=WALL_SEARCH_DISTANCE)
        self.w.vec.FV().NumPy()[:] = w_now

    def _solve(self, xs: FemState, dt: float, torque: float) -> np.ndarray | None:
        nV = self._nV
        wv = self.w.vec.FV().NumPy()
        wv[:nV] = xs.u + dt * xs.v
        wv[nV:] = xs.lam
        res = self._res
        scale = max(float(np.max(np.abs(dt * xs.v))), 1e-12)
        if self._jac is not None and not self._jac_ready:
            self._rebuild_held_jacobian(xs, dt, torque)
        # a different step size needs a new Jacobian; round-off in dt (masters compute t + h differently) does not
        refresh = self._jac is None or abs(self._jac.dt - dt) > 1e-9 * dt
        last = math.inf
        for _ in range(NEWTON_MAX_IT):
            if refresh:
                self._refresh_jacobian(xs, dt, torque)
                refresh = False
            self.a.Apply(self.w.vec, res)
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

    def _mark_active_contact(self, xs: FemState, dt: float) -> None:
        """Activate contact on head elements whose points could reach the block during the step."""
        p = self._head_positions(xs.u)
        dist, _, _ = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self.scene.block)
        self.gf_v.vec.FV().NumPy()[:] = xs.v
        speed = np.hypot(*self.gf_v(self._head_points).T)
        reach = 3.0 * float(np.max(speed)) * dt + 1e-4
        self._set_active(np.unique(self._point_element[dist < reach]))

    def _set_active(self, elements: np.ndarray) -> None:
        self._active.Clear()
        for e in self._head_elements[elements]:
            self._active.Set(int(e))
        self._active_local = set(int(i) for i in elements)

    def _contact_set_covers(self, u1: np.ndarray) -> bool:
        """True if every head point inside the block at the step's end was in the active set; else widen it."""
        p = self._head_positions(u1)
        dist, _, _ = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self.scene.block)
        touching = set(int(i) for i in np.unique(self._point_element[dist < 0.0]))
        missing = touching - self._active_local
        if not missing:
            return True
        self._set_active(np.array(sorted(self._active_local | missing), dtype=int))
        return False

    def _torque_work_increment(self, u0: np.ndarray, u1: np.ndarray, torque: float) -> float:
        """Work of the follower load at the midpoint configuration over the step (form built once in _build)."""
        if torque == 0.0:
            return 0.0
        self.gf_u.vec.FV().NumPy()[:] = 0.5 * (u0 + u1)
        self.gf_v.vec.FV().NumPy()[:] = u1 - u0
        # exact for the integrand's degree 2 order (Cof F, x and u); the default rule (order 5) lost
        # up to 15 % of the work when the rubber hinge edge deformed strongly (docs/robustness.md)
        return torque * float(Integrate(self._unit_torque_work_cf, self.mesh, BND, order=2 * self.scene.model.order + 2,
                                        definedon=self.mesh.Boundaries("hinge")))

    # ------------------------------------------------------ contact geometry
    def _head_positions(self, u: np.ndarray) -> np.ndarray:
        self.gf_u.vec.FV().NumPy()[:] = u
        return self._head_X + self.gf_u(self._head_points)

    def _wall_face_shift(self, p: np.ndarray) -> np.ndarray:
        """Displacement of the deformable wall at the face points level with head points (zero if rigid)."""
        shift = np.zeros_like(p)
        if not self.deformable_wall:
            return shift
        b = self.scene.block
        near = (p[:, 0] < b.x_max + 0.01) & (p[:, 1] > b.y_min) & (p[:, 1] < b.y_max)
        if np.any(near):
            ys = p[near, 1]
            pts = self.mesh(np.full(ys.shape, b.x_max - 1e-9), ys)
            shift[near] = self.gf_u(pts)
        return shift

    def _deformable_wall_contact(self, u: np.ndarray) -> tuple[float, float]:
        """Contact energy and force against the deformed wall face, integrated on the head points."""
        p = self._head_positions(u)
        shift = self._wall_face_shift(p)
        b, h, k = self.scene.block, self.scene.pendulum.thickness, self.scene.contact.stiffness
        level = (p[:, 1] > b.y_min) & (p[:, 1] < b.y_max)
        pen = np.where(level, np.maximum(b.x_max + shift[:, 0] - p[:, 0], 0.0), 0.0)
        return 0.5 * h * k * float(self._head_weights @ (pen * pen)), h * k * float(self._head_weights @ pen)

    def _closest_point(self, xs: FemState) -> ClosestPoint:
        """The head point closest to the (deformed) wall and its rate.

        The stepper asks for the gap and then for the contact scales of the same
        state; the last answer is kept so the boundary is evaluated once."""
        if self._closest is not None and self._closest[0] is xs:
            return self._closest[1]
        p = self._head_positions(xs.u)
        if self.deformable_wall:
            p = p - self._wall_face_shift(p)
        dist, nx, ny = wall_contact.box_signed_distance(p[:, 0], p[:, 1], self.scene.block)
        i = int(np.argmin(dist))
        self.gf_v.vec.FV().NumPy()[:] = xs.v
        vel = self.gf_v(self._head_points)[i]
        result = ClosestPoint(p, dist, i, (float(nx[i]), float(ny[i])), float(nx[i] * vel[0] + ny[i] * vel[1]))
        self._closest = (xs, result)
        return result

    def gap_and_rate(self, xs: FemState) -> tuple[float, float]:
        closest = self._closest_point(xs)
        return closest.gap, closest.rate

    def contact_scales(self, xs: FemState) -> tuple[float, float]:
        """Contact duration and depth estimated from the rigid-body effective mass at the closest point."""
        if not self.contact_on and self._wall_contact is None:
            return math.inf, 0.0
        closest = self._closest_point(xs)
        m_eff = effective_mass(self.inertia0, closest.arm, self.scene.geometry.head_centre_depth)
        return contact_time_scale(closest.gaps, self._head_weights, m_eff, closest.rate,
                                  self.scene.contact.stiffness * self.scene.pendulum.thickness)

    # ---------------------------------------------------------------- protocol
    def advance(self, t_end: float, torque: float) -> Outputs:
        check_advance_args(self.time, t_end, torque)
        torque = float(torque)
        held = self._jac
        try:
            with ngs.TaskManager() if self.scene.model.threads > 1 else nullcontext():
                if self.newmark:
                    result = seed_stepping.advance(self, self._state, self.time, t_end, torque,
                                                   self.scene.solver.scheme, self.control)
                else:
                    result = advance_steps(self, self._state, self.time, t_end, torque, self.control)
        except StepFailed:
            # the held Jacobian is part of the state: put back the one from before the failed
            # advance, so that a retry continues exactly as if it had never been tried
            self._jac, self._jac_ready = held, False
            raise
        self._state = result.state
        self.time = float(t_end)
        self.last_min_gap = result.min_gap
        self._outputs = self._compute_outputs(self._state, self.time, result.substeps)
        self._outputs.min_gap = min(result.min_gap, self._outputs.gap)
        return self._outputs

    def outputs(self) -> Outputs:
        return self._outputs

    def get_state(self) -> ModelState:
        s = self._state
        scalars = {"torque_work": s.torque_work, "substeps": float(self._outputs.substeps),
                   "last_min_gap": self.last_min_gap}
        arrays = {"u": s.u.copy(), "v": s.v.copy(), "lam": s.lam.copy()}
        if s.a is not None:
            arrays["a"] = s.a.copy()
        if self._jac is not None:
            jp = self._jac
            scalars.update(jac_dt=jp.dt, jac_torque=jp.torque)
            arrays.update(jac_u0=jp.u0.copy(), jac_v0=jp.v0.copy(), jac_w=jp.w.copy(), jac_active=jp.active.copy())
        return ModelState("fem", self.time, scalars, arrays)

    def set_state(self, state: ModelState) -> None:
        if state.fidelity != "fem" or state.arrays.get("u", np.empty(0)).shape != (self._nV,):
            raise ValueError(f"state of fidelity {state.fidelity!r} does not fit this fem model ({self._nV} displacement dofs)")
        arr, sc = state.arrays, state.scalars
        if self.newmark != ("a" in arr):
            raise ValueError("state of another time integration scheme (solver.scheme) than this fem model's")
        self._state = FemState(arr["u"].copy(), arr["v"].copy(), arr["lam"].copy(), sc["torque_work"],
                               arr["a"].copy() if self.newmark else None)
        if "jac_w" in arr:
            self._jac = JacobianPoint(arr["jac_u0"].copy(), arr["jac_v0"].copy(), arr["jac_w"].copy(),
                                      sc["jac_dt"], sc["jac_torque"], arr["jac_active"].astype(int))
        else:
            self._jac = None
        self._jac_ready = False
        self.time = state.time
        self._outputs = self._compute_outputs(self._state, self.time, int(state.scalars.get("substeps", 0)))
        self.last_min_gap = self._outputs.min_gap = restored_min_gap(state, self._outputs)

    # ----------------------------------------------------------------- outputs
    def _compute_outputs(self, s: FemState, t: float, substeps: int, light: bool = False) -> Outputs:
        """All outputs of a state; light: the energies only (for the energy guard)."""
        u, v = s.u, s.v
        self.gf_u.vec.FV().NumPy()[:] = u
        self.gf_v.vec.FV().NumPy()[:] = v
        Mv = (self.mass * self.gf_v.vec).Evaluate().FV().NumPy()
        kinetic = 0.5 * float(v @ Mv)
        potential = self.pot0 + float(self.l_pot @ u)
        theta = omega = 0.0
        if not light:
            # best-fit rigid rotation of the displacement, and angular velocity about the pivot
            s_num = float(self.l_rot @ u)
            c_num = self.inertia0 + float(self.l_pos @ u)
            theta = math.atan2(s_num, c_num)
            Cv = (self.cross * self.gf_v.vec).Evaluate().FV().NumPy()
            Mu = (self.mass_p * self.gf_u.vec).Evaluate().FV().NumPy()
            ang_mom = float(self.l_rot @ v) - float(u @ Cv)  # u @ (cross v) = -int rho h (u x v): rows are test functions
            inertia = self.inertia0 + 2.0 * float(self.l_pos @ u) + float(u @ Mu)
            omega = ang_mom / inertia
        # the forms' own rule (2 order): the scheme conserves the strain energy integrated so; a finer
        # rule differed by up to 3 % of the work in the crushed rubber hinge (docs/robustness.md)
        strain = sum(float(Integrate(cf, self.mesh, order=2 * self.scene.model.order,
                                     definedon=self.mesh.Materials(region))) for region, cf in self._strain_cf)
        c_force = 0.0
        if self._wall_contact is not None:
            c_energy, c_force = self._deformable_wall_contact(u)
        elif self.contact_on:
            mat = self.mesh.Boundaries("head")
            c_energy = float(Integrate(self._contact_energy_cf, self.mesh, BND, order=self._contact_order, definedon=mat))
            if not light:
                fvec = Integrate(self._contact_force_cf, self.mesh, BND, order=self._contact_order, definedon=mat)
                c_force = float(math.hypot(fvec[0], fvec[1]))
        else:
            c_energy = 0.0
        gap = self.gap_and_rate(s)[0] if not light else 0.0
        vm = 0.0
        if self.scene.model.compute_stress and not light:
            self.gf_u.vec.FV().NumPy()[:] = u
            vm = float(np.max(self._von_mises_cf(self.mesh.MapToAllElements(IntegrationRule(ngs.TRIG, 4), VOL))))
        total = kinetic + potential + strain + c_energy
        return Outputs(time=t, theta=theta, omega=omega, gap=gap, contact_force=c_force, kinetic=kinetic,
                       potential=potential, strain=strain, contact=c_energy, total=total,
                       torque_work=s.torque_work, von_mises_max=vm, substeps=substeps, min_gap=gap)

