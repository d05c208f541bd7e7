"""The reduced model's energy-consistent step: Newton on the discrete-gradient equations, in numpy
(NewtonStep, the compiled core's test reference) or in physics/core/reduced_step.c
(CompiledStep, bound to the model's data by `bind_kernel`).

Converged: the energy imbalance within ENERGY_TOL and the last update within UPDATE_TOL of the
step's largest change. The imbalance alone checks the residual along dz only: stopping on it alone
left rubber's angle about 0.7 degree off the converged solution by 0.5 s. From the linearised
predictor Newton contracts by ~3e-4 per iteration, so an update of 1e-3 leaves an error ~1e-6 of
the step: over 0.6 s of rubber impacts the angle stays within 3e-4 degree and the gap within 1
micrometre of steps converged to updates of 1e-8 (docs/notes/reduced.md).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .contact import WallContact
from .dynamics import Gravity, ModalMass, inverse_form, inverse_times
from .head import HeadPoints
from .kernel import ReducedKernel, reduced_kernel
from .potential import Potential
from .state import ReducedState
from .strain import LinearStrain, NeoHookeanStrain

NEWTON_MAX_IT = 40
UPDATE_TOL = 1e-3  # and the last Newton update at most this share of the step's largest coordinate change
ENERGY_TOL = 1e-10  # accepted energy imbalance of one step, relative to the energies it moves
STALL_TOL = 1e-9  # if Newton stalls at round-off, an imbalance up to this is still accepted


class StepStart(NamedTuple):
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


class Iterate(NamedTuple):
    """One Newton iterate: its residual and end momentum, and what its Jacobian needs."""

    residual: np.ndarray
    p1: np.ndarray
    dz: np.ndarray
    zm: np.ndarray
    m00: float  # M(zm) = [[m00, c^T], [c, Id]]
    c: np.ndarray


class NewtonStep:
    """The step in numpy. Every product of M(q) is a border of the identity (dynamics.py)."""

    def __init__(
        self,
        mass: ModalMass,
        gravity: Gravity,
        potential: Potential,
        contact: WallContact,
        strain: LinearStrain | NeoHookeanStrain,
        torque_unit: np.ndarray,
        omega2: np.ndarray,
    ):
        self.n = mass.n
        self._mass_parts = mass.parts
        self._inertia0, self._gyro, self._a, self._two_a = mass.inertia0, mass.gyro, mass.a, mass.two_a
        self._identity, self._identity_q = mass.identity, np.eye(mass.n - 1)
        self._gravity = gravity
        self._g, self._first_moment, self._moment_modes = gravity.g, gravity.first_moment, gravity.moment_modes
        self._potential_energy = potential.energy
        self._contact = contact.terms
        self._no_contact = contact.none
        self._strain = strain
        self._nonlinear_strain = not isinstance(strain, LinearStrain)  # the tangent changes with q
        self._Q = torque_unit  # generalised force of a unit torque
        self._omega2 = omega2
        self._jacobian_base: tuple[float, np.ndarray] | None = None

    def step(self, x: ReducedState, dt: float, torque: float) -> ReducedState | None:
        """One discrete-gradient step; None when Newton does not converge (the stepper halves dt)."""
        start = self.start(x.z, x.p, torque)
        scale = 0.5 * abs(start.t00) + abs(start.V0) + 1e-12
        z1, K_strain = self.predict(start, dt)
        for it in range(NEWTON_MAX_IT):
            ev = self.residual(start, z1, dt)
            if not math.isfinite(float(ev.residual @ ev.residual)):
                return None
            delta = np.linalg.solve(self.jacobian(ev, K_strain, dt), ev.residual)
            z1 = z1 - delta
            p1, imbalance, dz = self._energy_balance(start, z1, dt)
            if not math.isfinite(imbalance):
                return None
            converged = float(np.max(np.abs(delta))) <= UPDATE_TOL * float(np.max(np.abs(dz)))
            if (converged and imbalance <= ENERGY_TOL * scale) or (
                it == NEWTON_MAX_IT - 1 and imbalance <= STALL_TOL * scale
            ):
                return ReducedState(z1, p1, x.torque_work + float(start.Q @ dz))
        return None

    def start(self, z0: np.ndarray, p0: np.ndarray, torque: float) -> StepStart:
        q0, p0q = z0[1:], p0[1:]
        m00, c0, s0 = self._mass_parts(q0)
        c0p0, p0p0 = float(c0 @ p0q), float(p0q @ p0q)
        t00 = p0p0 + (p0[0] - c0p0) ** 2 / s0
        S0 = self._first_moment + self._moment_modes @ q0
        return StepStart(z0, p0, c0, s0, m00 - s0, c0p0, p0p0, t00, S0, self._potential_energy(z0), torque * self._Q)

    def predict(self, start: StepStart, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(z1, the strain's tangent at z0): the midpoint rule linearised at z0,
        [(2 / dt^2) M0 + H0 / 2] dz = (2 / dt) p0 + F0, with F0 the forces at z0 (torque, gravity,
        contact, strain, centrifugal and Coriolis) and H0 the potentials' Hessian (gravity, contact
        Gauss-Newton, strain tangent). Stiff modes (omega dt >> 1) and the penalty contact are taken
        implicitly, so Newton starts close to the solution."""
        z0, q0, h = start.z0, start.z0[1:], 2.0 / (dt * dt)
        K_strain = self._strain.hessian(q0)
        v0 = inverse_times(start.c0, start.s0, start.p0)
        contact = self._contact(z0)
        force = start.Q - self._gravity.gradient(z0) - contact.gradient
        w = float(v0[0])
        force[1:] += (w * w) * (self._a + q0) + w * (self._gyro @ v0[1:]) - self._strain.gradient(q0)
        g, s, c = self._g, math.sin(z0[0]), math.cos(z0[0])
        corner = h * (start.s0 + start.c0c0) - 0.5 * self._gravity.energy(z0)
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
            A += 0.5 * contact.hessian
        A[0, 0] += corner - h
        A[0, 1:] += border
        A[1:, 0] += border
        return z0 + np.linalg.solve(A, rhs), K_strain

    def residual(self, start: StepStart, z1: np.ndarray, dt: float) -> Iterate:
        """The discrete-gradient equations at the end point z1 (momentum balance over the step),
        written on theta and q apart."""
        z0, p0, c0 = start.z0, start.p0, start.c0
        dz = z1 - z0
        zm = z0 + 0.5 * dz
        q1, qm, dq, dth = z1[1:], zm[1:], dz[1:], float(dz[0])
        c1 = q1 @ self._gyro
        cm = 0.5 * (c0 + c1)
        c1c1, c0c1 = float(c1 @ c1), float(c0 @ c1)
        s1 = self._inertia0 + float((self._two_a + q1) @ q1) - c1c1
        mm = self._inertia0 + float((self._two_a + qm) @ qm)
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
        V1 = self._potential_energy(z1)
        cm_dq = float(cm @ dq)
        W0, Wq = mm * dth + cm_dq, dq + dth * cm
        denom = dth * W0 + cm_dq * dth + dq2
        k = (V1 - start.V0 - g_th * dth - float(g_q @ dq)) / denom if denom > 0.0 else 0.0
        residual = np.empty(self.n)
        residual[0] = p10 - float(p0[0]) + dt * (g_th + k * W0 - float(start.Q[0]))
        residual[1:] = p1q - p0q + dt * (g_q + k * Wq - start.Q[1:] + grad_T)
        return Iterate(residual, p1, dz, zm, mm, cm)

    def _end_momentum(
        self, start: StepStart, b: np.ndarray, c1: np.ndarray, s1: float, c0c1: float, c1c1: float
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

    def _energy_balance(self, start: StepStart, z1: np.ndarray, dt: float) -> tuple[np.ndarray, float, np.ndarray]:
        """(p1, |energy change - torque work|, dz) of the step ending at z1: dz . residual / dt without
        the residual's gradients (by construction dz . grad V = V1 - V0 and dq . grad T = t1 - t0, so
        it is T1 - T0 + V1 - V0 - Q . dz), half the cost of an iteration."""
        dz = z1 - start.z0
        q1 = z1[1:]
        c1 = q1 @ self._gyro
        c1c1 = float(c1 @ c1)
        s1 = self._inertia0 + float((self._two_a + q1) @ q1) - c1c1
        p1 = self._end_momentum(start, dz / dt, c1, s1, float(start.c0 @ c1), c1c1)
        kinetic = 0.5 * inverse_form(c1, s1, p1) - 0.5 * start.t00
        return p1, abs(kinetic + self._potential_energy(z1) - start.V0 - float(start.Q @ dz)), dz

    def _potential_gradient_parts(self, zm: np.ndarray, S0: np.ndarray, q1: np.ndarray) -> tuple[float, np.ndarray]:
        """(d/dtheta, d/dq) of gravity + contact + strain at the midpoint zm."""
        g = self._g
        s, c = math.sin(zm[0]), math.cos(zm[0])
        Sm = 0.5 * (S0 + self._first_moment + self._moment_modes @ q1)
        g_q = (g * s) * self._moment_modes[0] + (g * c) * self._moment_modes[1] + self._strain.gradient(zm[1:])
        g_th = g * (c * float(Sm[0]) - s * float(Sm[1]))
        contact = self._contact(zm)
        if contact is not self._no_contact:
            g_th += float(contact.gradient[0])
            g_q = g_q + contact.gradient[1:]
        return g_th, g_q

    def jacobian(self, ev: Iterate, K_strain: np.ndarray, dt: float) -> np.ndarray:
        """The residual's Jacobian in z1 to first order in the step: the mass matrix and its
        q-derivative (the moment of inertia grows with q, the gyroscopic coupling), the centrifugal
        and Coriolis forces of the kinetic energy, and the potentials' Hessians at the midpoint
        (gravity exact, contact Gauss-Newton, the strain's K_strain)."""
        zm, h, half = ev.zm, 2.0 / dt, 0.5 * dt
        jac = self._constant_jacobian(K_strain, dt)
        contact = self._contact(zm)
        if contact is not self._no_contact:
            jac += half * contact.hessian
        g, w = self._g, float(ev.dz[0]) / dt
        s, c = math.sin(zm[0]), math.cos(zm[0])
        jac[0, 0] += h * (ev.m00 - 1.0) - half * self._gravity.energy(zm)
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


class CompiledStep:
    """NewtonStep's step in physics/core/reduced_step.c; the end's potential parts remembered for
    the outputs and the next step's start."""

    def __init__(self, kernel: ReducedKernel, potential: Potential):
        self._kernel_step = kernel.step
        self._potential = potential

    def step(self, x: ReducedState, dt: float, torque: float) -> ReducedState | None:
        done = self._kernel_step(x.z, x.p, self._potential.energy(x.z), dt, torque)
        if done is None:
            return None
        z1, p1, work, parts = done
        self._potential.remember(z1, parts)
        return ReducedState(z1, p1, x.torque_work + work)


def bind_kernel(
    strain: LinearStrain | NeoHookeanStrain,
    mass: ModalMass,
    gravity: Gravity,
    head: HeadPoints,
    hk: float,
    torque_unit: np.ndarray,
    contact_on: bool,
) -> ReducedKernel | None:
    """The compiled step (physics/core/reduced_step.c) on a model's data."""
    runs, block = head.runs, head.block
    return reduced_kernel(
        **strain.kernel_fields(),
        inertia0=mass.inertia0,
        g=gravity.g,
        hk=hk,
        gyro=mass.gyro,
        a=mass.a,
        first_moment=gravity.first_moment,
        moment_modes=gravity.moment_modes,
        q_unit=torque_unit,
        contact_on=int(contact_on),
        x_min=block.x_min,
        x_max=block.x_max,
        y_min=block.y_min,
        y_max=block.y_max,
        head_cx=head.centre[0],
        head_cy=head.centre[1],
        head_radius=head.radius,
        phi_peak=head.phi_peak,
        P=len(head.X),
        head_X=head.X,
        head_phi=head.phi,
        head_w=head.weights,
        groups=len(runs.centre),
        group_start=runs.start,
        group_centre=runs.centre,
        group_radius=runs.radius,
        group_peak=runs.peak,
        max_it=NEWTON_MAX_IT,
        update_tol=UPDATE_TOL,
        energy_tol=ENERGY_TOL,
        stall_tol=STALL_TOL,
    )
