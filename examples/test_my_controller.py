"""Testing your own controller against the FE pendulum, as a pytest file: `pytest examples/test_my_controller.py`.

The fixture `pendulum_loop` comes with fem_pendulum_fmu (its pytest plugin): it runs a controller in
the loop with the pendulum FMU (dist/FemPendulum.fmu, built on first use) and returns the run, whose
`series` is a table and `metrics` a mapping of metric name to value. The wall stands at theta = 0:
set-points above zero swing the pendulum away from it.
"""

import math


def pd(t, m):
    """A PD controller: torque (N.m) from the tracking error and the angular velocity measured at t."""
    return 8.0 * m.error - 0.4 * m.omega


def test_the_pd_controller_tracks_a_step_away_from_the_wall(pendulum_loop):
    result = pendulum_loop(pd, setpoint="step:10deg", stop_time=1.5)
    result.check(settles_within=1.2, overshoot_below=0.5)  # names each failed metric, its value and when
    assert result.metrics["impacts"] == 0  # it never touches the wall
    assert result.series["torque"].abs().max() < 15.0  # nor needs more than the drive gives


def test_the_pid_fmu_with_new_gains_has_no_steady_state_error(pendulum_loop):
    gains = {"Kp": 20.0, "Ki": 30.0, "Kd": 0.6}
    result = pendulum_loop("pid", controller_parameters=gains, setpoint="step:10deg", stop_time=2.0, fidelity="rigid")
    result.check(steady_state_error_below=math.radians(0.2), settles_within=1.5, max_contact_force_below=1.0)
