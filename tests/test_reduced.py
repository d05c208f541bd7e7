"""The reduced fidelity (floating frame + modes) and the auto rule, against the FE model.

Bounds come from runs of the same code (docs/notes/reduced.md has the tables and commands):
steel through the first impact and rebound agrees with fem to 0.004 degree and
21 micrometres; rubber through its first impact to 0.24 degree and 1.4 mm (rigid: 3.9 degrees;
0.56 degree and 3.7 mm with the previous Newton solver: after an impact rubber's angle depends on
round-off, docs/notes/reduced.md).
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics import fidelity_rule as selection
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.reduced import modes, step, strain
from fem_pendulum_fmu.physics.scene import compliant, stiff

DT = 1e-3
# Newton stops when a step's energy imbalance is below ENERGY_TOL of the energies it moves (|E| < 2 J
# here): at most ~1000 steps * 1e-10 * 2 J = 2e-7 J, against a swing energy of 0.117 J (steel).
ENERGY_BOUND = 1000 * step.ENERGY_TOL * 2.0


def trace(m, t_end, torque=0.0):
    e0 = m.outputs().total
    rows = []
    while m.time < t_end - 1e-12:
        o = m.advance(round(m.time + DT, 9), torque(m.time) if callable(torque) else torque)
        rows.append((o.theta, o.gap, o.omega, o.total - e0 - o.torque_work, m.last_min_gap))
    return np.array(rows)


def test_modal_basis_is_the_hinged_pendulums():
    scene = stiff()
    basis = modes.modal_basis(scene)
    assert basis.count == scene.model.modes + modes.LOAD_CORRECTIONS
    assert np.all(np.diff(basis.omega2) > 0.0) and basis.omega2[0] > 0.0
    # the first eigenfrequency is the hinged steel plate's first bending mode, ~1 kHz (period ~ 3 contacts)
    f1 = math.sqrt(basis.eigen_omega2[0]) / (2.0 * math.pi)
    assert f1 == pytest.approx(modes.first_elastic_frequency(scene), rel=1e-9)
    assert 800.0 < f1 < 1200.0
    # mass-orthogonal to the rigid rotation: theta is the FE model's best-fit angle
    assert np.max(np.abs(basis.tisserand)) < 1e-9 * math.sqrt(basis.inertia0)
    again = modes.ModalBasis.from_bytes(basis.to_bytes())
    assert all(np.array_equal(getattr(again, f), getattr(basis, f)) for f in ("omega2", "head_phi", "gyro"))


def test_neo_hookean_strain_matches_the_modal_stiffness_for_small_displacements():
    scene = compliant(model__fidelity="reduced")
    basis = modes.modal_basis(scene)
    linear = strain.LinearStrain(basis.omega2)
    exact = strain.NeoHookeanStrain(scene, basis.phi, basis.omega2)
    q = 1e-6 * np.linspace(1.0, -1.0, basis.count)
    assert exact.energy(q) == pytest.approx(linear.energy(q), rel=1e-3)
    assert np.allclose(exact.gradient(q), linear.gradient(q), rtol=1e-3, atol=1e-3 * np.max(np.abs(linear.gradient(q))))
    assert strain.uses_linear_strain(stiff()) and not strain.uses_linear_strain(compliant())


@pytest.fixture(scope="module")
def steel():
    return {f: trace(create(stiff(model__fidelity=f)), 0.45) for f in ("reduced", "rigid", "fem")}


@pytest.mark.slow
def test_steel_reduced_follows_fem_through_impact_and_rebound(steel):
    red, fem, rigid = steel["reduced"], steel["fem"], steel["rigid"]
    assert np.min(fem[:, 4]) < 0.0 and np.min(red[:, 4]) < 0.0  # both hit the wall
    assert np.max(np.abs(np.degrees(red[:, 0] - fem[:, 0]))) < 0.02
    assert np.max(np.abs(red[:, 1] - fem[:, 1])) < 1e-4
    assert np.max(np.abs(red[:, 2] - fem[:, 2])) < 0.02  # omega: the same angular-momentum definition
    # the rigid model misses the ~6 % of the swing energy the impact puts into vibration
    assert np.max(np.abs(np.degrees(rigid[:, 0] - fem[:, 0]))) > 0.1
    assert np.max(np.abs(red[:, 3])) < ENERGY_BOUND


@pytest.mark.slow
def test_rubber_reduced_tracks_fem_through_the_first_impact_far_better_than_rigid():
    """Rubber is outside the reduced model's accurate range (auto picks fem): the impact excites
    modes up to ~1 kHz. It still carries the vibration the rigid model misses."""
    red = trace(create(compliant(model__fidelity="reduced")), 0.3)
    rigid = trace(create(compliant(model__fidelity="rigid")), 0.3)
    fem = trace(create(compliant()), 0.3)
    assert np.min(fem[:, 4]) < 0.0 and np.min(red[:, 4]) < 0.0
    err_red = np.max(np.abs(np.degrees(red[:, 0] - fem[:, 0])))
    err_rigid = np.max(np.abs(np.degrees(rigid[:, 0] - fem[:, 0])))
    assert err_red < 0.7 and err_rigid > 4.0 * err_red
    assert np.max(np.abs(red[:, 1] - fem[:, 1])) < 4e-3
    assert np.max(np.abs(red[:, 3])) < ENERGY_BOUND


@pytest.mark.slow
def test_rubber_torque_pulse_keeps_the_energy_balance():
    def pulse(t):
        return 2.0 if t < 0.05 else 0.0

    out = trace(create(compliant(model__fidelity="reduced")), 0.3, pulse)
    assert np.all(np.isfinite(out))
    assert np.max(np.abs(out[:, 3])) < ENERGY_BOUND


@pytest.mark.parametrize(
    "scene, picked",
    [
        (stiff(), "reduced"),  # 0.27 ms contact = 0.26 first bending periods: vibration matters, 6 modes span it
        (stiff(theta0=0.0), "reduced"),  # at rest against the wall: a torque can still drive it in (controller loop)
        (stiff(pendulum__E=2.1e13), "rigid"),  # the seed's effective stiffness: contact lasts 2.6 periods
        (stiff(model__modes=2), "fem"),  # 2 modes do not reach the band an impact excites
        (stiff(wall__kind="none"), "rigid"),
        (compliant(), "fem"),  # rubber: the impact excites ~1 kHz, far beyond a few modes
        (compliant(wall__kind="none"), "fem"),  # soft: a pivot torque bends the rod beyond a linear basis
        (
            compliant(pendulum__E=2e8, wall__kind="none"),
            "reduced",
        ),  # stiff enough for a linear basis, f1 only 78x the swing
        (stiff(wall__kind="deformable"), "fem"),
    ],
)
def test_auto_picks_the_cheapest_adequate_model_and_says_why(scene, picked, caplog):
    with caplog.at_level(logging.INFO, logger="fem_pendulum_fmu"):
        model = create(scene.with_values({"model.fidelity": "auto"}))
    assert model.fidelity == picked == selection.choose(scene).fidelity
    assert f"auto picks {picked}" in caplog.text


@pytest.mark.slow
def test_von_mises_of_the_modal_field_only_when_asked_and_as_fem_reports_it():
    """The modal displacement is a field on the FE mesh, so the reduced model reports the same
    stress measure as fem (plane-stress von Mises of the Neo-Hookean Cauchy stress). Measured:
    peaks 9.44e4 / 9.50e4 Pa swinging, 1.458e7 / 1.494e7 Pa after the impact (reduced / fem): the
    plate's ringing sampled at the doSteps' ends, which moves with the contact's internal steps (fem's
    contacts count the body's stiffness, contact_time.body_stiffness; the reduced model's do not)."""
    quiet = create(stiff(model__fidelity="reduced"))
    asked = create(stiff(model__fidelity="reduced", model__compute_stress=True))
    fem = create(stiff(model__compute_stress=True))
    red_peaks, fem_peaks = [], []
    for k in range(1, 261):
        assert quiet.advance(k * DT, 0.0).von_mises_max == 0.0
        red_peaks.append(asked.advance(k * DT, 0.0).von_mises_max)
        fem_peaks.append(fem.advance(k * DT, 0.0).von_mises_max)
    for window in (slice(0, 200), slice(235, 260)):  # swinging; after the impact at 0.24 s
        # measured: 0.59 % apart swinging (9.44e4 / 9.50e4 Pa), 2.4 % after the impact (1.458e7 / 1.494e7 Pa)
        assert max(red_peaks[window]) == pytest.approx(max(fem_peaks[window]), rel=0.03)
    assert max(red_peaks[235:]) > 10 * max(red_peaks[:200])


def _state_after(scene, t_end, torque):
    model = create(scene)
    while model.time < t_end - 1e-12:
        model.advance(round(model.time + DT, 9), torque)
    return model


def _newton_at(model, torque, dt=1e-3):
    """(the step's start, its first iterate, the Jacobian there, the residual's finite-difference Jacobian)."""
    z0, p0, _ = model._x
    newton = model._newton  # the step's numpy form (reduced/step.py)
    start = newton.start(z0, p0, torque)
    z1, _ = newton.predict(start, dt)
    ev = newton.residual(start, z1, dt)
    columns = []
    for j in range(model.n):
        e = np.zeros(model.n)
        e[j] = 1e-8
        plus, minus = newton.residual(start, z1 + e, dt), newton.residual(start, z1 - e, dt)
        columns.append((plus.residual - minus.residual) / 2e-8)
    return start, ev, newton.jacobian(ev, model._strain.hessian(ev.zm[1:]), dt), np.column_stack(columns)


def test_step_algebra_is_the_dense_one_and_its_newton_jacobian_is_exact_to_first_order():
    """The step applies M(q) as identity plus a border (O(n)); the end momentum must be the dense
    algebra's. Its Jacobian keeps the mass matrix's q-derivative and the centrifugal and Coriolis
    terms. Measured after a 2 N.m torque pulse: momentum 1e-15 off the dense one; Jacobian 3e-11
    off finite differences on steel (theta column 7e-5, against 7e-3 with the mass matrix alone),
    6.0e-3 on rubber, bent far (it leaves out terms of second order in the step)."""
    steel = _state_after(stiff(model__fidelity="reduced"), 0.05, 2.0)
    _, _, jac, fd = _newton_at(steel, 2.0)
    assert np.max(np.abs(jac - fd)) < 1e-8 * np.max(np.abs(fd))
    assert np.max(np.abs(jac[:, 0] - fd[:, 0])) < 1e-3 * np.max(np.abs(fd[:, 0]))
    rubber = _state_after(compliant(model__fidelity="reduced"), 0.05, 2.0)
    start, ev, jac, fd = _newton_at(rubber, 2.0)
    assert np.max(np.abs(jac - fd)) < 2e-2 * np.max(np.abs(fd))
    z0, z1 = start.z0, start.z0 + ev.dz
    assert np.max(np.abs(z1[1:])) > 1e-4  # the modes are well excited: the border terms matter
    A0, A1 = (np.linalg.inv(rubber.mass_matrix(z)) for z in (z0, z1))
    dense_p1 = 2.0 * np.linalg.solve(0.5 * (A0 + A1), ev.dz / 1e-3) - start.p0
    assert np.max(np.abs(ev.p1 - dense_p1)) < 1e-12 * np.max(np.abs(dense_p1))
