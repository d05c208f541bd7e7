"""The loop's metrics on runs through the pendulum FMU whose answers are worked out here, independently:
the rigid fidelity under a linear controller (a second-order system), a free swing into the wall
(elliptic quarter period, elastic rebound), a demand held at the drive limit for a known time."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from fem_pendulum_fmu.physics.mass_properties import gravity_moment, mass_properties
from fem_pendulum_fmu.physics.scene import Scene
from fem_pendulum_fmu.testing import LoopCheckFailed, closed_loop

SCENE = Scene()  # the FMU's defaults: tests/test_interface.py
INERTIA, MGC = mass_properties(SCENE).inertia, gravity_moment(SCENE)  # kg m^2, N.m/rad
KP, KD, STEP = 8.0, 0.4, math.radians(3.0)


def second_order_figures() -> dict[str, float]:
    """I theta'' + KD theta' + (MGC + KP) theta = KP STEP linearised: final value, overshoot (closed form),
    10-90 % rise and 2 % settling time (from the analytic response on a 1 us grid)."""
    stiffness = KP + MGC
    wn, zeta = math.sqrt(stiffness / INERTIA), KD / (2 * math.sqrt(INERTIA * stiffness))
    wd, final = wn * math.sqrt(1 - zeta**2), KP * STEP / stiffness
    t = np.linspace(0.0, 2.0, 2_000_001)
    y = final * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t)))
    outside = np.flatnonzero(np.abs(y - final) > 0.02 * final)
    return {
        "steady_state_error": STEP - final,
        "overshoot": math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)),
        "rise_time": float(t[np.argmax(y >= 0.9 * final)] - t[np.argmax(y >= 0.1 * final)]),
        "settling_time": float(t[outside[-1] + 1]),
    }


@pytest.fixture(scope="module")
def pd_step(fmus):
    law = lambda t, m: KP * m.error - KD * m.omega  # noqa: E731
    return closed_loop(law, setpoint="step:3deg", stop_time=4.0, fidelity="rigid", fmu=fmus[0])


def test_a_pd_step_response_has_the_figures_of_its_second_order_system(pd_step):
    exact = second_order_figures()
    m = pd_step.metrics
    # Measured at 1 ms steps: overshoot 0.37466 against 0.37150, rise time 0.08806 s against 0.08845 s, settling
    # time 0.74996 s against 0.75122 s, steady-state error 1.02362e-2 against 1.02386e-2 rad. The hold of the
    # torque over a step delays the loop by about half a step: at 0.1 ms steps the first three differences
    # shrink tenfold (overshoot 3.1e-4 off); sin(theta) ~ theta costs theta^2 / 6 = 4.6e-4 of the gravity term.
    assert m["overshoot"] == pytest.approx(exact["overshoot"], abs=0.006)
    assert m["rise_time"] == pytest.approx(exact["rise_time"], abs=1e-3)
    assert m["settling_time"] == pytest.approx(exact["settling_time"], abs=3e-3)
    assert m["steady_state_error"] == pytest.approx(exact["steady_state_error"], rel=1e-3)
    assert m["impacts"] == 0 and m["max_contact_force"] == 0.0 and m["time_at_drive_limit"] == 0.0
    # the energy-consistent scheme balances the torque's work to round-off (measured 4e-16 J); the swing's 0.05 J
    assert m["energy_error"] < 1e-12
    pd_step.check(settles_within=0.76, overshoot_below=0.38)
    with pytest.raises(LoopCheckFailed) as failed:
        pd_step.check(settles_within=0.7, overshoot_below=0.3)
    lines = failed.value.failures
    assert lines[0].startswith("settling_time = 0.75") and lines[0].endswith("s, above the bound 0.7 s"), lines
    assert lines[1].startswith("overshoot = 0.374") and " at t = 0.2" in lines[1] and "bound 0.3" in lines[1], lines


def test_a_free_swing_into_the_wall_has_its_impact_times_and_impulses(fmus):
    """Released at 20 degrees with no torque, the rigid pendulum reaches the wall after a quarter of the free
    period, T/4 = K(sin(10 deg)) sqrt(I / m g c), and rebounds elastically every half period after: each impact
    turns omega = -sqrt(2 m g c (1 - cos 20 deg) / I) into -omega, an impulse 2 I |omega| / d of the wall's force
    on the head at the depth d of its centre, the lever arm."""
    theta0 = math.radians(20.0)
    quarter = math.sqrt(INERTIA / MGC) * ellipk(math.sin(theta0 / 2) ** 2)
    speed = math.sqrt(2 * MGC * (1 - math.cos(theta0)) / INERTIA)
    impulse = 2 * INERTIA * speed / SCENE.geometry.head_centre_depth
    r = closed_loop(lambda t, m: 0.0, stop_time=1.3, fidelity="rigid", pendulum={"theta0": theta0}, fmu=fmus[0])
    impacts = np.asarray(r.metrics.impact_times)
    assert r.metrics["impacts"] == len(impacts) == 3  # at T/4, 3T/4 and 5T/4 = 1.197 s
    # an impact's time is the end of the step it began in: within one step after the onset
    assert 0.0 <= impacts[0] - quarter < 1e-3, (impacts[0], quarter)
    # measured 0.479 s between impacts against 2 T/4 = 0.4789 s: a contact lasts a fraction of a step
    assert np.allclose(np.diff(impacts), 2 * quarter, atol=1.5e-3), (np.diff(impacts), 2 * quarter)
    # measured 0.851459 N.s against 0.851460: the penalty contact is elastic to 5e-7
    assert r.metrics["max_impulse"] == pytest.approx(impulse, rel=1e-5)
    assert r.metrics["energy_error"] < 1e-12  # measured 7e-14 J


def test_the_time_at_the_drive_limit_is_the_time_the_demand_exceeds_it(fmus):
    r = closed_loop(lambda t, m: 100.0 if t < 0.2 - 1e-9 else 0.0, stop_time=0.5, fidelity="rigid", fmu=fmus[0])
    assert r.metrics["time_at_drive_limit"] == pytest.approx(0.2, abs=1e-12)  # steps from t = 0 to 0.199 s
    assert r.series["torque"].max() == 15.0 and r.series["demand"].max() == 100.0
    with pytest.raises(LoopCheckFailed, match=r"time_at_drive_limit = 0.2 s, above the bound 0.1 s"):
        r.check(time_at_drive_limit_below=0.1)
