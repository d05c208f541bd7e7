"""The Neo-Hookean law of material.py on arrays of points (numpy), for residuals evaluated without NGSolve.

A 2 x 2 tensor field at Q points is a (4, Q) array of its components
(00, 01, 10, 11); symmetric ones are (3, Q) arrays (00, 01, 11).
"""

from __future__ import annotations

import numpy as np

from ..material import GAUSS_ON_UNIT_INTERVAL


def right_cauchy_green(F: np.ndarray) -> np.ndarray:
    """C = F^T F, symmetric (3, Q)."""
    f00, f01, f10, f11 = F
    return np.stack((f00 * f00 + f10 * f10, f00 * f01 + f10 * f11, f01 * f01 + f11 * f11))


def averaged_pk2_stress(C0: np.ndarray, C1: np.ndarray, lame_lambda: float, mu: float, points: int) -> np.ndarray:
    """material.averaged_pk2_stress at points: the Gauss mean of S along C0 -> C1, symmetric (3, Q)."""
    rule = GAUSS_ON_UNIT_INTERVAL[points]
    s = np.array([p for p, _ in rule])[:, None]
    weights = np.array([w for _, w in rule])[:, None]
    c00, c01, c11 = (C0[i] + s * (C1[i] - C0[i]) for i in range(3))  # each (points, Q)
    det = c00 * c11 - c01 * c01
    scale = (lame_lambda * 0.5 * np.log(det) - mu) / det  # S = mu I + (lame_lambda/2 ln det C - mu) C^-1
    return np.stack(
        (
            mu + (weights * (scale * c11)).sum(axis=0),
            -(weights * (scale * c01)).sum(axis=0),
            mu + (weights * (scale * c00)).sum(axis=0),
        )
    )


def first_piola(F: np.ndarray, S: np.ndarray) -> np.ndarray:
    """P = F S (F as (4, Q), S symmetric (3, Q))."""
    f00, f01, f10, f11 = F
    s00, s01, s11 = S
    return np.stack((f00 * s00 + f01 * s01, f00 * s01 + f01 * s11, f10 * s00 + f11 * s01, f10 * s01 + f11 * s11))


def energy_density(C: np.ndarray, lame_lambda: float, mu: float) -> np.ndarray:
    """psi(C) of material.energy_density at the points of C (symmetric (3, Q))."""
    c00, c01, c11 = C
    log_j = 0.5 * np.log(c00 * c11 - c01 * c01)
    return 0.5 * mu * (c00 + c11 - 2.0 - 2.0 * log_j) + 0.5 * lame_lambda * log_j * log_j
