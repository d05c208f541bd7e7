"""The Newton solver's convergence test (fem/newton.py, converged) and what it buys on the steel swing."""

from __future__ import annotations

import math

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.fem.newton import RATE_FLOOR, converged
from fem_pendulum_fmu.physics.scene import stiff


def test_a_first_correction_must_itself_be_under_the_tolerance() -> None:
    assert converged(0.99, math.inf, 1.0)
    assert not converged(1.01, math.inf, 1.0)


def test_a_fast_contraction_credits_the_correction_with_its_rate() -> None:
    """At a contraction of 1e-3 the error left is about 1e-3 of the correction, taken as RATE_FLOOR of it: a
    correction of 99 tol converges (it is taken as 0.99 tol), one of 101 tol does not; at a contraction of
    0.1, above the floor, one of 9 tol is taken as its rate times itself over 0.9, 1.0 tol."""
    assert RATE_FLOOR == 0.01
    assert converged(99.0, 99e3, 1.0)
    assert not converged(101.0, 101e3, 1.0)
    assert converged(8.9, 89.0, 1.0)
    assert not converged(9.1, 91.0, 1.0)


def test_a_slow_contraction_needs_a_correction_well_under_the_tolerance() -> None:
    """At a contraction of 0.6 the error left is 1.5 times the correction: one of 0.9 tol has not converged,
    one of 0.6 tol has; a correction no smaller than the last never converges."""
    assert not converged(0.9, 1.5, 1.0)
    assert converged(0.6, 1.0, 1.0)
    assert not converged(1e-3, 1e-3, 1.0)
    assert not converged(1e-3, 0.5e-3, 1.0)


def test_free_flight_steps_take_about_two_iterations() -> None:
    """The steel swing's first 0.2 s (no contact, 200 steps of 1 ms): 2.14 iterations a step measured (this
    test's counts), where a stopping test that takes the last correction as the error left takes 3.06: 2.5
    allowed tells the two apart."""
    model = FemModel(stiff())
    steps = sum(model.advance(i * 1e-3, 0.0).substeps for i in range(1, 201))
    assert steps == 200
    assert model.newton.counts.iterations / steps <= 2.5
