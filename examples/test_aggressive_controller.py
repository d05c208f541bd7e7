"""A controller test that fails on purpose: `pytest examples/test_aggressive_controller.py` shows what
a failed check says (docs/guide/controller_testing.md quotes it).

The controller drives the pendulum into the wall at theta = 0 with a stiff gain and no damping, so
the head bangs the wall again and again.
"""


def aggressive(t, m):
    """A proportional controller with a gain far too high for a set-point behind the wall."""
    return 200.0 * m.error


def test_the_aggressive_controller_is_gentle_with_the_wall(pendulum_loop):
    result = pendulum_loop(aggressive, setpoint="step:-5deg", stop_time=0.5, pendulum={"theta0": 0.2})
    result.check(max_contact_force_below=2000.0, impacts_at_most=1, rms_error_below=0.05)
