"""Compressible Neo-Hookean material as NGSolve coefficient functions.

psi(C) = mu/2 (tr C - 2 - 2 ln J) + lame_lambda/2 (ln J)^2 with J = sqrt(det C): zero
energy and zero stress in the reference state, plane-stress Lame parameters
(lame_lambda*, mu) so that it linearises to plane-stress Hooke's law. Energies here
are per unit reference area; callers multiply by the thickness.
"""

from __future__ import annotations

import numpy as np
from ngsolve import CoefficientFunction, Det, Grad, Id, Inv, Trace, log, sqrt

# Gauss-Legendre points on [0, 1] for the averaged stress of the discrete gradient
GAUSS_ON_UNIT_INTERVAL = {
    # leggauss(n) gives n points and n weights
    n: tuple(
        zip((np.polynomial.legendre.leggauss(n)[0] + 1) / 2, np.polynomial.legendre.leggauss(n)[1] / 2, strict=True)
    )
    for n in (1, 2, 3)
}


def right_cauchy_green(F: CoefficientFunction) -> CoefficientFunction:
    return F.trans * F


def energy_density(C: CoefficientFunction, lame_lambda: float, mu: float) -> CoefficientFunction:
    log_j = 0.5 * log(Det(C))
    return 0.5 * mu * (Trace(C) - 2 - 2 * log_j) + 0.5 * lame_lambda * log_j * log_j


def pk2_stress(C: CoefficientFunction, lame_lambda: float, mu: float) -> CoefficientFunction:
    """Second Piola-Kirchhoff stress S = 2 dpsi/dC."""
    C_inv = Inv(C)
    return mu * (Id(2) - C_inv) + lame_lambda * 0.5 * log(Det(C)) * C_inv


def averaged_pk2_stress(
    C0: CoefficientFunction, C1: CoefficientFunction, lame_lambda: float, mu: float, points: int
) -> CoefficientFunction:
    """2 x the mean of dpsi/dC along the straight path C0 -> C1 (Gauss rule).

    This is the averaged-vector-field discrete gradient in C: S : (C1 - C0)/2
    equals psi(C1) - psi(C0) up to the quadrature error, so the internal work
    over a step equals the change of strain energy, and a rigid rotation
    (C0 = C1 = I) produces no stress at all."""
    dC = C1 - C0
    total = None
    for s, w in GAUSS_ON_UNIT_INTERVAL[points]:
        term = w * pk2_stress(C0 + s * dC, lame_lambda, mu)
        total = term if total is None else total + term
    return total


def cauchy_stress(F: CoefficientFunction, lame_lambda: float, mu: float) -> CoefficientFunction:
    J = Det(F)
    return (1 / J) * F * pk2_stress(right_cauchy_green(F), lame_lambda, mu) * F.trans


def von_mises_plane_stress(F: CoefficientFunction, lame_lambda: float, mu: float) -> CoefficientFunction:
    s = cauchy_stress(F, lame_lambda, mu)
    return sqrt(s[0, 0] ** 2 + s[1, 1] ** 2 - s[0, 0] * s[1, 1] + 3 * s[0, 1] ** 2)


def deformation_gradient(u: CoefficientFunction) -> CoefficientFunction:
    return Id(2) + Grad(u)
