"""Penalty contact with the rigid wall block, energy-consistent over a time step.

The law (shared by every fidelity): a boundary point at position p inside the
block is pushed out by the pressure k * d(p), where d(p) is the depth below
the nearest face, d(p) = min(x_max - px, px - x_min, y_max - py, py - y_min).
Its energy per unit reference length is k/2 * max(d, 0)^2.

Over a step p0 -> p1 the force is the discrete gradient of that energy:
Phi'(d0, d1) = (Phi(d1) - Phi(d0)) / (d1 - d0) times the discrete gradient of d
(Gonzalez's midpoint formula, which is the plain face normal while both ends
see the same face). Its work over the step is exactly Phi(d1) - Phi(d0), so
contact neither creates nor destroys energy, whatever the step size.
"""

from __future__ import annotations

from ngsolve import CF, CoefficientFunction, IfPos, InnerProduct

from ..scene import WallBlock

_EPS_LEN = 1e-30


def _min_with_normal(
    a: CoefficientFunction, na: CoefficientFunction, b: CoefficientFunction, nb: CoefficientFunction
) -> tuple[CoefficientFunction, CoefficientFunction]:
    """(min(a, b), normal of the smaller) as coefficient functions."""
    return IfPos(a - b, b, a), IfPos(a - b, nb, na)


def depth_and_gradient(p: CoefficientFunction, block: WallBlock) -> tuple[CoefficientFunction, CoefficientFunction]:
    """Inside depth d(p) (negative outside) and its gradient, as coefficient functions."""
    faces = [
        (block.x_max - p[0], CF((-1.0, 0.0))),
        (p[0] - block.x_min, CF((1.0, 0.0))),
        (block.y_max - p[1], CF((0.0, -1.0))),
        (p[1] - block.y_min, CF((0.0, 1.0))),
    ]
    d, g = faces[0]
    for df, gf in faces[1:]:
        d, g = _min_with_normal(d, g, df, gf)
    return d, g


def penalty_energy(d: CoefficientFunction, k: float) -> CoefficientFunction:
    return IfPos(d, 0.5 * k * d * d, 0.0)


def discrete_gradient_force(
    p0: CoefficientFunction, p1: CoefficientFunction, block: WallBlock, k: float
) -> CoefficientFunction:
    """Energy-consistent contact traction per unit reference length (force on the body)."""
    d0, _ = depth_and_gradient(p0, block)
    d1, _ = depth_and_gradient(p1, block)
    pm = 0.5 * (p0 + p1)
    dm, gm = depth_and_gradient(pm, block)
    jump = d1 - d0
    # (Phi(d1) - Phi(d0)) / (d1 - d0), with Phi' at the midpoint when d1 ~ d0
    distinct = jump * jump - 1e-28
    safe_jump = IfPos(distinct, jump, 1.0)
    phi_slope = IfPos(distinct, (penalty_energy(d1, k) - penalty_energy(d0, k)) / safe_jump, IfPos(dm, k * dm, 0.0))
    dp = p1 - p0
    len2 = InnerProduct(dp, dp)
    correction = IfPos(len2 - _EPS_LEN, (jump - InnerProduct(gm, dp)) / IfPos(len2 - _EPS_LEN, len2, 1.0), 0.0) * dp
    return -phi_slope * (gm + correction)
