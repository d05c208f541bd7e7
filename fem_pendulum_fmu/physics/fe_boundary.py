"""Quantities on the FE mesh's named boundaries that the FE model and the modal reduction share.

* the head boundary's quadrature points, where contact and the gap are sampled,
  with the reference arc length each point stands for;
* the hinge torque's follower load: a line load on the hinge edge with the
  zero-mean weight x / w, scaled so that its moment about the pivot is one.
"""

from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs
import numpy as np
from ngsolve import BND, CF, SEGM, Integrate, IntegrationRule, specialcf, x, y

from .scene import PendulumGeometry


@dataclass(frozen=True)
class HeadPoints:
    """Gauss points on the head's outer boundary ("head")."""

    rule: IntegrationRule  # on one boundary element
    points: object  # the mapped points of every head element (ngsolve MeshPoints)
    weights: np.ndarray  # (P,) reference arc length belonging to each point
    elements: np.ndarray  # (E,) mesh boundary element numbers of the head, in the points' order


def head_points(mesh: ngs.Mesh, order: int) -> HeadPoints:
    """The head boundary's Gauss points of a rule exact to `order`, and their arc-length weights."""
    rule = IntegrationRule(SEGM, order)
    points = mesh.MapToAllElements(rule, mesh.Boundaries("head"))
    lengths = Integrate(CF(1.0), mesh, BND, element_wise=True).NumPy()
    head_els = [el.nr for el in mesh.Elements(BND) if el.mat == "head"]
    weights = np.concatenate([lengths[e] * np.array([ip.weight for ip in rule]) for e in head_els])
    return HeadPoints(rule, points, weights, np.array(head_els))


def hinge_torque_load(mesh: ngs.Mesh, geometry: PendulumGeometry) -> tuple[ngs.CoefficientFunction, float]:
    """(weight, scale): the hinge edge's load weight x / w (a coefficient function) and the factor
    1 / int weight (x N_y - y N_x) ds that makes the moment of scale * weight * N one."""
    N = specialcf.normal(2)
    weight = x / geometry.rod_half_width
    arm = x * N[1] - y * N[0]
    return weight, 1.0 / Integrate(weight * arm, mesh, BND, definedon=mesh.Boundaries("hinge"))
