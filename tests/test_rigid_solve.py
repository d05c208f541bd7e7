"""The rigid model's scalar solves and contact shortcuts in Python (rigid/solve.py, rigid/model.py,
rigid/arc_contact.py), the compiled core's reference (tests/test_rigid_core.py holds the core to them).

A free-flight step takes one Newton update, accepted by an a-priori bound on the next one; a contact
step's Newton stops once the next update, as quadratic convergence predicts it, would pass the
stopping test; the impulse's line of action and the segment series skip work. Each is checked
against the full computation, and the work is counted in calls (no timing).
"""

from __future__ import annotations

import math

import numpy as np
import pendulum_closed_form as closed
import pytest

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.rigid import arc_contact as rc
from fem_pendulum_fmu.physics.rigid import solve as rigid_solve
from fem_pendulum_fmu.physics.scene import stiff

FIRST_CONTACT = closed.first_impact(stiff()).time  # s, the stiff scene released at 20 degrees: 239.47 ms


def rigid(**values):
    return create(stiff(model__fidelity="rigid", **values))


def residual(model, q0, w0, dt, torque, u):
    """G(u) of the step without contact and its derivative, written out here independently."""
    c, mgd, h = 2.0 * model.inertia / (dt * dt), model._mgd, 0.5 * u
    sinc, dsinc = math.sin(h) / h, (h * math.cos(h) - math.sin(h)) / (h * h)
    g = c * (u - dt * w0) - torque + mgd * math.sin(q0 + h) * sinc
    dg = c + 0.5 * mgd * (math.cos(q0 + h) * sinc + math.sin(q0 + h) * dsinc)
    return g, dg


def energy(model, x):
    q, w, _ = x
    return 0.5 * model.inertia * w * w - model._mgd * math.cos(q) + model.contact_energy(q).energy


def test_free_flight_single_update_is_the_converged_step():
    """Over angles, speeds up to 20 rad/s, steps and torques, the solve (one update, or the iteration
    when the bound does not pass) is within the stopping test of Newton iterated three more times: an
    error of at most 1e-15 of u, or of the energies the step moves (measured: at most 0.52 of that
    allowance). At up to 5 rad/s every step takes the single update."""
    model = rigid(**{"wall.kind": "none"})
    worst = 0.0
    for q0 in (-2.5, -0.3, 0.0, 0.2, 1.0, 3.0):
        for w0 in (-20.0, -2.0, 0.0, 0.5, 5.0, 20.0):
            for dt in (1e-5, 1e-3, 2e-3):
                for torque in (0.0, -0.3, 2.0):
                    if abs(w0) <= 5.0:
                        assert model.solver.solve_free(q0, w0, dt, torque) is not None
                    u = model.solver.solve(q0, w0, dt, torque, False)
                    if u == 0.0:  # at rest in the bottom, no torque
                        assert (q0, w0, torque) == (0.0, 0.0, 0.0)
                        continue
                    ref = u
                    for _ in range(3):
                        g, dg = residual(model, q0, w0, dt, torque, ref)
                        ref -= g / dg
                    c = 2.0 * model.inertia / (dt * dt)
                    scale = model._mgd + 0.5 * model.inertia * w0 * w0 + abs(torque * u)
                    allowance = max(1e-15 * abs(ref) + 1e-20, rigid_solve.ENERGY_ROUNDOFF * scale / (c * abs(ref)))
                    worst = max(worst, abs(u - ref) / allowance)
    assert worst <= 1.0


def contact_run(model):
    """Steps of the discrete gradient through the first impact, at the contact's own step size, from
    the last communication point before it until the head has left the block."""
    while model.time + 1e-3 < FIRST_CONTACT:
        model.advance(model.time + 1e-3, 0.0)
    x = model._x
    dt = model.contact_scales(x)[0] / model.control.steps_per_contact
    states = [x]
    touched = False
    while len(states) < 300 and not (touched and model.gap_and_rate(x)[0] > 0.0):
        x = model.step(x, dt, 0.0)
        states.append(x)
        touched = touched or model.gap_and_rate(x)[0] < 0.0
    return states


def test_contact_steps_balance_energy_and_take_two_evaluations(monkeypatch):
    """Each contact step balances kinetic + gravity + contact energy to 2e-14 of the energies it moves:
    the stopping test's 1e-15 plus the contact energy's own round-off, ~1.5e-13 of it at the deepest
    point (measured: at most 1.2e-14 per step, 1.3e-14 with the solve before the predicted-update
    test). Newton takes two contact evaluations per solve on average (measured 2.0; 3.5 before)."""
    model = rigid()
    evaluations = []
    original = model.solver.contact_quotient
    monkeypatch.setattr(model.solver, "contact_quotient", lambda *a: evaluations.append(a) or original(*a))
    states = contact_run(model)
    assert min(model.gap_and_rate(x)[0] for x in states) < -50e-6  # deep in contact
    scale = model._mgd + max(0.5 * model.inertia * x[1] ** 2 for x in states)
    for x0, x1 in zip(states[:-1], states[1:], strict=True):
        assert abs(energy(model, x1) - energy(model, x0)) <= 2e-14 * scale
    assert len(evaluations) <= 2.2 * (len(states) - 1)


def test_held_contact_with_approximate_jacobian_keeps_the_balance():
    """A head held on the wall by -5 N.m takes 1 ms steps in contact, rotating by less than
    EXACT_DERIVATIVE per step, where Newton's G' is approximate and its convergence linear: no
    quadratic prediction there, and the energy balance over 0.3 s stays within 1e-10 of the energy
    moved (measured 2.4e-11; 3.7e-9 with the prediction used there)."""
    model = rigid(**{"model.mesh_size": 0.06, "theta0": 0.0})
    rows = [model.outputs()]
    for k in range(1, 301):
        rows.append(model.advance(k * 1e-3, -5.0))
    total = np.array([o.total for o in rows])
    work = np.array([o.torque_work for o in rows])
    moved = max(o.kinetic + o.contact for o in rows) + np.abs(work).max()
    assert np.abs(total - total[0] - work).max() <= 1e-10 * moved


def test_impulse_line_of_action_from_pieces_matches_the_penalty():
    """For a head on one face the line of action without the energy's series equals the penalty's
    force over its moment to 1e-14 (measured 2e-16)."""
    model = rigid()
    states = contact_run(model)
    checked = 0
    for x in states:
        q = x[0] + 1e-9  # an angle not in the memo
        fx, fy, moment = model._force_line(q)
        pen = model.contact_energy(q)
        if pen.d_energy == 0.0:
            assert moment == 0.0
            continue
        assert fx / moment == pytest.approx(pen.fx / pen.d_energy, rel=1e-14, abs=1e-300)
        assert fy / moment == pytest.approx(pen.fy / pen.d_energy, rel=1e-14, abs=1e-14 * abs(fx / moment))
        checked += 1
    assert checked > 20


@pytest.mark.parametrize("phi", np.geomspace(1e-5, rc.SEGMENT_PHI_MAX, 40))
def test_segment_series_to_its_needed_terms_equals_all_ten(phi):
    """Summing only the terms above 1e-20 of the first changes S and C by at most 2 ulps (measured 0)."""
    x2, p2 = (2.0 * phi) ** 2, phi * phi
    sums = []
    for terms in (rc._SERIES[rc.bisect.bisect_left(rc._PHI_LIMITS, phi)], rc._SERIES[-1]):
        s_sum = c_sum = 0.0
        for s_j, c_j in terms:
            s_sum = s_sum * x2 + s_j
            c_sum = c_sum * p2 + c_j
        sums.append((s_sum, c_sum))
    (s_cut, c_cut), (s_all, c_all) = sums
    assert abs(s_cut - s_all) <= 2 * math.ulp(s_all)
    assert abs(c_cut - c_all) <= 2 * math.ulp(c_all)
