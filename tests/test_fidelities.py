"""The contract every fidelity keeps: one protocol, bit-identical state round trips,
determinism, energy balance under a torque, and bad input refused with the state kept.

Each test runs rigid, reduced and fem, driven through tests/fidelity_runs.py's `run`. The
round trip and the energy balance run the stiff scene through the first impact (about 0.2 s
with the torque below) with a torque on, so contact, elasticity and torque work are all
exercised. The energy bound: the rigid and reduced steps balance energy to their Newton
tolerance (<= 1e-11 of the energies a step moves, summed over a few hundred steps), the FE
model to its Newton tolerance and the averaged stress (measured <= 3e-5 of the swing energy
on this run); 1e-4 of the swing energy holds all three with margin and is 10x below what a
trapezoidal rule gains at one impact (the seed's Newmark scheme at 1 ms steps gains more than
1e-2 of it, tests/test_seed_schemes.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fidelity_runs import finite, run, same_bits

from fem_pendulum_fmu.physics.fidelity import AVAILABLE, PendulumModel, create
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.protocol import ModelState, StepFailed
from fem_pendulum_fmu.physics.reduced.model import ReducedModel
from fem_pendulum_fmu.physics.rigid.model import RigidModel
from fem_pendulum_fmu.physics.scene import rubber, steel

FIDELITIES = ("rigid", "reduced", "fem")


def model(fidelity, **values):
    return create(steel(model__fidelity=fidelity, **values))


def torque(t):
    return -0.5 * math.sin(25.0 * t)  # pushes towards the wall: first impact at about 0.2 s


def test_every_fidelity_is_available_behind_the_protocol():
    assert set(FIDELITIES) == set(AVAILABLE)
    for fidelity in FIDELITIES:
        m = model(fidelity)
        assert isinstance(m, PendulumModel) and m.fidelity == fidelity


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_state_round_trip_and_determinism_are_bit_identical(fidelity):
    m = model(fidelity)
    run(m, 0.2, torque)
    saved = m.get_state()
    snapshot = saved.to_bytes()
    first = run(m, 0.26, torque)  # across the first impact
    assert np.min(first.gap_min) < 0.0
    assert saved.to_bytes() == snapshot  # the returned state is a copy: running on does not change it
    m.set_state(saved)
    assert same_bits(run(m, 0.26, torque), first)
    other = model(fidelity)
    other.set_state(ModelState.from_bytes(saved.to_bytes()))
    assert same_bits(run(other, 0.26, torque), first)
    assert other.outputs() == m.outputs()
    fresh = model(fidelity)
    run(fresh, 0.2, torque)
    assert same_bits(run(fresh, 0.26, torque), first)


def wave(t):
    return 3.0 * math.sin(20.0 * t)


# (scene, torque, end): steel driven through two impacts; rubber under a constant torque, whose soft body takes its
# own paths (element order 3, the contact update, the soft discrete gradient)
FRESH_RUNS = {"steel": (steel, wave, 0.6), "rubber": (rubber, 0.1, 0.05)}


@pytest.mark.parametrize("preset", FRESH_RUNS)
@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_two_fresh_models_give_the_same_bits(fidelity, preset):
    scene, drive, end = FRESH_RUNS[preset]
    first = run(create(scene(model__fidelity=fidelity)), end, drive)
    assert same_bits(run(create(scene(model__fidelity=fidelity)), end, drive), first)


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_energy_balances_the_torque_work_through_an_impact(fidelity):
    m = model(fidelity)
    e0 = m.outputs().energy_total
    out = run(m, 0.26, torque)
    assert np.min(out.gap_min) < -1e-5  # it did hit the wall
    swing = swing_energy(m.scene)
    balance = out.energy_total - e0 - out.energy_torque_work
    assert finite(out)
    assert np.max(np.abs(balance)) < 1e-4 * swing
    assert np.max(np.abs(out.energy_torque_work)) > 1e-3  # the torque did real work
    if fidelity == "rigid":
        assert np.all(out.energy_strain == 0.0)
    else:
        assert np.max(out.energy_strain) > 0.0


@pytest.mark.parametrize("fidelity", FIDELITIES)
@pytest.mark.parametrize(
    "name, value, allowed",
    [
        ("pendulum.nu", 0.5, "[0, 0.5)"),
        ("pendulum.E", 0.0, "(0, inf)"),
        ("model.modes", 0, "[1, 200]"),
    ],
)
def test_bad_parameters_are_refused_naming_value_and_range(fidelity, name, value, allowed):
    with pytest.raises(ValueError) as err:
        create(steel(model__fidelity=fidelity).with_values({name: value}))
    assert name in str(err.value) and repr(value) in str(err.value) and allowed in str(err.value)


BAD_ADVANCES = [(0.01, 0.0), (0.005, 0.0), (math.nan, 0.0), (math.inf, 0.0), (0.02, math.nan), (0.02, math.inf)]


def unsolvable(m) -> bytes:
    """Make m's next step fail at every size, and return its state's bytes: rigid and reduced, advanced in the
    compiled core, get velocities so large that a step overflows; fem, stepped in Python, a step that fails."""
    state = m.get_state()
    if m.fidelity == "fem":
        m.step = lambda *args: None
        return state.to_bytes()
    if m.fidelity == "rigid":
        state.scalars["omega"] = 1e308
    else:
        state.arrays["p"][:] = 1e308
    with np.errstate(over="ignore", invalid="ignore"):  # the outputs of such a state overflow too
        m.set_state(state)
    return m.get_state().to_bytes()


@pytest.mark.parametrize("fidelity", FIDELITIES)
def test_bad_calls_raise_and_keep_the_state(fidelity):
    m = model(fidelity)
    m.advance(0.01, 0.0)
    before = m.get_state().to_bytes()
    for t_end, tq in BAD_ADVANCES:  # a time not after the current one, not finite; a torque not finite
        with pytest.raises(ValueError, match="torque|t_end"):
            m.advance(t_end, tq)
        assert m.get_state().to_bytes() == before, (t_end, tq)
    wrong = "fem" if fidelity != "fem" else "rigid"
    with pytest.raises(ValueError, match="fidelity"):
        m.set_state(ModelState(wrong, 0.0, {}, {}))
    assert m.get_state().to_bytes() == before
    before = unsolvable(m)  # a state no step size can solve
    with pytest.raises(StepFailed):
        m.advance(0.02, 0.0)
    assert m.get_state().to_bytes() == before


@pytest.mark.parametrize("fidelity", ("rigid", "reduced"))
def test_only_fem_models_a_deformable_wall(fidelity):
    with pytest.raises(ValueError, match="deformable"):
        model(fidelity, wall__kind="deformable")
    model_class = {"rigid": RigidModel, "reduced": ReducedModel}[fidelity]
    with pytest.raises(ValueError, match="deformable"):  # the class itself, not only create()
        model_class(steel(wall__kind="deformable"))
