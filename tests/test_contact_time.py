"""contact_time.py: the depth that holds the available energy, solved piecewise in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.contact_time import body_stiffness, contact_time_scale


def _bisected(gaps: np.ndarray, weights: np.ndarray, m_eff: float, rate: float, k: float) -> tuple[float, float]:
    """The same quantities by bisection on the penalty energy, straight from its definition."""
    g_min = float(np.min(gaps))
    pen = np.maximum(-gaps, 0.0)
    e_avail = 0.5 * k * float(weights @ (pen * pen)) + 0.5 * m_eff * (min(rate, 0.0) ** 2 if g_min > 0 else rate**2)

    def energy(delta: float) -> float:
        d = np.maximum(delta - (gaps - g_min), 0.0)
        return 0.5 * k * float(weights @ (d * d))

    lo, hi = 0.0, 1.0
    for _ in range(80):
        lo, hi = (lo, 0.5 * (lo + hi)) if energy(0.5 * (lo + hi)) >= e_avail else (0.5 * (lo + hi), hi)
    return math.pi * math.sqrt(m_eff * hi * hi / (2.0 * e_avail)), hi


def test_one_point_holds_its_energy_at_the_square_root():
    """A single point of weight w: k/2 w delta^2 = m v^2 / 2, duration pi sqrt(m / (k w))."""
    duration, delta = contact_time_scale(np.array([0.002]), np.array([1e-3]), 0.5, -1.0, 2e10)
    assert delta == pytest.approx(math.sqrt(0.5 / (2e10 * 1e-3)), rel=1e-14)
    assert duration == pytest.approx(math.pi * math.sqrt(0.5 / (2e10 * 1e-3)), rel=1e-14)


def test_piecewise_solution_equals_bisection():
    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(1, 300))
        gaps = rng.uniform(-1e-4, 1e-2, n) * rng.choice([1e-3, 1.0, 10.0])
        weights = rng.uniform(1e-4, 1e-3, n)
        got = contact_time_scale(gaps, weights, 0.5, -1.0, 2e10)
        assert got == pytest.approx(_bisected(gaps, weights, 0.5, -1.0, 2e10), rel=1e-12)


def test_nothing_approaching_has_no_contact_in_view():
    assert contact_time_scale(np.array([0.01, 0.02]), np.array([1e-3, 1e-3]), 0.5, 0.3, 2e10) == (math.inf, 0.0)


def test_a_body_as_stiff_as_the_penalty_lengthens_the_contact_by_root_two():
    """The body's stiffness in series with the penalty's (k w for one point): equal stiffnesses halve it, so
    the contact lasts sqrt(2) times as long; the depth is the penalty's, which the onset is located by."""
    args = (np.array([0.002]), np.array([1e-3]), 0.5, -1.0, 2e10)
    alone, depth = contact_time_scale(*args)
    duration, depth_in_series = contact_time_scale(*args, k_body=2e10 * 1e-3)
    assert duration == pytest.approx(math.sqrt(2.0) * alone, rel=1e-14)
    assert depth_in_series == depth


def test_a_soft_body_sets_the_duration_of_its_contact():
    """Rubber (E 1 MPa, nu 0.45, 1 cm) against one point of the default penalty (5e10 N/m^2 times a weight of
    1 mm): the body is 1/4000 of it, so the duration is sqrt(1 + 1/4000), 1 + 1.2e-4, times the body's own
    pi sqrt(m / k_body)."""
    k_body = body_stiffness(1e6, 0.45, 0.01)
    assert k_body == pytest.approx(1e4 / (1.0 - 0.45**2), rel=1e-14)
    duration, _ = contact_time_scale(np.array([0.0]), np.array([1e-3]), 0.3, -1.0, 5e10, k_body=k_body)
    assert duration == pytest.approx(math.pi * math.sqrt(0.3 / k_body) * math.sqrt(1.0 + k_body / 5e7), rel=1e-14)
    assert duration / (math.pi * math.sqrt(0.3 / k_body)) - 1.0 < 1.3e-4
