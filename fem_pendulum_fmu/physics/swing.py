"""Reading a sampled swing: when the pendulum rebounded from the wall, and how high it swung after.

Plain functions over the output series a master records (one sample per
communication step); tests, benchmarks and masters share them, so that "a
rebound" means one thing everywhere. The energy a swing is measured against
is mass_properties.swing_energy.
"""

from __future__ import annotations

import numpy as np


def rebounds(omega: np.ndarray, gap: np.ndarray, band: float = 1e-3, speed: float = 0.0) -> np.ndarray:
    """Indices i of the sample intervals [i, i + 1] in which the pendulum rebounded from the wall.

    A stiff impact lasts about 0.3 ms, so it mostly falls between two 1 ms samples
    and the sampled contact force misses it; what a sample cannot miss is its
    effect: omega turns from towards the wall (below -speed) to away from it
    (> 0) within the interval while the gap is below `band` at one end of it.

    Parameters
    ----------
    omega, gap : sampled angular velocity (rad/s) and gap (m).
    band : gap (m) under which the wall is within reach.
    speed : how fast (rad/s) the pendulum must have moved towards the wall; a positive value keeps
        a pendulum resting on the wall from counting.
    """
    omega, gap = np.asarray(omega), np.asarray(gap)
    return np.nonzero((omega[:-1] < -speed) & (omega[1:] > 0) & ((gap[:-1] < band) | (gap[1:] < band)))[0]


def peaks_after_first_contact(theta: np.ndarray, min_gap: np.ndarray) -> np.ndarray:
    """Indices of the samples at which theta has a local maximum (not below the sample before,
    above the one after), from the sample after the first with min_gap < 0 (from the second
    sample if there is none): the heights of the rebounds."""
    theta = np.asarray(theta)
    first = int(np.argmax(np.asarray(min_gap) < 0))
    return np.array(
        [i for i in range(first + 1, len(theta) - 1) if theta[i] >= theta[i - 1] and theta[i] > theta[i + 1]], dtype=int
    )
