"""Acceptance tests of the rigid fidelity and of the exact arc contact law (rigid/arc_contact.py).

The reference figures of the stiff scene (released at 20 degrees) are the closed forms of
tests/pendulum_closed_form.py, computed from the scene's parameters: mass 1.0912 kg, centre of
mass 0.18165 m below the pivot, inertia 0.044510 kg m^2 about it; first contact at 239.47 ms,
0.3376 ms in contact, 63.19 micrometres deep; rebound to the release angle, four impacts in 2 s.

Energy bound used below: every step of the discrete-gradient rule balances
kinetic + gravity + contact energy against the torque work up to the Newton
stopping test (an imbalance of at most 1e-15 of the energies the step moves,
models.rigid.ENERGY_ROUNDOFF) plus a few roundings of sums of O(mgd) energies;
so |E_total - E_0 - W_torque| <= steps * 4e-15 * (mgd + largest kinetic energy).

The block's top face and corners cannot be reached by the head's outer arc in
the default scene (they are 0.13-0.143 m from the pivot, the arc's nearest
points 0.18 m): a pendulum driven over the top meets the block's left face.
The top face and a corner are exercised with the block's top lowered to
y = -0.2 m, and directly on arcs placed against every face and corner.

The state round trip, determinism and refused arguments are every fidelity's contract:
tests/test_fidelities.py.
"""

from __future__ import annotations

import math

import numpy as np
import pendulum_closed_form as closed
import pytest
from fidelity_runs import DT, finite, run

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.rigid import arc_contact as rc
from fem_pendulum_fmu.physics.scene import WallBlock, steel
from fem_pendulum_fmu.physics.stepping import MIN_STEPS_PER_CONTACT
from fem_pendulum_fmu.physics.swing import peaks_after_first_contact

G = 9.81


def rigid(**values):
    return create(steel(model__fidelity="rigid", **values))


def balance(out, e0):
    """E_total - E_0 - W_torque at each communication point."""
    return out.energy_total - out.energy_torque_work - e0


def energy_bound(model, out, kinetic_max):
    mgd = model.total_mass * G * model.com_depth
    return out.solver_substeps.sum() * 4e-15 * (mgd + kinetic_max)


# ------------------------------------------------------------------ mass properties
def test_mass_properties_match_the_closed_form():
    model = rigid()
    exact = closed.body(model.scene)
    # the model integrates over the FE model's curved mesh, converged to ~1e-10 (mass_properties.py)
    assert model.total_mass == pytest.approx(exact.mass, rel=1e-8)
    assert model.com_depth == pytest.approx(exact.com_depth, rel=1e-8)
    assert model.inertia == pytest.approx(exact.inertia, rel=1e-8)
    # the closed form's values, rounded
    assert model.total_mass == pytest.approx(1.091, rel=5e-4)
    assert model.inertia == pytest.approx(0.0445, rel=2e-3)
    assert model.com_depth == pytest.approx(0.1817, rel=5e-4)
    # the mass properties scale with rho h only (cached per geometry)
    heavy = rigid(pendulum__rho=2 * 7850.0)
    assert heavy.total_mass == pytest.approx(2 * model.total_mass, rel=1e-14)
    assert heavy.com_depth == pytest.approx(model.com_depth, rel=1e-14)


# ------------------------------------------------------------------ the impact benchmark
@pytest.fixture(scope="module")
def stiff_run():
    model = rigid()
    e0 = model.outputs().energy_total
    states = dict.fromkeys(range(199, 261))
    out = run(model, 2.0, states=states)
    return model, out, e0, states


def test_rebounds_to_release_angle(stiff_run):
    model, out, _, _ = stiff_run
    th = out.theta
    peaks = []
    for i in peaks_after_first_contact(th, out.gap_min):
        a, b, c = th[i - 1], th[i], th[i + 1]  # parabola through three samples
        peaks.append(b + (a - c) ** 2 / (8 * (2 * b - a - c)))
    assert len(peaks) >= 3
    assert np.max(np.abs(np.degrees(peaks) - 20.0)) < 0.01
    onsets = out.time[1:][np.diff((out.gap_min < 0).astype(int)) == 1]  # ends of the steps contact begins in
    expected = closed.impact_times(model.scene, 2.0)  # four in 2 s
    assert len(onsets) == len(expected) == 4
    # each in the step contact begins in, give or take the first contact time's tolerance (below)
    assert np.all((onsets - DT - 2e-4 <= expected) & (expected <= onsets + 2e-4)), (onsets, expected)


def test_first_contact_time_and_penetration(stiff_run):
    model, out, _, states = stiff_run
    impact = closed.first_impact(model.scene)
    first = int(np.argmax(out.gap_min < 0))  # communication step during which the first contact happens
    assert 200 <= first <= 260
    assert np.all(out.gap_min[:first] > 0)
    fine = rigid()
    fine.set_state(states[first])
    fo = run(fine, fine.time + 2e-3, dt=1e-6)
    t, gap = fo.time, fo.gap
    i = int(np.argmax(gap < 0))
    t_on = t[i - 1] + (t[i] - t[i - 1]) * gap[i - 1] / (gap[i - 1] - gap[i])
    j = i + int(np.argmax(gap[i:] >= 0))
    t_off = t[j - 1] + (t[j] - t[j - 1]) * gap[j - 1] / (gap[j - 1] - gap[j])
    # the closed forms: 239.47 ms, 0.3376 ms, 63.19 um (tests/pendulum_closed_form.py)
    assert t_on == pytest.approx(impact.time, abs=2e-4)
    assert t_off - t_on == pytest.approx(impact.duration, rel=0.02)
    assert -gap.min() == pytest.approx(impact.penetration, rel=0.05)
    # the internal steps of the 1 ms run see the same depth (16 steps per contact and the onset's)
    assert -out.gap_min.min() == pytest.approx(-gap.min(), rel=5e-3)
    assert MIN_STEPS_PER_CONTACT <= out.solver_substeps[first] <= 60


def test_energy_conserved_through_impacts(stiff_run):
    model, out, e0, _ = stiff_run
    err = np.max(np.abs(balance(out, e0)))
    bound = energy_bound(model, out, swing_energy(model.scene))
    assert bound < 1e-9 * swing_energy(model.scene)  # the bound itself is tiny: < 1e-9 of the swing energy
    assert err <= bound
    assert np.all(out.contact_force >= 0.0)


# ------------------------------------------------------------------ no wall, static torque, resting contact
def test_small_amplitude_period_without_wall():
    theta0 = math.radians(2.0)
    model = rigid(wall__kind="none", theta0=theta0)
    e0 = model.outputs().energy_total
    out = run(model, 3.0)
    th, t = out.theta, out.time
    up = [t[i] - th[i] * (t[i + 1] - t[i]) / (th[i + 1] - th[i]) for i in range(len(th) - 1) if th[i] < 0 <= th[i + 1]]
    period = float(np.mean(np.diff(up)))
    t0 = 2 * math.pi * math.sqrt(model.inertia / (model.total_mass * G * model.com_depth))
    assert period == pytest.approx(t0, rel=5e-3)
    assert period == pytest.approx(t0 * (1 + theta0**2 / 16), rel=1e-4)  # with the amplitude correction
    assert np.max(np.abs(balance(out, e0))) < 1e-12 * model.total_mass * G * model.com_depth
    # the geometric gap is still reported (the head swings through where the wall would be), no force
    assert out.gap.min() < 0 and np.all(out.contact_force == 0.0)


def test_constant_torque_holds_static_angle():
    theta_e = math.radians(30.0)
    probe = rigid(wall__kind="none")
    torque = probe.total_mass * G * probe.com_depth * math.sin(theta_e)
    model = rigid(theta0=theta_e)
    out = run(model, 1.0, torque)
    assert np.max(np.abs(out.theta - theta_e)) <= 1e-3 * theta_e
    # a 0.5 % weaker torque does not hold it: the test can fail
    drift = run(rigid(theta0=theta_e), 1.0, 0.995 * torque)
    assert np.max(np.abs(drift.theta - theta_e)) > 1e-3 * theta_e


def test_a_held_contact_is_resolved_first_then_takes_free_flight_steps():
    """The torque presses the touching head on the right face: the first three contact durations
    (0.8-1.3 ms each) are resolved like an impact, then the contact is held (stepping.py) and each
    1 ms doStep is one step (measured: 23, 22, 21 steps, then 1), the energy balance still exact."""
    torque = -5.0  # presses the head against the right face
    model = rigid(theta0=0.0)  # touching, at rest: it rocks on the penalty spring
    e0 = model.outputs().energy_total
    out = run(model, 0.05, torque)
    assert np.all(out.gap_min < 0) and finite(out)
    assert out.solver_substeps[0] >= MIN_STEPS_PER_CONTACT and np.all(out.solver_substeps[3:] == 1)
    assert model.outputs().contact_hold == pytest.approx(0.05)  # in contact at every step's end
    assert np.max(np.abs(balance(out, e0))) <= energy_bound(model, out, 0.0)


def test_resting_contact_equilibrium_is_kept():
    torque = -5.0
    probe = rigid()
    mgd = probe.total_mass * G * probe.com_depth
    lo, hi = -1e-3, 0.0  # static balance: mgd sin(theta) + dE_c/dtheta = torque
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if mgd * math.sin(mid) + probe.contact_energy(mid).d_energy > torque:
            hi = mid
        else:
            lo = mid
    model = rigid(theta0=hi)
    out = run(model, 0.05, torque)
    assert np.max(np.abs(out.theta - hi)) < 1e-12
    assert np.all(out.gap < 0)
    # the wall force balances the torque about the pivot (lever = head centre depth)
    expected = (mgd * math.sin(hi) - torque) / model.scene.geometry.head_centre_depth
    assert out.contact_force[-1] == pytest.approx(expected, rel=1e-3)
    # resolved for three contact durations, then held: one step per doStep (measured 23, 23, 16, 1, ...),
    # and the equilibrium is a fixed point of the discrete gradient at any step
    assert out.solver_substeps[0] >= MIN_STEPS_PER_CONTACT and np.all(out.solver_substeps[3:] == 1)


# ------------------------------------------------------------------ driven over the top
def square_wave(t):
    return 50.0 if int(t / 0.4) % 2 == 0 else -50.0


@pytest.mark.parametrize("block, face", [(None, "left"), ({"block.y_max": -0.2}, "top")])
def test_driven_over_the_top(block, face):
    scene = steel(model__fidelity="rigid")
    if block:
        scene = scene.with_values(block)
    model = create(scene)
    e0 = model.outputs().energy_total
    states = dict.fromkeys(range(1, 3000))  # states[k + 1]: the state at row k's end
    out = run(model, 3.0, square_wave, states=states)
    assert finite(out)
    states[3000] = model.get_state()
    faces = set()
    for k in np.flatnonzero(out.gap < 0):
        q = states[k + 1].scalars["theta"]
        faces.update(rc.FACES[p.face] for p in rc.inside_pieces(model.arc(q), model.block))
    kinetic_max = float(out.energy_kinetic.max())
    assert np.max(np.unwrap(out.theta)) > math.pi + 1.0  # over the top and down the other side
    assert face in faces
    assert np.max(np.abs(balance(out, e0))) <= energy_bound(model, out, kinetic_max)
    assert np.max(np.abs(balance(out, e0))) < 1e-10 * kinetic_max


# ------------------------------------------------------------------ the arc contact law itself
BLOCK = WallBlock()
HK = 0.01 * 2e12


def _sample(arc, block, s0, s1, n):
    ang = arc.start + np.linspace(s0, s1, n)
    px, py = arc.cx + arc.radius * np.cos(ang), arc.cy + arc.radius * np.sin(ang)
    depths = np.stack([block.x_max - px, px - block.x_min, block.y_max - py, py - block.y_min])
    return px, py, depths


def _signed(px, py, depths):
    """Signed distance to the block: minus the depth inside, the Euclidean distance outside."""
    d = depths.min(axis=0)
    out = np.hypot(np.maximum(-np.minimum(depths[0], depths[1]), 0), np.maximum(-np.minimum(depths[2], depths[3]), 0))
    return np.where(d > 0, -d, out)


def brute_force(arc, block, n=200_001):
    """Energy, force and signed gap by dense sampling (trapezoid rule), refined on the window of
    the arc that the coarse sampling finds inside the block, and around the extreme gap."""
    step = arc.length / (n - 1)
    px, py, depths = _sample(arc, block, 0.0, arc.length, n)
    i = int(np.argmin(_signed(px, py, depths)))
    gpx, gpy, gdepths = _sample(arc, block, max(0.0, (i - 2) * step), min(arc.length, (i + 2) * step), n)
    gap = float(_signed(gpx, gpy, gdepths).min())
    inside = np.nonzero(depths.min(axis=0) > 0)[0]
    s0, s1 = 0.0, arc.length
    if inside.size:
        s0, s1 = max(0.0, (inside[0] - 1) * step), min(arc.length, (inside[-1] + 1) * step)
        px, py, depths = _sample(arc, block, s0, s1, n)
    face = np.argmin(depths, axis=0)
    d = np.maximum(depths.min(axis=0), 0.0)
    w = np.full(n, (s1 - s0) / (n - 1) * arc.radius)
    w[0] = w[-1] = w[0] / 2
    grads = np.array([(-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)])[face]
    energy = 0.5 * HK * np.sum(w * d * d)
    force = -HK * np.sum((w * d)[:, None] * grads, axis=0)
    return energy, force, gap


def arcs_near_every_face_and_corner():
    """Arcs of radius 0.06 pressed into (or held just off) each face and corner of the block."""
    rng = np.random.default_rng(7)
    R = 0.06
    b = BLOCK
    targets = [
        (b.x_max, -0.24, 0.0),
        (b.x_min, -0.2, math.pi),
        (-0.07, b.y_max, 0.5 * math.pi),
        (-0.07, b.y_min, -0.5 * math.pi),
    ] + [
        (x, y, math.atan2(y - (b.y_min + b.y_max) / 2, x + 0.0725))
        for x in (b.x_min, b.x_max)
        for y in (b.y_min, b.y_max)
    ]
    arcs = []
    for x, y, out in targets:
        for depth in (-2e-4, 1e-6, 6.3e-5, 2e-3):
            lean = out + rng.uniform(-0.3, 0.3)
            cx, cy = x + (R - depth) * math.cos(lean), y + (R - depth) * math.sin(lean)
            start = lean + math.pi + rng.uniform(0.3, 2.0)  # the arc's ends stay clear of the contact
            arcs.append(rc.Arc(cx, cy, R, start, 2 * math.pi - 0.5))
    return arcs


@pytest.mark.parametrize("arc", arcs_near_every_face_and_corner())
def test_arc_contact_matches_dense_sampling(arc):
    pen = rc.penalty(arc, BLOCK, HK)
    energy, force, gap = brute_force(arc, BLOCK)
    assert pen.energy == pytest.approx(energy, rel=1e-6, abs=1e-12)
    # the sampled force is first-order accurate where the nearest face (and the force direction) jumps
    assert math.hypot(pen.fx - force[0], pen.fy - force[1]) <= 1e-4 * math.hypot(*force) + 1e-9
    g, _ = rc.signed_gap(arc, BLOCK)
    assert g == pytest.approx(gap, abs=1e-11)


def test_top_face_and_corner_pieces_are_split_by_nearest_face():
    # a circle centred above-right of the top-right corner, pressed 1 mm into it
    b = BLOCK
    arc = rc.Arc(b.x_max + 0.04, b.y_max + math.sqrt(0.059**2 - 0.04**2), 0.06, 0.0, 2 * math.pi - 1e-3)
    faces = {rc.FACES[p.face] for p in rc.inside_pieces(arc, b)}
    assert faces == {"top", "right"}
    depth, px, py, face = rc.deepest_point(arc, b, rc.inside_pieces(arc, b))
    assert depth > 0 and b.x_min <= px <= b.x_max and b.y_min <= py <= b.y_max


def test_energy_derivatives_match_finite_differences():
    model = rigid()
    for q in (-1e-4, -2.6e-4, -3e-3, -0.62, -0.64):
        h = 1e-8
        p, pp, pm = model.contact_energy(q), model.contact_energy(q + h), model.contact_energy(q - h)
        assert p.energy > 0
        assert p.d_energy == pytest.approx((pp.energy - pm.energy) / (2 * h), rel=1e-5)
        assert p.d2_energy == pytest.approx((pp.d_energy - pm.d_energy) / (2 * h), rel=1e-4)
        gap, slope = model.geometric_gap(q)
        assert slope == pytest.approx(
            (model.geometric_gap(q + h)[0] - model.geometric_gap(q - h)[0]) / (2 * h), rel=1e-5
        )
    # on the right face at the head centre's height the force (+x) acts with lever D about the pivot,
    # and its moment is -dE/dtheta
    p = model.contact_energy(-1e-4)
    assert p.fx > 0 and abs(p.fy) < 1e-3 * p.fx
    assert -p.d_energy == pytest.approx(model.scene.geometry.head_centre_depth * p.fx, rel=1e-3)
