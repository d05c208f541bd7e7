"""contact_time.py: the depth that holds the available energy, solved piecewise in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem_pendulum_fmu.physics.contact_time import contact_time_scale


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
