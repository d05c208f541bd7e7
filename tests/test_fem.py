"""Acceptance tests of the full FE model, on the default (coarse) mesh.

Reference numbers are from shared/DESIGN.md section 2. One physical point
differs from the original expectation and is tested as measured: with every energy
times the thickness (the plate the seed describes), the steel pendulum's first
bending mode has a period of about 1 ms, three times the 0.34 ms contact, so
each impact puts about 6 % of the swing energy into elastic vibration and the
rigid-body proxy rebounds to 19.39-19.41 degrees on every mesh from 0.03/order
2 to 0.01/order 2 and 0.03/order 3 (docs/fem.md). The 20-degree rebound of
the seed's own formulation is checked with the seed's effective stiffness,
E / thickness, where the scheme must neither gain nor lose energy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.protocol import ModelState
from fem_pendulum_fmu.physics.scene import compliant, stiff, validate
from fem_pendulum_fmu.physics.swing import peaks_after_first_contact

G = 9.81


def run(model, t_end, dt=1e-3, torque=0.0):
    """Advance in communication steps of dt; return arrays of outputs and the min gap per step."""
    rows = []
    n = int(round((t_end - model.time) / dt))
    t_start = model.time
    for i in range(1, n + 1):
        o = model.advance(t_start + i * dt, torque)
        rows.append(
            (o.time, o.theta, o.omega, o.gap, model.last_min_gap, o.total - o.torque_work, o.contact_force, o.strain)
        )
    return np.array(rows)


def rebound_peaks(out):
    """theta at local maxima after the first contact (sampled every communication step)."""
    return np.degrees(out[peaks_after_first_contact(out[:, 1], out[:, 4]), 1])


@pytest.fixture(scope="module")
def stiff_run():
    model = create(stiff())
    e0 = model.outputs().total
    states = {}
    rows = []
    for i in range(1, 1001):
        if 230 <= i <= 250:
            states[i - 1] = model.get_state()
        o = model.advance(i * 1e-3, 0.0)
        rows.append(
            (o.time, o.theta, o.omega, o.gap, model.last_min_gap, o.total - o.torque_work, o.contact_force, o.strain)
        )
    return model, e0, np.array(rows), states


@pytest.mark.slow
def test_stiff_first_contact_time(stiff_run):
    model, _, out, states = stiff_run
    k = int(np.argmax(out[:, 4] < 0))  # first communication interval with contact
    model.set_state(states[k])
    t0 = model.time
    prev_t, prev_gap = t0, model.outputs().gap
    for i in range(1, 501):
        o = model.advance(t0 + i * 2e-6, 0.0)
        if o.gap < 0:
            t_contact = prev_t + (o.time - prev_t) * prev_gap / (prev_gap - o.gap)
            break
        prev_t, prev_gap = o.time, o.gap
    else:
        pytest.fail("no contact found inside the interval flagged by last_min_gap")
    assert abs(t_contact - 0.2394) <= 1e-3, t_contact


@pytest.mark.slow
def test_stiff_penetration_and_energy(stiff_run):
    model, e0, out, _ = stiff_run
    penetration = -out[:, 4].min()
    assert 63e-6 * 0.85 <= penetration <= 63e-6 * 1.15, penetration
    err = np.max(np.abs(out[:, 5] - e0))
    assert err <= 1e-3 * swing_energy(model.scene), (err, swing_energy(model.scene))
    assert np.all(out[:, 6] >= 0)


@pytest.mark.slow
def test_stiff_rebounds_lose_energy_to_vibration_only(stiff_run):
    model, _, out, _ = stiff_run
    peaks = rebound_peaks(out)
    assert len(peaks) >= 2  # two rebounds in the first second
    # first rebound: mesh-converged value of the plate with correct thickness scaling (module docstring)
    assert abs(peaks[0] - 19.40) <= 0.1, peaks
    # the second impact meets a vibrating pendulum and depends on the vibration's phase
    # (18.3-19.45 degrees across meshes), but no impact may gain energy
    assert np.all(peaks[:2] <= 20.0 + 0.01), peaks
    assert out[-1, 7] > 1e-3 * swing_energy(model.scene)  # the vibration is there, in strain and kinetic energy


@pytest.mark.slow
def test_seed_equivalent_stiffness_rebounds_to_20_degrees():
    model = create(stiff(**{"pendulum.E": 2.1e11 / 0.01}))
    out = run(model, 1.0)
    peaks = rebound_peaks(out)
    assert len(peaks) >= 2
    assert np.all(np.abs(peaks[:2] - 20.0) <= 0.1), peaks


@pytest.mark.slow
def test_free_swing_energy_and_small_amplitude_period():
    theta0 = math.radians(2.0)
    model = create(stiff(theta0=theta0, **{"wall.kind": "none"}))
    e0 = model.outputs().total
    out = run(model, 2.0)
    err = np.max(np.abs(out[:, 5] - e0))
    assert err <= 1e-4 * swing_energy(model.scene), err
    th, t = out[:, 1], out[:, 0]
    up = [i for i in range(1, len(th)) if th[i - 1] < 0 <= th[i]]
    crossings = [t[i - 1] + (t[i] - t[i - 1]) * (-th[i - 1]) / (th[i] - th[i - 1]) for i in up]
    period = float(np.mean(np.diff(crossings)))
    expected = 2 * math.pi * math.sqrt(model.inertia0 / (model.total_mass * G * model.com_depth))
    assert abs(period / expected - 1) <= 5e-3, (period, expected)


def test_constant_torque_holds_the_pendulum_where_gravity_balances_it():
    torque = 0.5
    model = create(stiff(**{"wall.kind": "none"}))
    theta_eq = math.asin(torque / (model.total_mass * G * model.com_depth))
    model = create(stiff(theta0=theta_eq, **{"wall.kind": "none"}))
    out = run(model, 0.3, torque=torque)
    assert abs(np.mean(out[:, 1]) / theta_eq - 1) <= 1e-3, (np.mean(out[:, 1]), theta_eq)
    assert np.max(np.abs(out[:, 1] - theta_eq)) <= 1e-3 * theta_eq


@pytest.mark.slow
def test_compliant_impact_feeds_vibration_and_keeps_energy():
    model = create(compliant())
    e0 = model.outputs().total
    out = run(model, 0.6)
    swing = swing_energy(model.scene)
    assert np.max(np.abs(out[:, 5] - e0)) <= 1e-3 * swing
    assert out[:, 4].min() < 0  # it hit the wall
    peak = rebound_peaks(out)[0]
    assert peak < 19.0, peak  # the rigid-body proxy loses energy into elastic vibration


@pytest.mark.slow
def test_compliant_angle_and_gap_converge_under_mesh_refinement():
    results = {}
    for size in (0.06, 0.03, 0.015):
        model = create(compliant(**{"model.mesh_size": size, "model.order": 2}))
        results[size] = run(model, 0.3)
    ref = results[0.015]
    err = {
        s: (np.max(np.abs(results[s][:, 1] - ref[:, 1])), np.max(np.abs(results[s][:, 3] - ref[:, 3])))
        for s in (0.06, 0.03)
    }
    assert err[0.03][0] < err[0.06][0], err
    assert err[0.03][1] < err[0.06][1], err
    assert err[0.03][0] < math.radians(0.5), err


def test_state_round_trip_is_bit_identical():
    model = create(stiff())
    model.advance(0.2, 0.3)
    saved = model.get_state()
    first = run(model, 0.26, torque=-0.2)
    model.set_state(ModelState.from_bytes(saved.to_bytes()))
    again = run(model, 0.26, torque=-0.2)
    assert np.array_equal(first, again)


def test_two_runs_are_bit_identical():
    a = run(create(compliant()), 0.05, torque=0.1)
    b = run(create(compliant()), 0.05, torque=0.1)
    assert np.array_equal(a, b)


def test_bad_advance_arguments_leave_the_state_unchanged():
    model = create(stiff())
    model.advance(0.01, 0.0)
    before = model.get_state()
    for t_end, torque in ((0.02, float("nan")), (0.02, float("inf")), (0.01, 0.0), (0.005, 0.0)):
        with pytest.raises(ValueError, match="torque|t_end"):
            model.advance(t_end, torque)
    after = model.get_state()
    assert after.time == before.time and all(np.array_equal(after.arrays[k], before.arrays[k]) for k in before.arrays)


@pytest.mark.parametrize(
    "name, value, allowed",
    [
        ("pendulum.nu", 0.5, r"\[0, 0.5\)"),
        ("pendulum.E", 0.0, r"\(0, inf\)"),
        ("pendulum.thickness", -0.01, r"\(0, inf\)"),
        ("model.order", 1, r"\[2, 5\]"),
        ("model.order", 10, r"\[2, 5\]"),
        ("contact.stiffness", float("nan"), "finite"),
        ("model.mesh_size", 0.0, r"\(0, 0.1\]"),
        ("wall.kind", "glass", "rigid, deformable, none"),
        # 1e-5 m would need ~15 TiB by the memory estimate: refused before anything is meshed
        ("model.mesh_size", 1e-5, r"model.order = 2 would need about .* GiB \(estimate\), more than this machine's"),
    ],
)
def test_bad_parameters_are_named_with_value_and_range(name, value, allowed):
    with pytest.raises(ValueError, match=allowed) as info:
        create(stiff(**{name: value}))
    assert name in str(info.value) and repr(value) in str(info.value)


@pytest.mark.slow
def test_deformable_wall_impact_is_finite_and_keeps_energy():
    """The seed's set-up: the meshed steel block, through ContactBoundary."""
    model = create(stiff(**{"wall.kind": "deformable"}))
    e0 = model.outputs().total
    model.advance(0.235, 0.0)
    out = run(model, 0.25)
    assert np.all(np.isfinite(out))
    assert out[:, 4].min() < 0  # the impact happened inside the window
    assert np.max(np.abs(out[:, 5] - e0)) <= 10 * 1e-3 * swing_energy(model.scene)
    assert out[-1, 2] > 0  # and the pendulum rebounds


def test_von_mises_only_when_asked_and_plausible():
    quiet = create(compliant())
    asked = create(compliant(**{"model.compute_stress": True}))
    a, b = quiet.advance(0.01, 0.0), asked.advance(0.01, 0.0)
    assert a.von_mises_max == 0.0
    # rubber hanging under its own weight: stress of the order rho g L (a few kPa), far below E
    # (rho g L = 2.9 kPa with L = 0.3 m, pivot to the bottom of the head); measured 3143 Pa at 0.01 s
    assert b.von_mises_max == pytest.approx(3143.0, rel=0.05), b.von_mises_max
    assert b.theta == a.theta  # asking for stress does not change the dynamics


def test_element_order_follows_the_material_unless_set():
    """model.order 0 (auto, the default): order 3 for a soft pendulum, 2 for a stiff one; set, it stays."""
    rubber = {"pendulum.E": 1e6, "pendulum.nu": 0.45, "pendulum.rho": 1000.0}
    assert validate(stiff()).model.order == 2
    assert validate(stiff(**rubber)).model.order == 3
    assert validate(compliant()).model.order == 3
    assert validate(stiff(**rubber, **{"model.order": 2})).model.order == 2
    assert validate(stiff(**{"model.order": 4})).model.order == 4
