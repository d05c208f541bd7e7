"""The scalar equation of one rigid discrete-gradient step, and its Newton solves.

With c = 2 I / dt^2 and V = gravity + contact energy, the step's rotation u = q1 - q0 solves

    G(u) = c (u - dt w0) - T + (V(q0 + u) - V(q0)) / u = 0

(rigid/model.py's two equations with omega1 eliminated). A step that provably stays off the block
leaves the contact energy out and, in free flight, takes a single Newton update (`solve_free`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from . import arc_contact as rigid_contact

NEWTON_MAX_IT = 80
ENERGY_ROUNDOFF = 1e-15  # relative energy imbalance per step accepted as converged
NEWTON_MARGIN = 10.0  # how much larger than quadratic convergence predicts the next Newton update is taken
SMALL_STEP = 1e-9  # |q1 - q0| (rad) below which the contact difference quotient is replaced by a derivative
# |q1 - q0| (rad) above which the contact quotient's derivative is exact (below, Newton's G' is approximate
# and its convergence linear: no quadratic prediction of the next update there)
EXACT_DERIVATIVE = 1e-6

Contact = tuple[Sequence[rigid_contact.Piece], rigid_contact.Penalty]
"""The head's contact at an angle: the arc's pieces inside the block and their penalty."""


def _gravity_quotient(mgd: float, q0: float, u: float) -> tuple[float, float]:
    """(V(q0 + u) - V(q0)) / u for gravity's V = -mgd cos q, and its derivative in u, free of
    cancellation: mgd sin(qm) sin(h) / h with h = u / 2, qm = q0 + h."""
    h = 0.5 * u
    if abs(h) > 1e-4:
        sin_h = math.sin(h)
        sinc, dsinc = sin_h / h, (h * math.cos(h) - sin_h) / (h * h)
    else:
        h2 = h * h
        sinc, dsinc = 1.0 - h2 / 6.0 + h2 * h2 / 120.0, h * (-1.0 / 3.0 + h2 / 30.0)
    s_m, c_m = math.sin(q0 + h), math.cos(q0 + h)
    return mgd * s_m * sinc, 0.5 * mgd * (c_m * sinc + s_m * dsinc)


def _next_update(du: float, last: float) -> float:
    """The Newton update after du as quadratic convergence predicts it from du and the update before,
    `last` (K = du / last^2, the next K du^2), NEWTON_MARGIN times over; inf when du did not contract."""
    if not last > du:
        return math.inf
    ratio = du / last
    return NEWTON_MARGIN * du * ratio * ratio


def _converged(du: float, size: float, c: float, scale: float) -> bool:
    """Newton's stopping test on an update du to u of size `size`: du at round-off in u, or the energy
    still unbalanced, c du |u|, at round-off of the energies the step moves (the contact energy
    carries relative noise ~1e-11 from the positions' round-off, which bounds how far u can settle)."""
    return du <= 1e-15 * size + 1e-20 or c * du * size <= ENERGY_ROUNDOFF * scale


def _free_newton_gain(c: float, mgd: float) -> float:
    """K with |u1 - u*| <= K (u1 - u0)^2 for a Newton update u0 -> u1 of the step without contact.

    There G(u) = c (u - dt w0) - T + mgd int_0^1 sin(q0 + s u) ds, so |G''| <= mgd / 3 and
    c - mgd / 2 <= G' <= c + mgd / 2. Newton's error is G''/(2 G'(u0)) (u0 - u*)^2 and
    |u0 - u*| <= |u1 - u0| (c + mgd / 2) / (c - mgd / 2); inf when G' may vanish (c <= mgd)."""
    if not c > mgd:
        return math.inf
    lo, hi = c - 0.5 * mgd, c + 0.5 * mgd
    return mgd / 3.0 / (2.0 * lo) * (hi / lo) ** 2


class StepSolver:
    """G(u) = 0 for one body: its moment of inertia `inertia` about the pivot, its gravity moment
    `mgd` (m g times the centre of mass's depth) and its contact at an angle, `contact` (the model's
    memoised `_contact`: Newton revisits angles)."""

    def __init__(self, inertia: float, mgd: float, contact: Callable[[float], Contact]):
        self.inertia, self.mgd, self._contact = inertia, mgd, contact
        # the last free-flight step size dt, 2 I / dt^2, dt^2 / 2 and _free_newton_gain at it
        self._free_consts = (math.nan, math.nan, math.nan, math.inf)

    def contact_quotient(self, q0: float, u: float, e0: float) -> tuple[float, float]:
        """(E(q0 + u) - E(q0)) / u for the contact energy E, and its derivative in u; e0 = E(q0).
        Minus the first is the contact torque of the step (the discrete gradient)."""
        pen = self._contact(q0 + u)[1]
        if abs(u) > SMALL_STEP:
            qc = (pen.energy - e0) / u
            dqc = (pen.d_energy - qc) / u if abs(u) > EXACT_DERIVATIVE else 0.5 * pen.d2_energy
        else:  # E'(midpoint) to O(u^2)
            qc = pen.d_energy - 0.5 * u * pen.d2_energy
            dqc = 0.5 * pen.d2_energy
        return qc, dqc

    def solve(self, q0: float, w0: float, dt: float, torque: float, contact: bool) -> float | None:
        """The increment u = q1 - q0 solving G(u) = 0 (Newton, safeguarded by a bracket); `contact`
        False leaves the contact energy out (a step that provably never reaches the block)."""
        if not contact:
            u_free = self.solve_free(q0, w0, dt, torque)
            if u_free is not None:
                return u_free
        c = 2.0 * self.inertia / (dt * dt)
        mgd = self.mgd
        pen0 = self._contact(q0)[1] if contact else None
        e0 = pen0.energy if pen0 is not None else 0.0
        # predictor: G linearised about u = 0 (the explicit step with the force at q0, stiffened by the
        # contact's and gravity's d2V/dq2 at q0: in contact the stiffness matters)
        force0 = torque - mgd * math.sin(q0) - (pen0.d_energy if pen0 is not None else 0.0)
        stiff = 0.5 * (mgd * math.cos(q0) + pen0.d2_energy) if pen0 is not None and pen0.d2_energy > 0.0 else 0.0
        explicit = dt * w0 + 0.5 * dt * dt * force0 / self.inertia
        u = u0 = (c * dt * w0 + force0) / (c + stiff) if stiff > 0.0 else explicit
        scale = mgd + 0.5 * self.inertia * w0 * w0 + e0 + abs(torque * u)  # energies this step moves
        lo, hi = -math.inf, math.inf
        span = 0.0  # the widening stride, set the first time Newton leaves an open bracket (rarely)
        last = 0.0  # the Newton update before this one (0: none, or a bisection came between)
        for _ in range(NEWTON_MAX_IT):
            # G(u) = c (u - dt w0) - T + (V(q0 + u) - V(q0)) / u
            quot, dquot = _gravity_quotient(mgd, q0, u)
            if contact:
                qc, dqc = self.contact_quotient(q0, u, e0)
                quot += qc
                dquot += dqc
            g, dg = c * (u - dt * w0) - torque + quot, c + dquot
            if not (math.isfinite(g) and math.isfinite(dg)):
                return None
            if g == 0.0:
                return u
            if g < 0.0:
                lo = u
            else:
                hi = u
            u_new = u - g / dg if dg > 0.0 else math.nan
            if lo <= u_new <= hi:
                du = abs(u_new - u)
                exact = not contact or abs(u) > EXACT_DERIVATIVE  # G' exact: quadratic convergence
                ahead = _next_update(du, last) if exact else math.inf
                if _converged(du if du < ahead else ahead, abs(u_new), c, scale):  # monotone: the smaller decides
                    return u_new
                last = du if exact else 0.0
            if not lo < u_new < hi:  # Newton left the bracket (or G' <= 0): bisect or widen
                last = 0.0
                if math.isfinite(lo) and math.isfinite(hi):
                    u_new = 0.5 * (lo + hi)
                    if u_new == lo or u_new == hi or _converged(0.5 * (hi - lo), abs(u_new), c, scale):
                        return u_new  # bracket exhausted at round-off, or as narrow as the stopping test asks
                else:
                    span = 2.0 * (span or max(abs(u0), dt * abs(w0), 1e-12))
                    u_new = u + span if g < 0.0 else u - span
            u = u_new
        return None

    def solve_free(self, q0: float, w0: float, dt: float, torque: float) -> float | None:
        """`solve` without contact as one Newton update from the explicit predictor, accepted when the
        next update, bounded a priori (_free_newton_gain), would pass the stopping test; None when it
        would not (then `solve` iterates). This is a free-flight step's whole solve."""
        inertia, mgd = self.inertia, self.mgd
        step, c, half_dt2, gain = self._free_consts
        if step != dt:  # a new step size (free flight keeps one): its constants again
            c, half_dt2 = 2.0 * inertia / (dt * dt), 0.5 * dt * dt
            gain = _free_newton_gain(c, abs(mgd))
            self._free_consts = (dt, c, half_dt2, gain)
        u = dt * w0 + half_dt2 * (torque - mgd * math.sin(q0)) / inertia
        quot, dquot = _gravity_quotient(mgd, q0, u)
        g, dg = c * (u - dt * w0) - torque + quot, c + dquot
        if not (dg > 0.0 and math.isfinite(g) and math.isfinite(dg)):
            return None
        if g == 0.0:
            return u
        u_new = u - g / dg
        du, size = abs(u_new - u), abs(u_new)
        bound = gain * du * du  # the next update's: accept if either passes
        if bound < du:
            du = bound
        if du <= 1e-15 * size + 1e-20:  # _converged, inlined (every free-flight step's test), its
            return u_new  # energy test only when needed
        scale = mgd + 0.5 * inertia * w0 * w0 + abs(torque * u)
        return u_new if c * du * size <= ENERGY_ROUNDOFF * scale else None
