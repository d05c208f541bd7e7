"""Impacts visible at any sampling rate: contact_force_max and contact_impulse.

A steel impact lasts about 0.34 ms, so 1 ms communication steps rarely sample a contact force;
contact_force_max (the largest force at the internal steps of a doStep) and contact_impulse (the
scheme's contact impulse over the doStep) report it anyway.

Momentum check, derived from the models' own quantities. The wall's contact face is the block's
right face x = x_max (scene.WallBlock), so the penalty force on the head is along the face normal
+x. A force F along +x at a point p has the moment p_x F_y - p_y F_x = -p_y F about the pivot (0, 0):
its lever is the contact point's depth below the pivot. The rigid model's contact moment is
-dE/dtheta = -h k int d p_y ds (rigid_contact.penalty: jd = p_y on that face) with the depth
d = x_max - p_x symmetric about the level of the head's centre, so the moment is exactly F times the
head centre's depth D cos(theta), D = geometry.head_centre_depth. The FE head deforms by
micrometres, so the same lever holds there to ~1e-5. Across the doSteps with an impulse,

    I (omega_after - omega_before) = D cos(theta) J - int m g d sin(theta) dt   (torque 0)

with I from the kinetic energy of the rigid swing before the impact (I = 2 E_kin / omega^2: the
model's inertia as the model counts it; for fem, omega is its angular momentum over the current
inertia) and m g d from the potential energy (-m g d cos(theta), zero at the pivot level).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmu_runner import col, run_schedule

from fem_pendulum_fmu.physics.scene import PendulumGeometry

DT = 1e-3
STEPS = 300  # the first impact is near theta = 0, a quarter period (about 0.27 s) after release from 20 deg
CASES = {
    "rigid": {"model.fidelity": "rigid"},
    "reduced": {"model.fidelity": "reduced"},
    "fem": {"model.fidelity": "fem", "model.mesh_size": 0.06},
}


@pytest.fixture(scope="module")
def runs(fmus):
    fmu, _ = fmus
    return {name: run_schedule(str(fmu), params, [(DT, 0.0)] * STEPS)[0] for name, params in CASES.items()}


@pytest.mark.parametrize("fidelity", list(CASES))
def test_the_impact_shows_in_contact_force_max_whatever_the_sampling(runs, fidelity):
    run = runs[fidelity]
    gap_min, force_max, impulse = col(run, "gap_min"), col(run, "contact_force_max"), col(run, "contact_impulse")
    hits = np.flatnonzero(gap_min < 0.0)
    assert hits.size, "no impact in the run"
    first = hits[0]
    assert force_max[first] > 0.0 and impulse[first] > 0.0  # the doStep of the first impact
    assert np.all(force_max >= col(run, "contact_force"))
    free = gap_min > 0.0  # doSteps with no point in contact: nothing to report
    assert np.all(force_max[free] == 0.0) and np.all(impulse[free] == 0.0)


@pytest.mark.parametrize("fidelity", ["rigid", "fem"])
def test_moment_of_the_impulse_is_the_jump_of_angular_momentum(runs, fidelity):
    run = runs[fidelity]
    impulse = col(run, "contact_impulse")
    steps = np.flatnonzero(impulse > 0.0)
    first, last = steps[0], steps[0]
    while last + 1 < len(run) and impulse[last + 1] > 0.0:
        last += 1  # the doSteps of the first impact (row i: after the i-th doStep)
    before, after = first - 1, last
    theta, omega = col(run, "theta"), col(run, "omega")
    inertia = 2.0 * col(run, "energy.kinetic")[before] / omega[before] ** 2
    mgd = -col(run, "energy.potential")[before] / math.cos(theta[before])
    window = slice(before, after + 1)
    torque = mgd * np.sin(theta[window])
    gravity = -DT * float(np.sum(torque[1:] + torque[:-1])) / 2.0  # trapezoid rule (numpy 1.24 has no np.trapezoid)
    lever = PendulumGeometry().head_centre_depth * math.cos(np.mean(theta[window]))
    moment = lever * float(np.sum(impulse[first : last + 1]))
    jump = inertia * (omega[after] - omega[before]) - gravity
    assert omega[before] < 0.0 < omega[after]  # a rebound
    assert moment == pytest.approx(jump, rel=0.02)


@pytest.mark.parametrize("fidelity", ["rigid", "reduced"])
def test_a_restored_state_reports_the_step_it_was_taken_after(fidelity):
    """contact_force_max and contact_impulse describe the last step, like gap_min: set_state puts them back."""
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.protocol import ModelState
    from fem_pendulum_fmu.physics.scene import stiff

    model = create(stiff(model__fidelity=fidelity))
    while model.outputs().contact_impulse == 0.0:
        model.advance(round(model.time + DT, 9), 0.0)
    saved, taken = model.get_state(), model.outputs()
    model.advance(round(model.time + 0.02, 9), 0.0)
    assert model.outputs().contact_impulse == 0.0  # rebounded
    for state in (saved, ModelState.from_bytes(saved.to_bytes())):
        model.set_state(state)
        out = model.outputs()
        assert (out.contact_force_max, out.contact_impulse) == (taken.contact_force_max, taken.contact_impulse)
        assert out.contact_impulse > 0.0
