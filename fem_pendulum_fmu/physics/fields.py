"""Nodal fields of a body on the vertices of its NGSolve mesh, for field output (ParaView, animations).

`VertexSampler` evaluates coefficient functions at the vertices of every triangle of one region (a
fixed set of mapped points, built once) and averages the values of the triangles that meet at a
vertex: the identity for continuous fields (displacement, velocity), the usual nodal average for
stresses. `rigid_motion` is the displacement and velocity of a rigid rotation about the pivot;
`best_fit_rotation` reads the rotation back from such vertex fields (field output, animations).
"""

from __future__ import annotations

import math

import ngsolve as ngs
import numpy as np

from .protocol import BodyField

# NGSolve's reference triangle has its vertices 0, 1, 2 at (1, 0), (0, 1), (0, 0)
_VERTEX_RULE = ((1.0, 0.0), (0.0, 1.0), (0.0, 0.0))


class VertexSampler:
    """Vertex values of coefficient functions on the triangles of one region of a mesh."""

    def __init__(self, mesh: ngs.Mesh, region: str):
        elements = list(mesh.Elements(ngs.VOL))
        mine = np.array([el.mat == region for el in elements])
        vertices = np.array([[v.nr for v in el.vertices] for el in elements], dtype=np.int64)[mine]
        used, local = np.unique(vertices, return_inverse=True)
        everywhere = np.array([v.point for v in mesh.vertices], dtype=float)
        self.region = region
        self.points = everywhere[used]  # (N, 2) reference positions
        self.cells = local.reshape(-1, 3).astype(np.int64)  # (M, 3) into points
        rule = ngs.IntegrationRule([tuple(p) for p in _VERTEX_RULE], [0.0] * 3)
        self._mapped = mesh.MapToAllElements(rule, ngs.VOL)
        self._rows = (3 * np.flatnonzero(mine)[:, None] + np.arange(3)).ravel()  # mapped points of the region
        self._count = np.bincount(self.cells.ravel(), minlength=len(self.points)).astype(float)

    def values(self, cf: ngs.CoefficientFunction) -> np.ndarray:
        """(N, dim) values of `cf` at the vertices, averaged over the triangles meeting there ((N,) if scalar)."""
        raw = np.asarray(cf(self._mapped))
        raw = raw.reshape(raw.shape[0], -1)[self._rows]
        total = np.zeros((len(self.points), raw.shape[1]))
        np.add.at(total, self.cells.ravel(), raw)
        mean = total / self._count[:, None]
        return mean[:, 0] if mean.shape[1] == 1 else mean


def rigid_motion(points: np.ndarray, theta: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """(displacement, velocity) of points X rotated by theta about the pivot (0, 0) at rate omega."""
    c, s = math.cos(theta), math.sin(theta)
    x = np.column_stack([c * points[:, 0] - s * points[:, 1], s * points[:, 0] + c * points[:, 1]])
    return x - points, omega * np.column_stack([-x[:, 1], x[:, 0]])


def body_field(
    sampler: VertexSampler, displacement: np.ndarray, velocity: np.ndarray, von_mises: np.ndarray
) -> BodyField:
    """A BodyField on the sampler's vertices."""
    return BodyField(sampler.region, sampler.points, sampler.cells, displacement, velocity, von_mises)


def best_fit_rotation(points: np.ndarray, cells: np.ndarray, displacement: np.ndarray) -> float:
    """Area-weighted best-fit rotation about the pivot (0, 0) of the displaced points, in rad."""
    a, b, c = (points[cells[:, i]] for i in range(3))
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    weight = np.zeros(len(points))
    for i in range(3):
        np.add.at(weight, cells[:, i], area / 3.0)
    x = points + displacement
    cross = np.sum(weight * (points[:, 0] * x[:, 1] - points[:, 1] * x[:, 0]))
    dot = np.sum(weight * (points[:, 0] * x[:, 0] + points[:, 1] * x[:, 1]))
    return math.atan2(cross, dot)
