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
* contact  the penalty law of contact.py, summed over points on the head
  boundary in the deformed configuration.

Time integration is a discrete gradient scheme for H(z, p): kinetic energy is
split exactly into its p and q differences, and gravity + contact + strain get
Gonzalez's correction in the mass metric. Over every step H changes by exactly
the torque's work tau (d theta + beta . dq), so impacts neither gain nor lose
energy. Step sizes come from stepping.py, as for the other fidelities.

The step, the contact terms and the gap run in physics/reduced/reduced_kernel.c
(reduced/kernel.py) where a C compiler built it; the numpy forms here
are the same computation, the fallback and the kernel's test reference.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ..box import Box
from ..contact_time import ClosestPoint, contact_time_scale, effective_mass
from ..protocol import BodyField, ModelState, Outputs, check_state_fidelity, model_state, restore_advance_summary
from ..rigid import arc_contact as rigid_contact
from ..scene import Scene, refuse_deformable_wall, validate
from ..stepping import StepControl, SteppedModel
from .kernel import ReducedKernel, reduced_kernel
from .modes import ModalBasis, modal_basis
from .strain import LinearStrain, NeoHookeanStrain, uses_linear_strain

if TYPE_CHECKING:
    from ngsolve import CoefficientFunction, GridFunction

    from ..fields import VertexSampler

NEWTON_MAX_IT = 40
UPDATE_TOL = 1e-3  # and the last Newton update at most this share of the step's largest coordinate change
ENERGY_TOL = 1e-10  # accepted energy imbalance of one step, relative to the energies it moves
SCALE_BAND = (
    0.02  # m: contact scales consider head points at most this far behind the closest (penetrations are < 2 mm)
)
FAR_GAP = 0.01  # m: beyond this the stepper sees the head's bounding circle instead of every point
HEAD_GROUP = 8  # head points per run of the gap's and contact's exclusion test
STALL_TOL = 1e-9  # if Newton stalls at round-off, an imbalance up to this is still accepted

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


def strain_energy(scene: Scene, basis: ModalBasis) -> LinearStrain | NeoHookeanStrain:
    """The scene's strain energy: quadratic (stiff bodies) or Neo-Hookean (soft ones)."""
    if uses_linear_strain(scene):
        return LinearStrain(basis.omega2)
    return NeoHookeanStrain(scene, basis.phi, basis.omega2)


class _StepStart(NamedTuple):
    """What a step's Newton iterations share: the start state and the products of it they use
    (M(q0) = [[m00, c0^T], [c0, Id]], s0 = m00 - c0.c0), its potential energy and the torque's
    generalised force."""

    z0: np.ndarray
    p0: np.ndarray
    c0: np.ndarray
    s0: float
    c0c0: float
    c0p0: float  # c0 . p0_q
    p0p0: float  # p0_q . p0_q
    t00: float  # p0^T M(q0)^-1 p0
    S0: np.ndarray  # first mass moment at q0 (body frame)
    V0: float
    Q: np.ndarray


class _Iterate(NamedTuple):
    """One Newton iterate: its residual and end momentum, and what its Jacobian needs."""

    residual: np.ndarray
    p1: np.ndarray
    dz: np.ndarray
    zm: np.ndarray
    m00: float  # M(zm) = [[m00, c^T], [c, Id]]
    c: np.ndarray


class ReducedModel(SteppedModel[tuple]):
    """The reduced fidelity (fidelity "reduced").

    State: z = (theta, q), the momenta p and the torque work. wall.kind
    "deformable" is not offered (models.create rejects it); "none" or a zero
    contact stiffness switch contact off, `gap` still reports the geometric
    distance to the block.
    """

    fidelity = "reduced"

    def __init__(self, scene: Scene, basis: ModalBasis | None = None):
        self.scene = scene = validate(scene)  # with model.order resolved
        refuse_deformable_wall(scene, self.fidelity)
        self.basis = b = basis if basis is not None else modal_basis(scene)
        self.m = b.count
        self.n = self.m + 1
        self.inertia0 = b.inertia0
        self._g = scene.gravity
        self._hk = scene.pendulum.thickness * scene.contact.stiffness
        self.contact_on = scene.wall.kind == "rigid" and scene.contact.stiffness > 0.0
        self.block = blk = scene.block
        self._box = Box.of(blk)
        self._Q = np.concatenate([[1.0], b.torque_modes])  # generalised force of a unit torque
        self._head_flat = b.head_phi.reshape(-1, self.m)  # (2P, m): x and y rows interleaved
        self._phi_peak = np.max(np.linalg.norm(b.head_phi, axis=1), axis=0)  # (m,) largest head displacement per mode
        self._head_centre = (0.0, -scene.geometry.head_centre_depth)
        self._head_radius = float(np.max(np.linalg.norm(b.head_X - self._head_centre, axis=1)))
        self._group_head_points(b)
        self.control = StepControl.for_scene(scene)
        self._memo: dict[bytes, tuple] = {}
        zeros = (np.zeros(self.n), np.zeros((self.n, self.n)), np.zeros(2))
        for array in zeros:
            array.flags.writeable = False
        self._no_contact = (0.0, *zeros)
        self._closest_memo: tuple[tuple, ClosestPoint, np.ndarray] | None = None
        self._circle_memo: tuple[tuple, tuple[float, float]] | None = None
        self._parts_memo: tuple[np.ndarray, tuple[float, float, float]] | None = None
        self._jacobian_base: tuple[float, np.ndarray] | None = None
        self._identity = np.eye(self.n)
        self._identity_q = np.eye(self.m)
        self._gyro, self._a, self._two_a, self._omega2 = b.gyro, b.a, 2.0 * b.a, b.omega2
        self._first_moment, self._moment_modes = b.first_moment, b.moment_modes
        # (field, von Mises of it, the elements' integration points), built when first asked for
        self._stress: tuple[GridFunction, CoefficientFunction, Any] | None = None
        self._sampler: VertexSampler | None = None
        self._strain = strain_energy(scene, b)
        self._nonlinear_strain = not isinstance(self._strain, LinearStrain)  # the tangent changes with q
        self._kernel = self._bind_kernel()
        z0 = np.zeros(self.n)
        z0[0] = float(scene.theta0)
        p0 = self.mass_matrix(z0) @ np.concatenate([[float(scene.omega0)], np.zeros(self.m)])
        self.time = 0.0
        self._x = (z0, p0, 0.0)
        self._outputs = self._compute_outputs(self._x, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    def _group_head_points(self, b: ModalBasis) -> None:
        """The head points in runs of about HEAD_GROUP consecutive points (neighbours on the boundary),
        with each run's centre, radius and largest displacement per mode, for _candidates."""
        P = len(b.head_X)
        runs = np.array_split(np.arange(P), max(1, P // HEAD_GROUP))
        self._group_of_point = np.concatenate([np.full(len(r), k) for k, r in enumerate(runs)])
        self._group_start = np.cumsum([0, *map(len, runs)])  # run k holds points group_start[k] to [k + 1] - 1
        self._group_centre = np.array([b.head_X[r].mean(axis=0) for r in runs])
        self._group_radius = np.array(
            [np.max(np.linalg.norm(b.head_X[r] - c, axis=1)) for r, c in zip(runs, self._group_centre, strict=True)]
        )
        self._group_peak = np.array([np.max(np.linalg.norm(b.head_phi[r], axis=1), axis=0) for r in runs])  # (runs, m)
        self._head_X = b.head_X
        self._head_phi_pairs = b.head_phi.reshape(P, -1)  # (P, 2m): a point's x row, then its y row
        self._head_phi_rows = b.head_phi  # (P, 2, m)

    def _bind_kernel(self) -> ReducedKernel | None:
        """The compiled step (physics/reduced/reduced_kernel.c) on this model's data, or None (numpy forms)."""
        b, blk = self.basis, self.block
        return reduced_kernel(
            **self._strain.kernel_fields(),
            inertia0=self.inertia0,
            g=self._g,
            hk=self._hk,
            gyro=b.gyro,
            a=b.a,
            first_moment=b.first_moment,
            moment_modes=b.moment_modes,
            q_unit=self._Q,
            contact_on=int(self.contact_on),
            x_min=blk.x_min,
            x_max=blk.x_max,
            y_min=blk.y_min,
            y_max=blk.y_max,
            head_cx=self._head_centre[0],
            head_cy=self._head_centre[1],
            head_radius=self._head_radius,
            phi_peak=self._phi_peak,
            P=len(b.head_X),
            head_X=b.head_X,
            head_phi=b.head_phi,
            head_w=b.head_weights,
            groups=len(self._group_centre),
            group_start=self._group_start,
            group_centre=self._group_centre,
            group_radius=self._group_radius,
            group_peak=self._group_peak,
            max_it=NEWTON_MAX_IT,
            update_tol=UPDATE_TOL,
            energy_tol=ENERGY_TOL,
            stall_tol=STALL_TOL,
        )

    # ---------------------------------------------------------------- energies
    def _mass_parts(self, q: np.ndarray) -> tuple[float, np.ndarray, float]:
        """(m00, c, s): M(q) = [[m00, c^T], [c, Id]] and its Schur complement s = m00 - c.c. M is
        identity plus a border, so it is applied, inverted and averaged in O(n) (no factorisation)."""
        c = q @ self._gyro
        m00 = self.inertia0 + float(self._two_a @ q) + float(q @ q)
        return m00, c, m00 - float(c @ c)

    @staticmethod
    def _inverse_times(c: np.ndarray, s: float, p: np.ndarray) -> np.ndarray:
        """M(q)^-1 p from the parts of _mass_parts."""
        v = np.empty_like(p)
        v[0] = v0 = (p[0] - float(c @ p[1:])) / s
        v[1:] = p[1:] - v0 * c
        return v

    @staticmethod
    def _inverse_form(c: np.ndarray, s: float, p: np.ndarray) -> float:
        """p^T M(q)^-1 p."""
        pq = p[1:]
        return float(pq @ pq) + (p[0] - float(c @ pq)) ** 2 / s

    @staticmethod
    def _mass_times(m00: float, c: np.ndarray, v: np.ndarray) -> np.ndarray:
        """M(q) v."""
        w = v.copy()
        w[0] = m00 * v[0] + float(c @ v[1:])
        w[1:] += v[0] * c
        return w

    @staticmethod
    def _mean_inverse_solve(c0: np.ndarray, s0: float, c1: np.ndarray, s1: float, b: np.ndarray) -> np.ndarray:
        """x with 1/2 (M(q0)^-1 + M(q1)^-1) x = b. Each inverse is E + u u^T / s with E = diag(0, Id)
        and u = (1, -c), so the mean is Id plus a rank-3 term (the third removes e0 e0^T) and
        Woodbury leaves a 3x3 system [[A, B, 1], [B, D, 1], [1, 1, 0]] y = r, solved by hand."""
        bq = b[1:]
        r0, r1, r2 = b[0] - float(c0 @ bq), b[0] - float(c1 @ bq), b[0]
        c01 = float(c0 @ c1)
        A = 2.0 * s0 + 1.0 + float(c0 @ c0)
        B = 1.0 + c01
        D = 2.0 * s1 + 1.0 + float(c1 @ c1)
        y0 = (r0 - r1 - (B - D) * r2) / (A - 2.0 * B + D)
        y1 = r2 - y0
        y2 = r0 - A * y0 - B * y1
        x = np.empty_like(b)
        x[0] = b[0] - y0 - y1 - y2
        x[1:] = bq + y0 * c0 + y1 * c1
        return x

    def mass_matrix(self, z: np.ndarray) -> np.ndarray:
        m00, c, _ = self._mass_parts(z[1:])
        M = self._identity.copy()
        M[0, 0] = m00
        M[0, 1:] = c
        M[1:, 0] = c
        return M

    def _gravity_energy(self, z: np.ndarray) -> float:
        S = self._first_moment + self._moment_modes @ z[1:]
        return self._g * (math.sin(z[0]) * S[0] + math.cos(z[0]) * S[1])

    def _gravity(self, z: np.ndarray) -> np.ndarray:
        """Gravity's gradient in z."""
        g = self._g
        s, c = math.sin(z[0]), math.cos(z[0])
        S = self._first_moment + self._moment_modes @ z[1:]
        grad = np.empty(self.n)
        grad[0] = g * (c * S[0] - s * S[1])
        grad[1:] = (g * s) * self._moment_modes[0] + (g * c) * self._moment_modes[1]
        return grad

    def head_points(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(deformed positions (P, 2), body-frame positions (P, 2)) of the head sample points."""
        local = self.basis.head_X + (self._head_flat @ z[1:]).reshape(-1, 2)
        s, c = math.sin(z[0]), math.cos(z[0])
        return local @ np.array([[c, s], [-s, c]]), local

    def _head_circle(self, z: np.ndarray) -> tuple[float, float, float]:
        """(centre x, centre y, radius) of a circle that holds every head point at z."""
        s, c = math.sin(z[0]), math.cos(z[0])
        cx, cy = self._head_centre
        radius = self._head_radius + float(self._phi_peak @ np.abs(z[1:]))
        return c * cx - s * cy, s * cx + c * cy, radius

    def _may_touch(self, z: np.ndarray) -> bool:
        """Cheap exclusion: no head point can reach the block."""
        return rigid_contact.circle_may_touch(*self._head_circle(z), self.block)

    def _contact(self, z: np.ndarray) -> tuple:
        """(energy, gradient, Gauss-Newton Hessian, force on the body (2,)) of the wall contact at z.
        Out of reach of the block: one shared read-only zero result, nothing allocated."""
        if not (self.contact_on and self._may_touch(z)):
            return self._no_contact
        key = z.tobytes()
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        result = self._evaluate_contact(z)
        if len(self._memo) > 32:
            self._memo.clear()
        self._memo[key] = result
        return result

    def _evaluate_contact(self, z: np.ndarray) -> tuple:
        """_contact's terms summed over the head points inside the block. Inside, the signed distance
        is max(qx, qy) < 0 and its gradient the nearer face's normal (box.Box's
        values for such points, computed here without its general case)."""
        if self._kernel is not None:
            terms = self._kernel.contact(z)
            return self._no_contact if terms is None else terms
        candidates, world = self._candidates(z, 0.0, 0.0)
        blk = self.block
        px, py = world[:, 0], world[:, 1]
        local_inside = np.flatnonzero((px < blk.x_max) & (px > blk.x_min) & (py < blk.y_max) & (py > blk.y_min))
        if not local_inside.size:
            return self._no_contact
        inside = candidates[local_inside]
        pts = world[local_inside]
        ex, ey = pts[:, 0] - self._box.cx, pts[:, 1] - self._box.cy
        qx, qy = np.abs(ex) - self._box.hx, np.abs(ey) - self._box.hy
        x_face = qx >= qy
        depth = -np.maximum(qx, qy)
        normal = np.empty_like(pts)  # outward: the force direction
        normal[:, 0] = np.where(x_face, np.sign(ex), 0.0)
        normal[:, 1] = np.where(x_face, 0.0, np.sign(ey))
        w = self.basis.head_weights[inside] * self._hk
        energy = 0.5 * float(w @ (depth * depth))
        # d depth / dz = -n . dx/dz with dx/dtheta = J x, dx/dq = R phi
        s, c = math.sin(z[0]), math.cos(z[0])
        rn = normal @ np.array([[c, -s], [s, c]])  # rows: (R^T n)^T
        D = np.empty((len(inside), self.n))  # d depth / dz
        D[:, 0] = normal[:, 0] * pts[:, 1] - normal[:, 1] * pts[:, 0]
        D[:, 1:] = -np.matmul(rn[:, None, :], self._head_phi_rows[inside])[:, 0, :]
        grad = D.T @ (w * depth)
        hess = D.T @ (w[:, None] * D)
        force = (w * depth) @ normal
        return (energy, grad, hess, force)

    def potential_energy(self, z: np.ndarray) -> float:
        """Gravity + contact + strain energy."""
        gravity, contact, strain = self._potential_parts(z)
        return gravity + contact + strain

    def _potential_parts(self, z: np.ndarray) -> tuple[float, float, float]:
        """(gravity, contact, strain) energies at z, remembered for the last z: a step's accepted end
        point is the next step's start and the outputs' state (a pure function of z, so reusing it
        changes no bit)."""
        memo = self._parts_memo
        if memo is not None and memo[0] is z:
            return memo[1]
        parts = (self._gravity_energy(z), float(self._contact(z)[0]), self._strain.energy(z[1:]))
        self._parts_memo = (z, parts)
        return parts

    def potential_gradient(self, z: np.ndarray) -> np.ndarray:
        """Gradient of gravity + contact + strain in z."""
        grad = self._gravity(z) + self._contact(z)[1]
        grad[1:] += self._strain.gradient(z[1:])
        return grad

    def energy(self, x: tuple) -> float:
        z, p, _ = x
        _, c, s = self._mass_parts(z[1:])
        return 0.5 * self._inverse_form(c, s, p) + self.potential_energy(z)

    # ---------------------------------------------------------------- stepping
    def step(self, x: tuple, dt: float, torque: float) -> tuple | None:
        """One discrete-gradient step; None when Newton does not converge (the stepper halves dt).

        Converged: the energy imbalance within ENERGY_TOL and the last update within UPDATE_TOL of
        the step's largest change. The imbalance alone checks the residual along dz only: stopping on
        it alone left rubber's angle about 0.7 degree off the converged solution by 0.5 s. From the
        linearised predictor Newton contracts by ~3e-4 per iteration, so an update of 1e-3 leaves an
        error ~1e-6 of the step: over 0.6 s of rubber impacts the angle stays within 3e-4 degree and the
        gap within 1 micrometre of steps converged to updates of 1e-8 (docs/reduced.md)."""
        if self._kernel is not None:
            return self._compiled_step(x, dt, torque, self._kernel)
        start = self._start(x[0], x[1], torque)
        scale = 0.5 * abs(start.t00) + abs(start.V0) + 1e-12
        z1, K_strain = self._predict(start, dt)
        for it in range(NEWTON_MAX_IT):
            ev = self._residual(start, z1, dt)
            if not math.isfinite(float(ev.residual @ ev.residual)):
                return None
            delta = np.linalg.solve(self._jacobian(ev, K_strain, dt), ev.residual)
            z1 = z1 - delta
            p1, imbalance, dz = self._energy_balance(start, z1, dt)
            if not math.isfinite(imbalance):
                return None
            converged = float(np.max(np.abs(delta))) <= UPDATE_TOL * float(np.max(np.abs(dz)))
            if (converged and imbalance <= ENERGY_TOL * scale) or (
                it == NEWTON_MAX_IT - 1 and imbalance <= STALL_TOL * scale
            ):
                return (z1, p1, x[2] + float(start.Q @ dz))
        return None

    def _compiled_step(self, x: tuple, dt: float, torque: float, kernel: ReducedKernel) -> tuple | None:
        """step() in physics/reduced/reduced_kernel.c; the end's potential parts remembered for the outputs."""
        done = kernel.step(x[0], x[1], self.potential_energy(x[0]), dt, torque)
        if done is None:
            return None
        z1, p1, work, parts = done
        self._parts_memo = (z1, parts)
        return (z1, p1, x[2] + work)

    def _energy_balance(self, start: _StepStart, z1: np.ndarray, dt: float) -> tuple[np.ndarray, float, np.ndarray]:
        """(p1, |energy change - torque work|, dz) of the step ending at z1: dz . residual / dt without
        the residual's gradients (by construction dz . grad V = V1 - V0 and dq . grad T = t1 - t0, so
        it is T1 - T0 + V1 - V0 - Q . dz), half the cost of an iteration."""
        dz = z1 - start.z0
        q1 = z1[1:]
        c1 = q1 @ self._gyro
        c1c1 = float(c1 @ c1)
        s1 = self.inertia0 + float((self._two_a + q1) @ q1) - c1c1
        p1 = self._end_momentum(start, dz / dt, c1, s1, float(start.c0 @ c1), c1c1)
        kinetic = 0.5 * self._inverse_form(c1, s1, p1) - 0.5 * start.t00
        return p1, abs(kinetic + self.potential_energy(z1) - start.V0 - float(start.Q @ dz)), dz

    def _start(self, z0: np.ndarray, p0: np.ndarray, torque: float) -> _StepStart:
        q0, p0q = z0[1:], p0[1:]
        m00, c0, s0 = self._mass_parts(q0)
        c0p0, p0p0 = float(c0 @ p0q), float(p0q @ p0q)
        t00 = p0p0 + (p0[0] - c0p0) ** 2 / s0
        S0 = self._first_moment + self._moment_modes @ q0
        return _StepStart(z0, p0, c0, s0, m00 - s0, c0p0, p0p0, t00, S0, self.potential_energy(z0), torque * self._Q)

    def _predict(self, start: _StepStart, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(z1, the strain's tangent at z0): the midpoint rule linearised at z0,
        [(2 / dt^2) M0 + H0 / 2] dz = (2 / dt) p0 + F0, with F0 the forces at z0 (torque, gravity,
        contact, strain, centrifugal and Coriolis) and H0 the potentials' Hessian (gravity, contact
        Gauss-Newton, strain tangent). Stiff modes (omega dt >> 1) and the penalty contact are taken
        implicitly, so Newton starts close to the solution."""
        z0, q0, h = start.z0, start.z0[1:], 2.0 / (dt * dt)
        K_strain = self._strain.hessian(q0)
        v0 = self._inverse_times(start.c0, start.s0, start.p0)
        contact = self._contact(z0)
        force = start.Q - self._gravity(z0) - contact[1]
        w = float(v0[0])
        force[1:] += (w * w) * (self._a + q0) + w * (self._gyro @ v0[1:]) - self._strain.gradient(q0)
        g, s, c = self._g, math.sin(z0[0]), math.cos(z0[0])
        corner = h * (start.s0 + start.c0c0) - 0.5 * self._gravity_energy(z0)
        border = h * start.c0 + (0.5 * g * c) * self._moment_modes[0] - (0.5 * g * s) * self._moment_modes[1]
        rhs = (2.0 / dt) * start.p0 + force
        if contact is self._no_contact and not self._nonlinear_strain:
            # A is diagonal on the modes plus the border: eliminate theta, O(n)
            diagonal = h + 0.5 * self._omega2
            scaled = border / diagonal
            dth = (float(rhs[0]) - float(scaled @ rhs[1:])) / (corner - float(scaled @ border))
            dz = np.empty(self.n)
            dz[0] = dth
            dz[1:] = (rhs[1:] - dth * border) / diagonal
            return z0 + dz, K_strain
        A = (1.0 / dt) * self._constant_jacobian(K_strain, dt)
        if contact is not self._no_contact:
            A += 0.5 * contact[2]
        A[0, 0] += corner - h
        A[0, 1:] += border
        A[1:, 0] += border
        return z0 + np.linalg.solve(A, rhs), K_strain

    def _residual(self, start: _StepStart, z1: np.ndarray, dt: float) -> _Iterate:
        """The discrete-gradient equations at the end point z1 (momentum balance over the step),
        written on theta and q apart: every product of M(q) is a border of the identity."""
        z0, p0, c0 = start.z0, start.p0, start.c0
        dz = z1 - z0
        zm = z0 + 0.5 * dz
        q1, qm, dq, dth = z1[1:], zm[1:], dz[1:], float(dz[0])
        c1 = q1 @ self._gyro
        cm = 0.5 * (c0 + c1)
        c1c1, c0c1 = float(c1 @ c1), float(c0 @ c1)
        s1 = self.inertia0 + float((self._two_a + q1) @ q1) - c1c1
        mm = self.inertia0 + float((self._two_a + qm) @ qm)
        sm = mm - 0.25 * (start.c0c0 + 2.0 * c0c1 + c1c1)
        p1 = self._end_momentum(start, dz / dt, c1, s1, c0c1, c1c1)
        p10, p1q, p0q = float(p1[0]), p1[1:], p0[1:]
        c1p0, c1p1, c0p1, p1p1 = float(c1 @ p0q), float(c1 @ p1q), float(c0 @ p1q), float(p1q @ p1q)
        # kinetic energy's q difference: g(q) = 1/4 (p0^T A(q) p0 + p1^T A(q) p1), A = M^-1, at the midpoint
        va = (float(p0[0]) - 0.5 * (start.c0p0 + c1p0)) / sm
        vb = (p10 - 0.5 * (c0p1 + c1p1)) / sm
        k2 = va * va + vb * vb
        grad_T = -0.5 * (k2 * (self._a + qm) + self._gyro @ (va * p0q + vb * p1q - k2 * cm))
        dq2 = float(dq @ dq)
        if dq2 > 0.0:
            t0 = 0.25 * (start.t00 + p1p1 + (p10 - c0p1) ** 2 / start.s0)
            t1 = 0.25 * (start.p0p0 + (float(p0[0]) - c1p0) ** 2 / s1 + p1p1 + (p10 - c1p1) ** 2 / s1)
            grad_T += ((t1 - t0 - float(grad_T @ dq)) / dq2) * dq
        # gravity + contact + strain: Gonzalez's correction in the mass metric M(zm)
        g_th, g_q = self._potential_gradient_parts(zm, start.S0, q1)
        V1 = self.potential_energy(z1)
        cm_dq = float(cm @ dq)
        W0, Wq = mm * dth + cm_dq, dq + dth * cm
        denom = dth * W0 + cm_dq * dth + dq2
        k = (V1 - start.V0 - g_th * dth - float(g_q @ dq)) / denom if denom > 0.0 else 0.0
        residual = np.empty(self.n)
        residual[0] = p10 - float(p0[0]) + dt * (g_th + k * W0 - float(start.Q[0]))
        residual[1:] = p1q - p0q + dt * (g_q + k * Wq - start.Q[1:] + grad_T)
        return _Iterate(residual, p1, dz, zm, mm, cm)

    def _end_momentum(
        self, start: _StepStart, b: np.ndarray, c1: np.ndarray, s1: float, c0c1: float, c1c1: float
    ) -> np.ndarray:
        """p1 = 2 x - p0 with 1/2 (M(q0)^-1 + M(q1)^-1) x = b = dz / dt. Each inverse is
        E + u u^T / s with E = diag(0, Id) and u = (1, -c), so the mean is Id plus a rank-3 term (the
        third removes e0 e0^T) and Woodbury leaves a 3x3 system [[A, B, 1], [B, D, 1], [1, 1, 0]] y = r,
        solved by hand."""
        c0, bq, b0 = start.c0, b[1:], float(b[0])
        r0, r1 = b0 - float(c0 @ bq), b0 - float(c1 @ bq)
        A = 2.0 * start.s0 + 1.0 + start.c0c0
        B = 1.0 + c0c1
        D = 2.0 * s1 + 1.0 + c1c1
        y0 = (r0 - r1 - (B - D) * b0) / (A - 2.0 * B + D)
        y1 = b0 - y0
        y2 = r0 - A * y0 - B * y1
        p1 = np.empty(self.n)
        p1[0] = 2.0 * (b0 - y0 - y1 - y2) - float(start.p0[0])
        p1[1:] = 2.0 * bq - start.p0[1:] + (2.0 * y0) * c0 + (2.0 * y1) * c1
        return p1

    def _potential_gradient_parts(self, zm: np.ndarray, S0: np.ndarray, q1: np.ndarray) -> tuple[float, np.ndarray]:
        """(d/dtheta, d/dq) of gravity + contact + strain at the midpoint zm."""
        g = self._g
        s, c = math.sin(zm[0]), math.cos(zm[0])
        Sm = 0.5 * (S0 + self._first_moment + self._moment_modes @ q1)
        g_q = (g * s) * self._moment_modes[0] + (g * c) * self._moment_modes[1] + self._strain.gradient(zm[1:])
        g_th = g * (c * float(Sm[0]) - s * float(Sm[1]))
        contact = self._contact(zm)
        if contact is not self._no_contact:
            g_th += float(contact[1][0])
            g_q = g_q + contact[1][1:]
        return g_th, g_q

    def _jacobian(self, ev: _Iterate, K_strain: np.ndarray, dt: float) -> np.ndarray:
        """The residual's Jacobian in z1 to first order in the step: the mass matrix and its
        q-derivative (the moment of inertia grows with q, the gyroscopic coupling), the centrifugal
        and Coriolis forces of the kinetic energy, and the potentials' Hessians at the midpoint
        (gravity exact, contact Gauss-Newton, the strain's K_strain)."""
        zm, h, half = ev.zm, 2.0 / dt, 0.5 * dt
        jac = self._constant_jacobian(K_strain, dt)
        contact = self._contact(zm)
        if contact is not self._no_contact:
            jac += half * contact[2]
        g, w = self._g, float(ev.dz[0]) / dt
        s, c = math.sin(zm[0]), math.cos(zm[0])
        jac[0, 0] += h * (ev.m00 - 1.0) - half * self._gravity_energy(zm)
        symmetric = h * ev.c + (half * g * c) * self._moment_modes[0] - (half * g * s) * self._moment_modes[1]
        skew = (2.0 * w) * (self._a + zm[1:]) + self._gyro @ (ev.dz[1:] / dt)
        jac[0, 1:] += symmetric + skew
        jac[1:, 0] += symmetric - skew
        jac[1:, 1:] -= (2.0 * w) * self._gyro + (half * w * w) * self._identity_q
        return jac

    def _constant_jacobian(self, K_strain: np.ndarray, dt: float) -> np.ndarray:
        """A copy of (2 / dt) Id + dt / 2 K_strain on the modes, remembered for the linear strain
        (a pure function of dt there)."""
        if K_strain is not self._strain.linear_hessian:
            jac = (2.0 / dt) * self._identity
            jac[1:, 1:] += (0.5 * dt) * K_strain
            return jac
        if self._jacobian_base is None or self._jacobian_base[0] != dt:
            base = (2.0 / dt) * self._identity
            base[1:, 1:] += (0.5 * dt) * K_strain
            self._jacobian_base = (dt, base)
        return self._jacobian_base[1].copy()

    def contact_force(self, x: tuple) -> float:
        """Magnitude of the wall's force on the head at state x (N)."""
        return float(np.hypot(*self._contact(x[0])[3]))

    def contact_impulse(self, x0: tuple, x1: tuple, dt: float) -> np.ndarray:
        """The step's contact impulse (N.s, vector). The step applies the contact's share of the
        discrete gradient, Gc = gc(zm) + (C(z1) - C(z0) - gc(zm).dz) / (dz.M dz) M dz (the Gonzalez
        correction is linear in the energy, so the shares of gravity, contact and strain add up to
        the step's); Gc[0] is minus the contact moment about the pivot. The force is the midpoint's
        penalty force scaled to that moment, so the impulse's moment is exactly the scheme's
        contact angular impulse. A step whose midpoint is out of contact (the step onto the wall, aimed
        at the onset): the force at the end in contact, scaled the same way."""
        if not self.contact_on:
            return np.zeros(2)
        z0, z1 = x0[0], x1[0]
        dz, zm = z1 - z0, 0.5 * (z0 + z1)
        gcm = self._contact(zm)[1]
        Wdz = self.mass_matrix(zm) @ dz
        denom = float(dz @ Wdz)
        gc = gcm + ((self._contact(z1)[0] - self._contact(z0)[0] - gcm @ dz) / denom) * Wdz if denom > 0.0 else gcm
        for z in (zm, z1, z0):
            _, grad, _, force = self._contact(z)
            if grad[0] != 0.0:
                return dt * (gc[0] / grad[0]) * force
        return np.zeros(2)

    def _velocity(self, x: tuple) -> np.ndarray:
        z, p, _ = x
        _, c, s = self._mass_parts(z[1:])
        return self._inverse_times(c, s, p)

    def _closest(self, x: tuple) -> ClosestPoint:
        """The head point closest to the wall and its rate."""
        if self._closest_memo is not None and self._closest_memo[0] is x:
            return self._closest_memo[1]
        z = x[0]
        points, world, dist = self._near_points(z, SCALE_BAND)
        i = int(np.argmin(dist))
        px, py = float(world[i, 0]), float(world[i, 1])
        n_x, n_y = self._box.normal(px, py)
        v = self._velocity(x)
        s, c = math.sin(z[0]), math.cos(z[0])
        ex, ey = self.basis.head_phi[points[i]] @ v[1:]
        w = float(v[0])
        rate = n_x * (-w * py + c * ex - s * ey) + n_y * (w * px + s * ex + c * ey)
        result = ClosestPoint(world, dist, i, (n_x, n_y), rate)
        self._closest_memo = (x, result, points)  # the stepper asks for the gap, then the scales, of one state
        return result

    def _near_points(self, z: np.ndarray, band: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(indices, positions (k, 2), signed distances to the block (k,)) of the head points, in their
        order, leaving out only runs of points certainly more than `band` farther from the block than
        the closest point."""
        points, world = self._candidates(z, band, None)
        return points, world, self._signed_distances(world)

    def _candidates(self, z: np.ndarray, band: float, cutoff: float | None) -> tuple[np.ndarray, np.ndarray]:
        """(indices, positions (k, 2)) of the head points in the runs (_group_head_points) that may have
        a point within `cutoff` of the block (default: within `band` of the closest point). The distance
        is 1-Lipschitz, so a run whose centre is d from the block has its points within d +- (its
        radius + its largest modal displacement)."""
        s, c = math.sin(z[0]), math.cos(z[0])
        rotation = np.array([[c, s], [-s, c]])
        q = z[1:]
        reach = self._group_radius + self._group_peak @ np.abs(q)
        centre_gap = self._signed_distances(self._group_centre @ rotation)
        if cutoff is None:
            cutoff = float(np.min(centre_gap + reach)) + band
        points = np.flatnonzero((centre_gap - reach <= cutoff)[self._group_of_point])
        displacement = (self._head_phi_pairs[points].reshape(-1, self.m) @ q).reshape(-1, 2)
        return points, (self._head_X[points] + displacement) @ rotation

    def _signed_distances(self, world: np.ndarray) -> np.ndarray:
        """Signed distances of points (k, 2) to the block."""
        return self._box.distances(world[:, 0], world[:, 1])

    def _gap(self, z: np.ndarray) -> float:
        """The smallest signed distance of the head points to the block (the gap output)."""
        if self._kernel is not None:
            return self._kernel.gap(z)
        return float(np.min(self._near_points(z, 0.0)[2]))

    def _circle_gap(self, x: tuple) -> tuple[float, float]:
        """Gap of the head's bounding circle to the block and its rate: a lower bound of the gap.
        Remembered for the last state: the stepper asks for it two or three times per state."""
        if self._circle_memo is not None and self._circle_memo[0] is x:
            return self._circle_memo[1]
        cx, cy, radius = self._head_circle(x[0])
        d, qx, qy = rigid_contact.point_box(cx, cy, self.block)
        if d <= 0.0:  # the centre inside the block: no bound from the circle
            result = (-radius, 0.0)
        else:
            nx, ny = (cx - qx) / d, (cy - qy) / d
            result = (d - radius, float(self._velocity(x)[0]) * (-cy * nx + cx * ny))
        self._circle_memo = (x, result)
        return result

    def gap_and_rate(self, x: tuple) -> tuple[float, float]:
        """Gap and rate of the closest head point; far from the block (beyond FAR_GAP), the
        bounding circle's gap and rate instead: a lower bound, which is all the stepper needs there."""
        if not self.contact_on:
            return math.inf, 0.0
        circle_gap, circle_rate = self._circle_gap(x)
        if circle_gap > FAR_GAP:
            return circle_gap, circle_rate
        closest = self._closest(x)
        return closest.gap, closest.rate

    def contact_scales(self, x: tuple) -> tuple[float, float]:
        """Contact duration and depth from the rigid-body effective mass at the closest point (as fem/model.py)."""
        if not self.contact_on:
            return math.inf, 0.0
        circle_gap, circle_rate = self._circle_gap(x)
        if circle_gap > FAR_GAP and circle_gap + 2.0 * self.control.max_step * min(circle_rate, 0.0) > 0.0:
            return math.inf, 0.0  # no contact within the next two largest steps
        closest = self._closest(x)
        assert self._closest_memo is not None
        weights = self.basis.head_weights[self._closest_memo[2]]
        m_eff = effective_mass(self.inertia0, closest.arm, self.scene.geometry.head_centre_depth)
        dist = closest.gaps
        near = dist < dist[closest.index] + SCALE_BAND  # points further behind the closest one cannot take part
        return contact_time_scale(dist[near], weights[near], m_eff, closest.rate, self._hk)

    # ---------------------------------------------------------------- protocol
    def get_state(self) -> ModelState:
        z, p, work = self._x
        return model_state(
            self.fidelity, self.time, self._outputs, {"torque_work": work}, {"z": z.copy(), "p": p.copy()}
        )

    def set_state(self, state: ModelState) -> None:
        check_state_fidelity(state, self.fidelity)
        z, p = state.arrays.get("z"), state.arrays.get("p")
        if z is None or p is None or z.shape != (self.n,) or p.shape != (self.n,) or "torque_work" not in state.scalars:
            raise ValueError(f"state does not fit this reduced model ({self.m} modes: z and p of length {self.n})")
        x = (z.astype(float).copy(), p.astype(float).copy(), float(state.scalars["torque_work"]))
        if not (np.all(np.isfinite(x[0])) and np.all(np.isfinite(x[1])) and math.isfinite(x[2])):
            raise ValueError("reduced model state has non-finite values")
        self._x = x
        self.time = float(state.time)
        self._outputs = restore_advance_summary(state, self._compute_outputs(x, self.time, 0))
        self.last_min_gap = self._outputs.min_gap

    # ----------------------------------------------------------------- outputs
    def _compute_outputs(self, x: tuple, t: float, substeps: int) -> Outputs:
        z, p, work = x
        m00, c, s = self._mass_parts(z[1:])
        kinetic = 0.5 * self._inverse_form(c, s, p)
        potential, c_energy, strain = self._potential_parts(z)
        force = self._contact(z)[3]
        if self.contact_on and self._closest_memo is not None and self._closest_memo[0] is x:
            gap = self._closest_memo[1].gap
        else:
            gap = self._gap(z)
        vm = self.von_mises_max(z) if self.scene.model.compute_stress else 0.0
        return Outputs(
            time=t,
            theta=math.remainder(float(z[0]), 2.0 * math.pi),
            omega=float(p[0] / m00),
            gap=gap,
            contact_force=float(np.hypot(*force)),
            kinetic=kinetic,
            potential=potential,
            strain=strain,
            contact=c_energy,
            total=kinetic + potential + strain + c_energy,
            torque_work=work,
            von_mises_max=vm,
            substeps=substeps,
            min_gap=gap,
        )

    def von_mises_max(self, z: np.ndarray) -> float:
        """Largest von Mises stress of the modal displacement field (frame-invariant), on the FE mesh."""
        gf, cf, points = self._modal_stress()
        gf.vec.FV().NumPy()[:] = self.basis.phi @ z[1:]
        return float(np.max(cf(points)))

    def _modal_stress(self) -> tuple[GridFunction, CoefficientFunction, Any]:
        """(field of the modal displacement, its von Mises stress, the stress's sample points), built once."""
        if self._stress is None:
            import ngsolve as ngs

            from .. import material
            from .modes import fe_space

            mesh, V = fe_space(self.scene)
            gf = ngs.GridFunction(V)
            cf = material.von_mises_plane_stress(material.deformation_gradient(gf), *self.scene.pendulum.lame)
            self._stress = (gf, cf, mesh.MapToAllElements(ngs.IntegrationRule(ngs.TRIG, 4), ngs.VOL))
        return self._stress

    def fields(self) -> list[BodyField]:
        """Nodal fields of the modal field: x = R(theta) (X + w), w = phi q on the FE mesh, so the
        displacement is x - X, the velocity omega J x + R(theta) phi dq/dt (dz/dt = M(q)^-1 p), and
        the von Mises stress that of w (frame-invariant)."""
        from ..fields import VertexSampler, body_field

        gf, cf, _ = self._modal_stress()
        if self._sampler is None:
            self._sampler = VertexSampler(gf.space.mesh, "pendulum")
        sampler, (z, _, _) = self._sampler, self._x
        rate = self._velocity(self._x)
        gf.vec.FV().NumPy()[:] = self.basis.phi @ z[1:]
        w, von_mises = sampler.values(gf), sampler.values(cf)
        gf.vec.FV().NumPy()[:] = self.basis.phi @ rate[1:]
        w_rate = sampler.values(gf)
        c, s = math.cos(z[0]), math.sin(z[0])
        rot = np.array([[c, -s], [s, c]])
        x = (sampler.points + w) @ rot.T
        velocity = rate[0] * (x @ _J.T) + w_rate @ rot.T
        return [body_field(sampler, x - sampler.points, velocity, von_mises)]
