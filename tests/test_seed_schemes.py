"""The seed's schemes as options of the FE model (solver.scheme), and the gap_min output.

They exist so that the work-precision benchmark compares the seed's time
integration with ours on the same mesh, material and contact law; these tests
check that they are what they claim to be (trapezoidal Newmark, the seed's step
rule) and that our default scheme is untouched by them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fem.seed_stepping import gap_rule_step
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import stiff

COARSE = {"model.mesh_size": 0.06}


def newmark(scheme: str = "newmark_fixed", dt: float = 1e-3, **values):
    return create(stiff(**{**COARSE, "solver.scheme": scheme, "solver.max_step": dt, **values}))


def test_newmark_steps_are_the_trapezoidal_rule():
    model = newmark(dt=2.5e-4)
    model.advance(1e-3, 0.0)
    s0 = model.get_state()
    out = model.advance(1.25e-3, 0.0)
    s1 = model.get_state()
    assert out.substeps == 1
    dt = 2.5e-4
    u0, v0, a0 = (s0.arrays[k] for k in "uva")
    u1, v1, a1 = (s1.arrays[k] for k in "uva")
    scale = np.max(np.abs(v1))
    assert np.max(np.abs(v1 - (2 / dt * (u1 - u0) - v0))) <= 1e-9 * scale
    assert np.max(np.abs(u1 - (u0 + dt * v0 + dt * dt / 4 * (a0 + a1)))) <= 1e-12 + 1e-9 * np.max(np.abs(u1 - u0))


def test_newmark_starts_from_the_consistent_acceleration():
    """Angular acceleration of the start state = -m g d sin(theta0) / I (the seed starts from 0)."""
    model = newmark()
    a0 = model.get_state().arrays["a"]
    u0 = model.get_state().arrays["u"]
    cross_a = model.measures.cross @ a0
    alpha = (float(model.measures.l_rot @ a0) - float(u0 @ cross_a)) / model.inertia0  # int rho h (X + u) x a / I
    expected = -model.total_mass * 9.81 * model.com_depth * math.sin(math.radians(20)) / model.inertia0
    assert alpha == pytest.approx(expected, rel=1e-3)


@pytest.mark.slow
def test_newmark_agrees_with_our_scheme_in_free_flight_at_small_steps():
    ours = create(stiff(**COARSE))
    seed = newmark(dt=1e-4)
    for k in range(1, 151):
        a, b = ours.advance(k * 1e-3, 0.0), seed.advance(k * 1e-3, 0.0)
    assert a.gap > 0.01  # still in free flight
    assert abs(a.theta - b.theta) < 1e-5


def test_the_gap_rule_steps():
    assert [gap_rule_step(g, 2e-3) for g in (-1e-5, 5e-4, 3e-3, 7e-3, 0.05)] == [1e-4, 1e-4, 5e-4, 1e-3, 2e-3]
    model = newmark("newmark_gap_rule", dt=1e-3)
    counts = []
    for k in range(1, 260):
        out = model.advance(k * 1e-3, 0.0)
        counts.append((out.substeps, model.last_min_gap))
    assert counts[0][0] == 1  # far from the wall: the base step
    assert any(n == 10 for n, g in counts if g < 1e-3)  # under 1 mm: steps of 1e-4 s


@pytest.mark.slow
def test_newmark_at_the_seeds_step_misses_the_energy_balance_ours_keeps():
    """At dt = 1 ms the whole 0.34 ms impact falls inside one trapezoidal step, whose rule averages the penalty force
    across the kink where contact starts and ends and so gains energy; the energy-consistent steps do not."""
    errors = {}
    for name, model in (("ours", create(stiff(**COARSE))), ("newmark", newmark(dt=1e-3))):
        e0 = model.outputs().total
        worst = 0.0
        for k in range(1, 301):
            out = model.advance(k * 1e-3, 0.0)
            worst = max(worst, abs(out.total - e0 - out.torque_work))
        errors[name] = worst / swing_energy(model.scene)
    assert errors["ours"] < 1e-4
    assert errors["newmark"] > 1e-2


def test_newmark_state_round_trip_and_refusals():
    model = newmark(dt=5e-4)
    model.advance(0.01, 0.0)
    state = model.get_state()
    first = model.advance(0.02, 0.0)
    model.set_state(state)
    again = model.advance(0.02, 0.0)
    assert again.theta == first.theta and again.omega == first.omega
    with pytest.raises(ValueError, match="solver.scheme"):
        model.set_state(create(stiff(**COARSE)).get_state())
    with pytest.raises(ValueError, match=r"solver.scheme = 'newmark_fixed' is an option of the fem fidelity"):
        create(stiff(**{"model.fidelity": "rigid", "solver.scheme": "newmark_fixed"}))


@pytest.mark.parametrize("fidelity", ["fem", "rigid"])
def test_gap_min_sees_the_penetration_between_communication_points(fidelity):
    model = create(stiff(**{**COARSE, "model.fidelity": fidelity}))
    assert model.outputs().min_gap == model.outputs().gap
    gaps, mins = [], []
    for k in range(1, 260):
        out = model.advance(k * 1e-3, 0.0)
        gaps.append(out.gap)
        mins.append(out.min_gap)
    assert all(m <= g for m, g in zip(mins, gaps, strict=True))  # appended together
    assert min(mins) < -3e-5  # the impact's 55-65 um penetration, whether or not a sample falls in it
    assert min(mins) < min(gaps)
