"""Reduced pendulum (fidelity "reduced"): exact rotation about the hinge plus a few elastic modes.

Floating frame of reference: a material point X of the pendulum is at

    x = R(theta) (X + sum_j phi_j(X) q_j)

with a mass-normalised basis phi_j of the hinged pendulum's elastic motion
(modes.py: eigenmodes and static corrections for the loads). The modes are
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
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import rigid_contact
from ..contact_time import ClosestPoint, contact_time_scale, effective_mass
from ..modes import ModalBasis, modal_basis
from ..protocol import BodyField, ModelState, Outputs, last_advance_scalars, restore_last_advance, restored_min_gap
from ..scene import Scene, refuse_deformable_wall, validate
from ..stepping import StepControl, SteppedModel

if TYPE_CHECKING:
    from ngsolve import CoefficientFunction, GridFunction

    from ..fields import VertexSampler

NEWTON_MAX_IT = 40
TANGENT_AFTER = 4  # Newton iterations on the linear modal stiffness before the strain's tangent is assembled
ENERGY_TOL = 1e-10  # accepted energy imbalance of one step, relative to the energies it moves
SCALE_BAND = (
    0.02  # m: contact scales consider head points at most this far behind the closest (penetrations are < 2 mm)
)
FAR_GAP = 0.01  # m: beyond this the stepper sees the head's bounding circle instead of every point
STALL_TOL = 1e-9  # if Newton stalls at round-off, an imbalance up to this is still accepted

STIFF_WAVE_SPEED2 = 1e5  # m^2/s^2: E / rho above this strains stay ~1e-6 and the energy is quadratic (see below)

_J = np.array([[0.0, -1.0], [1.0, 0.0]])


def uses_linear_strain(scene: Scene) -> bool:
    """Stiff bodies (steel: strains ~1e-6) use the quadratic modal strain energy: exact to O(strain^3),
    while evaluating the Neo-Hookean energy there would lose ~4 digits to cancellation
    (tr C - 2 - 2 ln J is O(strain^2) from O(strain) terms). Soft bodies use the Neo-Hookean energy."""
    return scene.pendulum.E / scene.pendulum.rho > STIFF_WAVE_SPEED2


class LinearStrain:
    """1/2 sum omega_j^2 q_j^2: linear elasticity in the rotating frame."""

    def __init__(self, omega2: np.ndarray):
        self.omega2 = omega2
        self.linear_hessian = np.diag(omega2)

    def energy(self, q: np.ndarray) -> float:
        return 0.5 * float(self.omega2 @ (q * q))

    def gradient(self, q: np.ndarray) -> np.ndarray:
        return self.omega2 * q

    def hessian(self, q: np.ndarray) -> np.ndarray:
        return self.linear_hessian


class NeoHookeanStrain:
    """The FE model's Neo-Hookean energy of the modal displacement field w = phi q, integrated on
    the FE mesh (rotation-invariant, so the floating frame stays exact at large strains).

    The modes' displacement gradients are sampled once at the mesh's quadrature points; an
    evaluation is then F = I + G q and the energy law at those points, in numpy: the reduced
    model's hot loop never calls into the FE assembly."""

    def __init__(self, scene: Scene, phi: np.ndarray, omega2: np.ndarray):
        import ngsolve as ngs

        from ..modes import fe_space

        mesh, V = fe_space(scene)
        rule = ngs.IntegrationRule(ngs.TRIG, 2 * scene.model.order)
        points = mesh.MapToAllElements(rule, ngs.VOL)
        jac_det = ngs.Det(ngs.specialcf.JacobianMatrix(2))(points).ravel()
        self._weights = scene.pendulum.thickness * np.abs(jac_det) * np.tile([ip.weight for ip in rule], mesh.ne)
        gf = ngs.GridFunction(V)
        grad = ngs.Grad(gf)
        G = np.empty((len(self._weights), 4, phi.shape[1]))  # rows d wx/dx, d wx/dy, d wy/dx, d wy/dy
        for j in range(phi.shape[1]):
            gf.vec.FV().NumPy()[:] = phi[:, j]
            G[..., j] = np.asarray(grad(points)).reshape(-1, 4)
        self._G = G.reshape(-1, phi.shape[1])
        self._lam, self._mu = scene.pendulum.lame
        self.linear_hessian = np.diag(omega2)  # the tangent at q = 0

    def _kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        F = (self._G @ q).reshape(-1, 2, 2)
        F[:, 0, 0] += 1.0
        F[:, 1, 1] += 1.0
        J = F[:, 0, 0] * F[:, 1, 1] - F[:, 0, 1] * F[:, 1, 0]
        return F, J

    def energy(self, q: np.ndarray) -> float:
        F, J = self._kinematics(q)
        with np.errstate(invalid="ignore", divide="ignore"):
            log_j = np.log(J)  # nan for an inverted point: the step fails and is retried smaller
        density = 0.5 * self._mu * (np.einsum("pij,pij->p", F, F) - 2.0 - 2.0 * log_j) + 0.5 * self._lam * log_j * log_j
        return float(self._weights @ density)

    @staticmethod
    def _inverse_and_log(F: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """F^-1 and ln J at every point (nan where an element is inverted)."""
        inv = np.empty_like(F)
        inv[:, 0, 0], inv[:, 0, 1] = F[:, 1, 1], -F[:, 0, 1]
        inv[:, 1, 0], inv[:, 1, 1] = -F[:, 1, 0], F[:, 0, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            inv /= J[:, None, None]
            return inv, np.log(J)

    def gradient(self, q: np.ndarray) -> np.ndarray:
        F, J = self._kinematics(q)
        inv, log_j = self._inverse_and_log(F, J)
        inv_t = inv.transpose(0, 2, 1)
        P = self._mu * (F - inv_t) + (self._lam * log_j)[:, None, None] * inv_t  # first Piola-Kirchhoff
        return ((self._weights[:, None, None] * P).reshape(-1)) @ self._G

    def hessian(self, q: np.ndarray) -> np.ndarray:
        """Exact tangent: sum_p w_p G_p^T A_p G_p with the Neo-Hookean elasticity tensor
        A_iJkL = mu d_ik d_JL + (mu - lam ln J) Fi_Li Fi_Jk + lam Fi_Ji Fi_Lk (Fi = F^-1)."""
        F, J = self._kinematics(q)
        inv, log_j = self._inverse_and_log(F, J)
        n = len(J)
        A = np.einsum("pli,pjk->pijkl", inv, inv).reshape(n, 4, 4) * (self._mu - self._lam * log_j)[
            :, None, None
        ] + self._lam * np.einsum("pji,plk->pijkl", inv, inv).reshape(n, 4, 4)
        A += self._mu * np.eye(4)
        G = self._G.reshape(n, 4, -1)
        AG = A @ G
        return np.einsum("pam,pan->mn", G * self._weights[:, None, None], AG, optimize=True)


class ReducedModel(SteppedModel[tuple]):
    """The reduced fidelity (fidelity "reduced").

    State: z = (theta, q), the momenta p and the torque work. wall.kind
    "deformable" is not offered (models.create rejects it); "none" or a zero
    contact stiffness switch contact off, `gap` still reports the geometric
    distance to the block.
    """

    fidelity = "reduced"

    def __init__(self, scene: Scene, basis: ModalBasis | None = None):
        self.scene = validate(scene)
        refuse_deformable_wall(scene, self.fidelity)
        self.basis = b = basis if basis is not None else modal_basis(scene)
        self.m = b.count
        self.n = self.m + 1
        self.inertia0 = b.inertia0
        self._g = scene.gravity
        self._hk = scene.pendulum.thickness * scene.contact.stiffness
        self.contact_on = scene.wall.kind == "rigid" and scene.contact.stiffness > 0.0
        self.block = scene.block
        self._Q = np.concatenate([[1.0], b.torque_modes])  # generalised force of a unit torque
        self._head_flat = b.head_phi.reshape(-1, self.m)  # (2P, m): x and y rows interleaved
        self._phi_peak = np.max(np.linalg.norm(b.head_phi, axis=1), axis=0)  # (m,) largest head displacement per mode
        self._head_centre = (0.0, -scene.geometry.head_centre_depth)
        self._head_radius = float(np.max(np.linalg.norm(b.head_X - self._head_centre, axis=1)))
        self.control = StepControl.for_scene(scene)
        self._memo: dict[bytes, tuple] = {}
        self._closest_memo: tuple[tuple, ClosestPoint] | None = None
        self._identity = np.eye(self.n)
        # (field, von Mises of it, the elements' integration points), built when first asked for
        self._stress: tuple[GridFunction, CoefficientFunction, Any] | None = None
        self._sampler: VertexSampler | None = None
        self._strain = LinearStrain(b.omega2) if uses_linear_strain(scene) else NeoHookeanStrain(scene, b.phi, b.omega2)
        z0 = np.zeros(self.n)
        z0[0] = float(scene.theta0)
        p0 = self.mass_matrix(z0) @ np.concatenate([[float(scene.omega0)], np.zeros(self.m)])
        self.time = 0.0
        self._x = (z0, p0, 0.0)
        self._outputs = self._compute_outputs(self._x, 0.0, 0)
        self.last_min_gap = self._outputs.gap

    # ---------------------------------------------------------------- energies
    def mass_matrix(self, z: np.ndarray) -> np.ndarray:
        b, q = self.basis, z[1:]
        M = self._identity.copy()
        M[0, 0] = b.inertia0 + 2.0 * b.a @ q + q @ q
        coupling = q @ b.gyro
        M[0, 1:] = coupling
        M[1:, 0] = coupling
        return M

    def _kinetic_gradient_q(self, z: np.ndarray, v: np.ndarray) -> np.ndarray:
        """d/dq of 1/2 v^T M(q) v at fixed velocity v (= minus d/dq of 1/2 p^T M^-1 p at fixed p)."""
        q = z[1:]
        return v[0] * v[0] * (self.basis.a + q) + v[0] * (self.basis.gyro @ v[1:])

    def _gravity(self, z: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Gravity energy, gradient and Hessian in z."""
        b, g = self.basis, self._g
        s, c = math.sin(z[0]), math.cos(z[0])
        S = b.first_moment + b.moment_modes @ z[1:]
        energy = g * (s * S[0] + c * S[1])
        grad = np.empty(self.n)
        grad[0] = g * (c * S[0] - s * S[1])
        grad[1:] = g * (s * b.moment_modes[0] + c * b.moment_modes[1])
        hess = np.zeros((self.n, self.n))
        hess[0, 0] = -energy
        hess[0, 1:] = hess[1:, 0] = g * (c * b.moment_modes[0] - s * b.moment_modes[1])
        return energy, grad, hess

    def head_points(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(deformed positions (P, 2), body-frame positions (P, 2)) of the head sample points."""
        b = self.basis
        local = b.head_X + (self._head_flat @ z[1:]).reshape(-1, 2)
        s, c = math.sin(z[0]), math.cos(z[0])
        world = np.column_stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]])
        return world, local

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
        """(energy, gradient, Gauss-Newton Hessian, force on the body (2,)) of the wall contact at z."""
        key = z.tobytes()
        hit = self._memo.get(key)
        if hit is not None:
            return hit
        zero = (0.0, np.zeros(self.n), np.zeros((self.n, self.n)), np.zeros(2))
        result = zero
        if self.contact_on and self._may_touch(z):
            from ..contact import box_signed_distance

            world, _ = self.head_points(z)
            blk = self.block
            px, py = world[:, 0], world[:, 1]
            inside = np.flatnonzero((px < blk.x_max) & (px > blk.x_min) & (py < blk.y_max) & (py > blk.y_min))
            if inside.size:
                dist, nx, ny = box_signed_distance(px[inside], py[inside], blk)
                w = self.basis.head_weights[inside] * self._hk
                depth = -dist
                normal = np.column_stack([nx, ny])  # outward: the force direction
                energy = 0.5 * float(w @ (depth * depth))
                # d depth / dz = -n . dx/dz with dx/dtheta = J x, dx/dq = R phi
                s, c = math.sin(z[0]), math.cos(z[0])
                R = np.array([[c, -s], [s, c]])
                pts = world[inside]
                dtheta = -(normal[:, 0] * -pts[:, 1] + normal[:, 1] * pts[:, 0])
                rn = normal @ R  # rows: (R^T n)^T
                dq = -np.einsum("pk,pkj->pj", rn, self.basis.head_phi[inside])
                D = np.column_stack([dtheta, dq])  # (k, n): d depth / dz
                grad = D.T @ (w * depth)
                hess = D.T @ (w[:, None] * D)
                force = (w * depth) @ normal
                result = (energy, grad, hess, force)
        if len(self._memo) > 32:
            self._memo.clear()
        self._memo[key] = result
        return result

    def potential_energy(self, z: np.ndarray) -> float:
        """Gravity + contact + strain energy."""
        b = self.basis
        S = b.first_moment + b.moment_modes @ z[1:]
        gravity = self._g * (math.sin(z[0]) * S[0] + math.cos(z[0]) * S[1])
        return gravity + self._contact(z)[0] + self._strain.energy(z[1:])

    def potential_gradient(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gradient of gravity + contact + strain in z, and the Hessian of gravity + contact
        (Gauss-Newton for contact); the strain's Hessian is the strain model's own."""
        _, gg, hg = self._gravity(z)
        _, gc, hc, _ = self._contact(z)
        grad = gg + gc
        grad[1:] += self._strain.gradient(z[1:])
        return grad, hg + hc

    def energy(self, x: tuple) -> float:
        z, p, _ = x
        return 0.5 * float(p @ np.linalg.solve(self.mass_matrix(z), p)) + self.potential_energy(z)

    # ---------------------------------------------------------------- stepping
    def step(self, x: tuple, dt: float, torque: float) -> tuple | None:
        """One discrete-gradient step; None when Newton does not converge (the stepper halves dt)."""
        z0, p0, work = x
        A0 = np.linalg.inv(self.mass_matrix(z0))
        V0 = self.potential_energy(z0)
        Q = torque * self._Q
        v0 = A0 @ p0
        scale = abs(0.5 * p0 @ v0) + abs(V0) + 1e-12
        g0, _ = self.potential_gradient(z0)
        z1 = z0 + dt * v0 + (0.5 * dt * dt) * (A0 @ (Q - g0))  # predictor (no gyroscopic terms)
        K_strain = self._strain.linear_hessian  # the tangent at q = 0; refreshed if Newton is slow
        for it in range(NEWTON_MAX_IT):
            dz = z1 - z0
            zm = 0.5 * (z0 + z1)
            A1 = np.linalg.inv(self.mass_matrix(z1))
            Abar = 0.5 * (A0 + A1)
            pm = np.linalg.solve(Abar, dz / dt)
            p1 = 2.0 * pm - p0
            # kinetic energy's q difference: g(q) = 1/4 (p0^T A(q) p0 + p1^T A(q) p1)
            Mm = self.mass_matrix(zm)
            Am = np.linalg.inv(Mm)
            grad_T = -0.5 * (self._kinetic_gradient_q(zm, Am @ p0) + self._kinetic_gradient_q(zm, Am @ p1))
            dq = dz[1:]
            dq2 = float(dq @ dq)
            if dq2 > 0.0:
                t0 = 0.25 * (p0 @ A0 @ p0 + p1 @ A0 @ p1)
                t1 = 0.25 * (p0 @ A1 @ p0 + p1 @ A1 @ p1)
                grad_T = grad_T + (t1 - t0 - grad_T @ dq) / dq2 * dq
            # gravity + contact + strain: Gonzalez's correction in the mass metric
            V1 = self.potential_energy(z1)
            gVm, hVm = self.potential_gradient(zm)
            Wdz = Mm @ dz
            denom = float(dz @ Wdz)
            grad_V = gVm + ((V1 - V0 - gVm @ dz) / denom) * Wdz if denom > 0.0 else gVm
            residual = p1 - p0 - dt * Q + dt * grad_V
            residual[1:] += dt * grad_T
            if not np.all(np.isfinite(residual)):
                return None
            imbalance = abs(float(dz @ residual)) / dt  # the energy this iterate leaves unbalanced
            if imbalance <= ENERGY_TOL * scale and it > 0:
                break
            if it >= NEWTON_MAX_IT - 1:
                if imbalance <= STALL_TOL * scale:
                    break
                return None
            if it == TANGENT_AFTER:  # slow convergence: the strain's tangent at the midpoint
                K_strain = self._strain.hessian(zm[1:])
            # approximate Jacobian: inertia and potential Hessians, no gyroscopic terms (modified Newton)
            jac = (2.0 / dt) * Mm + 0.5 * dt * hVm
            jac[1:, 1:] += 0.5 * dt * K_strain
            z1 = z1 - np.linalg.solve(jac, residual)
        return (z1, p1, work + float(Q @ dz))

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
        return np.linalg.solve(self.mass_matrix(z), p)

    def _closest(self, x: tuple) -> ClosestPoint:
        """The head point closest to the wall and its rate."""
        if self._closest_memo is not None and self._closest_memo[0] is x:
            return self._closest_memo[1]
        from ..contact import box_signed_distance

        z = x[0]
        world, local = self.head_points(z)
        dist, nx, ny = box_signed_distance(world[:, 0], world[:, 1], self.block)
        i = int(np.argmin(dist))
        v = self._velocity(x)
        s, c = math.sin(z[0]), math.cos(z[0])
        elastic = self.basis.head_phi[i] @ v[1:]
        vel = v[0] * (_J @ world[i]) + np.array([c * elastic[0] - s * elastic[1], s * elastic[0] + c * elastic[1]])
        result = ClosestPoint(world, dist, i, (float(nx[i]), float(ny[i])), float(nx[i] * vel[0] + ny[i] * vel[1]))
        self._closest_memo = (x, result)  # the stepper asks for the gap, then the scales, of one state
        return result

    def _circle_gap(self, x: tuple) -> tuple[float, float]:
        """Gap of the head's bounding circle to the block and its rate: a lower bound of the gap."""
        cx, cy, radius = self._head_circle(x[0])
        d, qx, qy = rigid_contact.point_box(cx, cy, self.block)
        if d <= 0.0:  # the centre inside the block: no bound from the circle
            return -radius, 0.0
        nx, ny = (cx - qx) / d, (cy - qy) / d
        return d - radius, self._velocity(x)[0] * (-cy * nx + cx * ny)

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
        """Contact duration and depth from the rigid-body effective mass at the closest point (as fem.py)."""
        if not self.contact_on:
            return math.inf, 0.0
        circle_gap, circle_rate = self._circle_gap(x)
        if circle_gap > FAR_GAP and circle_gap + 2.0 * self.control.max_step * min(circle_rate, 0.0) > 0.0:
            return math.inf, 0.0  # no contact within the next two largest steps
        closest = self._closest(x)
        m_eff = effective_mass(self.inertia0, closest.arm, self.scene.geometry.head_centre_depth)
        dist = closest.gaps
        near = dist < dist[closest.index] + SCALE_BAND  # points further behind the closest one cannot take part
        return contact_time_scale(dist[near], self.basis.head_weights[near], m_eff, closest.rate, self._hk)

    # ---------------------------------------------------------------- protocol
    def get_state(self) -> ModelState:
        z, p, work = self._x
        return ModelState(
            self.fidelity,
            self.time,
            {
                "torque_work": work,
                "substeps": float(self._outputs.substeps),
                "last_min_gap": self.last_min_gap,
                **last_advance_scalars(self._outputs),
            },
            {"z": z.copy(), "p": p.copy()},
        )

    def set_state(self, state: ModelState) -> None:
        if state.fidelity != self.fidelity:
            raise ValueError(f"state of fidelity {state.fidelity!r} does not fit a reduced model")
        z, p = state.arrays.get("z"), state.arrays.get("p")
        if z is None or p is None or z.shape != (self.n,) or p.shape != (self.n,) or "torque_work" not in state.scalars:
            raise ValueError(f"state does not fit this reduced model ({self.m} modes: z and p of length {self.n})")
        x = (z.astype(float).copy(), p.astype(float).copy(), float(state.scalars["torque_work"]))
        if not (
            np.all(np.isfinite(x[0]))
            and np.all(np.isfinite(x[1]))
            and math.isfinite(x[2])
            and math.isfinite(state.time)
        ):
            raise ValueError("reduced model state has non-finite values")
        self._x = x
        self.time = float(state.time)
        self._outputs = self._compute_outputs(x, self.time, int(state.scalars.get("substeps", 0)))
        self.last_min_gap = self._outputs.min_gap = restored_min_gap(state, self._outputs)
        restore_last_advance(state, self._outputs)

    # ----------------------------------------------------------------- outputs
    def _compute_outputs(self, x: tuple, t: float, substeps: int) -> Outputs:
        z, p, work = x
        M = self.mass_matrix(z)
        kinetic = 0.5 * float(p @ np.linalg.solve(M, p))
        potential = self._gravity(z)[0]
        c_energy, _, _, force = self._contact(z)
        strain = self._strain.energy(z[1:])
        if self.contact_on:
            gap = self._closest(x).gap
        else:
            from ..contact import box_signed_distance

            world, _ = self.head_points(z)
            gap = float(np.min(box_signed_distance(world[:, 0], world[:, 1], self.block)[0]))
        vm = self.von_mises_max(z) if self.scene.model.compute_stress else 0.0
        return Outputs(
            time=t,
            theta=math.remainder(float(z[0]), 2.0 * math.pi),
            omega=float(p[0] / M[0, 0]),
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
            from ..modes import fe_space

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
