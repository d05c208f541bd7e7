"""A torque that follows a polynomial over an advance (physics/torque.py), and the outputs' time
derivatives (physics/output_rates.py): what FMI 2.0 input interpolation and output derivatives
rest on, tested on the models directly (tests/test_coupling_fmu.py goes through the FMU).

The reference of a ramped advance is the same motion in 2000 advances of 10 us, each given the
polynomial as it stands at its own start ("following the ramp"). The one 20 ms advance takes 10
internal steps of 2 ms, each with the exact mean torque over it; the midpoint rule then misses the
ramp's effect on theta by 1 / (2 N^2) of it, N = 10 steps: 0.50 % for the ramp, 0.61 % for the
parabola below, measured alike for rigid, reduced and fem (the varying part of a torque is what
the scheme integrates to second order; a constant torque's effect it integrates exactly).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.protocol import CONTINUOUS_OUTPUTS
from fem_pendulum_fmu.physics.scene import stiff
from fem_pendulum_fmu.physics.torque import TorqueProfile

FIDELITIES = ("rigid", "reduced", "fem")
COARSE = {"model.mesh_size": 0.06}  # the fem runs on the coarsest mesh (well under 10 s each)
H, FINE = 0.02, 2000
RAMP = TorqueProfile(0.2, 50.0)  # +1 N.m over the 20 ms
PARABOLA = TorqueProfile(0.2, 50.0, 3000.0)


def model(fidelity, **values):
    return create(stiff(model__fidelity=fidelity).with_values({**COARSE, **values}))


def theta_after(fidelity, profile, advances):
    """theta after H in `advances` equal advances, each given `profile` re-anchored at its start."""
    m, h = model(fidelity), H / advances
    for k in range(advances):
        s = k * h
        m.advance((k + 1) * h, TorqueProfile(profile.at(s), profile.derivative(s), profile.curvature))
    return m.outputs().theta


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_one_advance_with_a_torque_polynomial_matches_fine_advances_following_it(fidelity, order):
    profile = RAMP if order == 1 else PARABOLA
    fine = theta_after(fidelity, profile, FINE)
    held = theta_after(fidelity, TorqueProfile(profile.value), 1)  # the derivatives ignored: the value held
    one = theta_after(fidelity, profile, 1)
    effect = fine - held  # 1.5e-3 rad (ramp), 1.9e-3 rad (parabola)
    assert abs(effect) > 1e-3
    assert abs(one - fine) < 0.01 * abs(effect)  # measured 0.50 % and 0.61 %: the midpoint rule's 1 / (2 N^2)


@pytest.mark.parametrize("fidelity", ("rigid", "reduced"))
def test_the_energy_balance_holds_with_a_ramped_torque_through_an_impact(fidelity):
    """tests/test_fidelities.py's run through the first impact, the sine torque now given with its
    first and second derivative at every 1 ms advance; the same bound, 1e-4 of the swing energy
    (measured 2.6e-13 rigid, 1.0e-9 reduced)."""
    m = model(fidelity)
    e0, rows = m.outputs().total, []
    for k in range(260):
        t = k * 1e-3
        profile = TorqueProfile(-0.5 * math.sin(25 * t), -12.5 * math.cos(25 * t), 312.5 * math.sin(25 * t))
        o = m.advance((k + 1) * 1e-3, profile)
        rows.append((m.last_min_gap, o.total - e0 - o.torque_work, o.torque_work))
    gap, balance, work = np.array(rows).T
    assert gap.min() < -1e-5 and np.abs(work).max() > 1e-3  # it hit the wall, the torque did work
    assert np.abs(balance).max() < 1e-4 * swing_energy(m.scene)


def test_the_torque_work_is_the_mean_torque_times_the_rotation():
    """One rigid free-flight advance: the work of the ramp is its exact mean over the step times the
    rotation (the discrete gradient's torque work), to round-off."""
    m = model("rigid")
    theta0 = m.outputs().theta
    out = m.advance(1e-3, RAMP)
    assert out.torque_work == pytest.approx(RAMP.mean(0.0, 1e-3) * (out.theta - theta0), rel=1e-12)


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_a_bad_torque_polynomial_is_refused_and_the_state_kept(fidelity):
    m = model(fidelity)
    m.advance(1e-3, 0.1)
    before = m.get_state()
    for bad in (TorqueProfile(0.1, math.nan), TorqueProfile(0.1, 0.0, math.inf)):
        with pytest.raises(ValueError, match="is not allowed: it must be a finite number"):
            m.advance(2e-3, bad)
    after = m.get_state()
    assert after.time == before.time and after.scalars == before.scalars
    assert all(np.array_equal(after.arrays[k], before.arrays[k]) for k in before.arrays)


# ------------------------------------------------------------------------------------- output derivatives
def derivatives_at(fidelity, t, profile, **values):
    """(outputs, derivatives) of a model advanced to t in 1 ms advances under `profile` (anchored at 0)."""
    m = model(fidelity, **values)
    for k in range(round(t / 1e-3)):
        s = k * 1e-3
        m.advance((k + 1) * 1e-3, TorqueProfile(profile.at(s), profile.derivative(s), profile.curvature))
    s = m.time
    return m.outputs(), m.output_derivatives(TorqueProfile(profile.at(s), profile.derivative(s), profile.curvature))


SWING = TorqueProfile(0.3, 5.0, -20.0)
T0, DH = 0.05, 1e-3  # in free flight (the first impact is at 0.2 s), no second derivative near 0 (gap's is at 0.08)


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_theta_rate_is_omega_and_theta_acceleration_the_rate_of_omega(fidelity):
    out, d = derivatives_at(fidelity, T0, SWING)
    assert d.first["theta"] == pytest.approx(out.omega, rel=1e-9)
    (_, before), (_, after) = derivatives_at(fidelity, T0 - DH, SWING), derivatives_at(fidelity, T0 + DH, SWING)
    rate = (after.first["theta"] - before.first["theta"]) / (2 * DH)
    # theta'' agrees with the rate of the theta' reported around it: measured 1.6e-5 (rigid), 4.4e-4 (reduced, fem)
    assert d.second["theta"] == pytest.approx(rate, rel=0.02)
    assert d.second["theta"] == d.first["omega"]


def test_every_rigid_output_derivative_agrees_with_finite_differences_in_free_flight():
    """First derivatives against central differences of the outputs, second derivatives against those
    of the first derivatives, 1 ms either side (internal steps of 0.1 ms, so that the references'
    trajectories are converged): measured within 3e-4 (potential energy's second) of the reference;
    bound 2 %. gap, energies, torque work; contact force and strain are 0 in free flight."""
    fine = {"solver.max_step": 1e-4}
    (o0, d), (om, dm), (op, dp) = (derivatives_at("rigid", t, SWING, **fine) for t in (T0, T0 - DH, T0 + DH))
    for name in ("omega", "gap", "kinetic", "potential", "total", "torque_work"):
        first_ref = (getattr(op, name) - getattr(om, name)) / (2 * DH)
        second_ref = (dp.first[name] - dm.first[name]) / (2 * DH)
        assert d.first[name] == pytest.approx(first_ref, rel=0.02), name
        assert d.second[name] == pytest.approx(second_ref, rel=0.02), name
    assert all(d.first[n] == d.second[n] == 0.0 for n in ("contact_force", "strain", "contact", "von_mises_max"))
    assert set(d.first) == set(d.second) == set(CONTINUOUS_OUTPUTS)


def test_rigid_derivatives_in_an_impact_are_those_of_the_contact():
    """In contact the energies' rates balance: without a torque total' and total'' vanish (measured 6e-8 and
    4e-8 of the contact energy's rates, the penalty law's truncation over the differences)."""
    m = model("rigid")
    while m.outputs().gap > -2e-5:  # into the first impact (about 239 ms), in 0.02 ms advances
        m.advance(m.time + 2e-5, 0.0)
    d = m.output_derivatives(TorqueProfile(0.0))
    assert d.first["contact"] > 0.0 and d.first["contact_force"] > 0.0  # pressing in
    assert abs(d.first["total"]) < 1e-6 * abs(d.first["contact"])
    assert abs(d.second["total"]) < 1e-4 * abs(d.second["contact"])
    assert d.second["theta"] > 1e3  # the wall's push dominates gravity's 15 rad/s^2


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_asking_for_derivatives_leaves_the_run_bit_identical(fidelity):
    """The fem probes restore its state (held Jacobian included); rigid and reduced only evaluate."""

    def run(ask):
        m, rows = model(fidelity), []
        for k in range(1, 41):
            rows.append(m.advance(k * 1e-3, 0.2).as_dict())
            if ask and k % 3 == 0:
                m.output_derivatives(TorqueProfile(0.2, 3.0, 1.0))
        return rows

    assert run(True) == run(False)
