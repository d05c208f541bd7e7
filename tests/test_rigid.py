"""Acceptance tests of the rigid fidelity and of the exact arc contact law (rigid/arc_contact.py).

Reference numbers are from shared/DESIGN.md section 2 (stiff preset, released
at 20 degrees): first contact 239.4 ms, 0.338 ms in contact, 63 micrometres
penetration, rebound to 20.000 degrees.

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
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.protocol import ModelState, StepFailed
from fem_pendulum_fmu.physics.rigid import arc_contact as rc
from fem_pendulum_fmu.physics.rigid.model import RigidModel
from fem_pendulum_fmu.physics.scene import WallBlock, stiff
from fem_pendulum_fmu.physics.stepping import MIN_STEPS_PER_CONTACT
from fem_pendulum_fmu.physics.swing import peaks_after_first_contact

G = 9.81
DT = 1e-3  # communication step of the FMU masters


def rigid(**values):
    return create(stiff(model__fidelity="rigid", **values))


def row(model, o, e0):
    """(time, theta, omega, gap, min gap in step, energy balance, contact force, substeps) after a step."""
    return (
        o.time,
        o.theta,
        o.omega,
        o.gap,
        model.last_min_gap,
        o.total - o.torque_work - e0,
        o.contact_force,
        o.substeps,
    )


def run(model, t_end, torque=0.0, dt=DT):
    """Advance in communication steps; rows of (time, theta, omega, gap, min gap in step, energy balance,
    contact force, substeps)."""
    e0 = model.outputs().total
    rows = []
    t0 = model.time
    for i in range(1, int(round((t_end - t0) / dt)) + 1):
        tq = torque(t0 + (i - 1) * dt) if callable(torque) else torque
        o = model.advance(t0 + i * dt, tq)
        rows.append(row(model, o, e0))
    return np.array(rows)


def energy_bound(model, out, kinetic_max):
    mgd = model.total_mass * G * model.com_depth
    return out[:, 7].sum() * 4e-15 * (mgd + kinetic_max)


# ------------------------------------------------------------------ mass properties
def test_mass_properties_match_design_and_closed_form():
    model = rigid()
    assert model.total_mass == pytest.approx(1.091, rel=5e-4)
    assert model.inertia == pytest.approx(0.0445, rel=2e-3)
    assert model.com_depth == pytest.approx(0.1817, rel=5e-4)
    # closed-form area: ring + rod outside the outer disc
    g = model.scene.geometry
    w, D, R, r = g.rod_half_width, g.head_centre_depth, g.head_radius, g.hole_radius
    chord = w * math.sqrt(R * R - w * w) + R * R * math.asin(w / R)  # int_{-w}^{w} sqrt(R^2 - x^2) dx
    area = math.pi * (R * R - r * r) + 2 * w * D - chord
    assert model.total_mass == pytest.approx(7850 * 0.01 * area, rel=1e-8)
    # the mass properties scale with rho h only (cached per geometry)
    heavy = rigid(pendulum__rho=2 * 7850.0)
    assert heavy.total_mass == pytest.approx(2 * model.total_mass, rel=1e-14)
    assert heavy.com_depth == pytest.approx(model.com_depth, rel=1e-14)


# ------------------------------------------------------------------ the impact benchmark
@pytest.fixture(scope="module")
def stiff_run():
    model = rigid()
    states = {}
    rows = []
    e0 = model.outputs().total
    for i in range(1, 2001):
        if 200 <= i <= 260:
            states[i - 1] = model.get_state()
        o = model.advance(i * DT, 0.0)
        rows.append(row(model, o, e0))
    return model, np.array(rows), states


def test_rebounds_to_release_angle(stiff_run):
    model, out, _ = stiff_run
    th = out[:, 1]
    peaks = []
    for i in peaks_after_first_contact(th, out[:, 4]):
        a, b, c = th[i - 1], th[i], th[i + 1]  # parabola through three samples
        peaks.append(b + (a - c) ** 2 / (8 * (2 * b - a - c)))
    assert len(peaks) >= 3
    assert np.max(np.abs(np.degrees(peaks) - 20.0)) < 0.01
    assert int(np.sum(np.diff((out[:, 4] < 0).astype(int)) == 1)) == 4  # four impacts in 2 s


def test_first_contact_time_and_penetration(stiff_run):
    model, out, states = stiff_run
    first = int(np.argmax(out[:, 4] < 0))  # communication step during which the first contact happens
    assert 200 <= first <= 260
    assert np.all(out[:first, 4] > 0)
    fine = rigid()
    fine.set_state(states[first])
    fo = run(fine, fine.time + 2e-3, dt=1e-6)
    i = int(np.argmax(fo[:, 3] < 0))
    t_on = fo[i - 1, 0] + (fo[i, 0] - fo[i - 1, 0]) * fo[i - 1, 3] / (fo[i - 1, 3] - fo[i, 3])
    j = i + int(np.argmax(fo[i:, 3] >= 0))
    t_off = fo[j - 1, 0] + (fo[j, 0] - fo[j - 1, 0]) * fo[j - 1, 3] / (fo[j - 1, 3] - fo[j, 3])
    assert t_on == pytest.approx(0.2394, abs=2e-4)
    assert t_off - t_on == pytest.approx(0.338e-3, rel=0.02)
    assert -fo[:, 3].min() == pytest.approx(63e-6, rel=0.05)
    # the internal steps of the 1 ms run see the same depth (16 steps per contact and the onset's)
    assert -out[:, 4].min() == pytest.approx(-fo[:, 3].min(), rel=5e-3)
    assert MIN_STEPS_PER_CONTACT <= out[first, 7] <= 60


def test_energy_conserved_through_impacts(stiff_run):
    model, out, _ = stiff_run
    err = np.max(np.abs(out[:, 5]))
    bound = energy_bound(model, out, swing_energy(model.scene))
    assert bound < 1e-9 * swing_energy(model.scene)  # the bound itself is tiny: < 1e-9 of the swing energy
    assert err <= bound
    assert np.all(out[:, 6] >= 0.0)


# ------------------------------------------------------------------ no wall, static torque, resting contact
def test_small_amplitude_period_without_wall():
    theta0 = math.radians(2.0)
    model = rigid(wall__kind="none", theta0=theta0)
    out = run(model, 3.0)
    th, t = out[:, 1], out[:, 0]
    up = [t[i] - th[i] * (t[i + 1] - t[i]) / (th[i + 1] - th[i]) for i in range(len(th) - 1) if th[i] < 0 <= th[i + 1]]
    period = float(np.mean(np.diff(up)))
    t0 = 2 * math.pi * math.sqrt(model.inertia / (model.total_mass * G * model.com_depth))
    assert period == pytest.approx(t0, rel=5e-3)
    assert period == pytest.approx(t0 * (1 + theta0**2 / 16), rel=1e-4)  # with the amplitude correction
    assert np.max(np.abs(out[:, 5])) < 1e-12 * model.total_mass * G * model.com_depth
    # the geometric gap is still reported (the head swings through where the wall would be), no force
    assert out[:, 3].min() < 0 and np.all(out[:, 6] == 0.0)


def test_constant_torque_holds_static_angle():
    theta_e = math.radians(30.0)
    probe = rigid(wall__kind="none")
    torque = probe.total_mass * G * probe.com_depth * math.sin(theta_e)
    model = rigid(theta0=theta_e)
    out = run(model, 1.0, torque)
    assert np.max(np.abs(out[:, 1] - theta_e)) <= 1e-3 * theta_e
    # a 0.5 % weaker torque does not hold it: the test can fail
    drift = run(rigid(theta0=theta_e), 1.0, 0.995 * torque)
    assert np.max(np.abs(drift[:, 1] - theta_e)) > 1e-3 * theta_e


def test_a_held_contact_is_resolved_first_then_takes_free_flight_steps():
    """The torque presses the touching head on the right face: the first three contact durations
    (0.8-1.3 ms each) are resolved like an impact, then the contact is held (stepping.py) and each
    1 ms doStep is one step (measured: 23, 22, 21 steps, then 1), the energy balance still exact."""
    torque = -5.0  # presses the head against the right face
    model = rigid(theta0=0.0)  # touching, at rest: it rocks on the penalty spring
    out = run(model, 0.05, torque)
    assert np.all(out[:, 4] < 0) and np.all(np.isfinite(out))
    assert out[0, 7] >= MIN_STEPS_PER_CONTACT and np.all(out[3:, 7] == 1)
    assert model.outputs().contact_hold == pytest.approx(0.05)  # in contact at every step's end
    assert np.max(np.abs(out[:, 5])) <= energy_bound(model, out, 0.0)


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
    assert np.max(np.abs(out[:, 1] - hi)) < 1e-12
    assert np.all(out[:, 3] < 0)
    # the wall force balances the torque about the pivot (lever = head centre depth)
    expected = (mgd * math.sin(hi) - torque) / model.scene.geometry.head_centre_depth
    assert out[-1, 6] == pytest.approx(expected, rel=1e-3)
    # resolved for three contact durations, then held: one step per doStep (measured 23, 23, 16, 1, ...),
    # and the equilibrium is a fixed point of the discrete gradient at any step
    assert out[0, 7] >= MIN_STEPS_PER_CONTACT and np.all(out[3:, 7] == 1)


# ------------------------------------------------------------------ driven over the top
def square_wave(t):
    return 50.0 if int(t / 0.4) % 2 == 0 else -50.0


@pytest.mark.parametrize("block, face", [(None, "left"), ({"block.y_max": -0.2}, "top")])
def test_driven_over_the_top(block, face):
    scene = stiff(model__fidelity="rigid")
    if block:
        scene = scene.with_values(block)
    model = create(scene)
    e0 = model.outputs().total
    faces, kinetic_max, rows = set(), 0.0, []
    for i in range(1, 3001):
        o = model.advance(i * DT, square_wave((i - 1) * DT))
        assert all(math.isfinite(v) for v in o.as_dict().values())
        kinetic_max = max(kinetic_max, o.kinetic)
        rows.append(row(model, o, e0))
        if o.gap < 0:
            q = model.get_state().scalars["theta"]
            faces.update(rc.FACES[p.face] for p in rc.inside_pieces(model.arc(q), model.block))
    out = np.array(rows)
    assert np.max(np.unwrap(out[:, 1])) > math.pi + 1.0  # over the top and down the other side
    assert face in faces
    assert np.max(np.abs(out[:, 5])) <= energy_bound(model, out, kinetic_max)
    assert np.max(np.abs(out[:, 5])) < 1e-10 * kinetic_max


# ------------------------------------------------------------------ state, determinism, arguments
def test_state_round_trip_is_bit_identical():
    model = rigid()
    run(model, 0.235)
    saved = model.get_state()
    snapshot = (saved.time, dict(saved.scalars))
    first = run(model, 0.26, torque=0.3)  # across the first impact
    assert (saved.time, saved.scalars) == snapshot  # the returned state is a copy
    model.set_state(saved)
    again = run(model, 0.26, torque=0.3)
    assert np.array_equal(first, again)
    restored = rigid()
    restored.set_state(ModelState.from_bytes(saved.to_bytes()))
    assert np.array_equal(run(restored, 0.26, torque=0.3), first)
    assert restored.outputs() == model.outputs()


def test_two_runs_are_identical():
    def wave(t):
        return 3.0 * math.sin(20 * t)

    assert np.array_equal(run(rigid(), 0.6, wave), run(rigid(), 0.6, wave))


def test_bad_arguments_raise_and_keep_state():
    model = rigid()
    model.advance(0.01, 0.0)
    before = model.get_state()
    for t_end, torque in [
        (0.01, 0.0),
        (0.005, 0.0),
        (math.nan, 0.0),
        (math.inf, 0.0),
        (0.02, math.nan),
        (0.02, math.inf),
    ]:
        with pytest.raises(ValueError):
            model.advance(t_end, torque)
        after = model.get_state()
        assert after.time == before.time and after.scalars == before.scalars
    # a step that cannot be solved at any size (an angular velocity whose step overflows): StepFailed,
    # state unchanged
    before.scalars["omega"] = 1e308
    model.set_state(before)
    with pytest.raises(StepFailed, match="smallest step"):
        model.advance(0.02, 0.0)
    after = model.get_state()
    assert after.time == before.time and after.scalars == before.scalars
    with pytest.raises(ValueError, match="fidelity"):
        model.set_state(ModelState("fem", 0.0, {}, {}))
    with pytest.raises(ValueError, match="deformable"):
        rigid(wall__kind="deformable")
    with pytest.raises(ValueError, match="deformable"):
        RigidModel(stiff(wall__kind="deformable"))


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
