"""The head's boundary sample points in the deformed configuration, and which of them can reach the block.

A point X of the head is at R(theta) (X + phi(X) q). The points are grouped in runs of neighbours,
each with a bounding radius, so the gap and the contact look only at the runs that can be within
reach of the block (about 100 of the 793 points in free flight).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..box import Box
from ..rigid import arc_contact as rigid_contact
from ..scene import WallBlock
from .modes import ModalBasis

HEAD_GROUP = 8  # head points per run of the gap's and contact's exclusion test


@dataclass(frozen=True)
class HeadRuns:
    """The head points in runs of about HEAD_GROUP consecutive points (neighbours on the boundary),
    with each run's centre, radius and largest displacement per mode: what a run is culled by."""

    of_point: np.ndarray  # (P,) the run of each point
    start: np.ndarray  # (runs + 1,) run k holds points start[k] to start[k + 1] - 1
    centre: np.ndarray  # (runs, 2) body frame
    radius: np.ndarray  # (runs,)
    peak: np.ndarray  # (runs, m) largest displacement of a point of the run per mode

    @classmethod
    def of(cls, head_X: np.ndarray, head_phi: np.ndarray) -> HeadRuns:
        P = len(head_X)
        runs = np.array_split(np.arange(P), max(1, P // HEAD_GROUP))
        centre = np.array([head_X[r].mean(axis=0) for r in runs])
        return cls(
            of_point=np.concatenate([np.full(len(r), k) for k, r in enumerate(runs)]),
            start=np.cumsum([0, *map(len, runs)]),
            centre=centre,
            radius=np.array([np.max(np.linalg.norm(head_X[r] - c, axis=1)) for r, c in zip(runs, centre, strict=True)]),
            peak=np.array([np.max(np.linalg.norm(head_phi[r], axis=1), axis=0) for r in runs]),
        )


class HeadPoints:
    """The modal basis's head points (body frame X, modal displacements phi, boundary weights), placed
    at a state z and measured against the wall block."""

    def __init__(self, basis: ModalBasis, head_centre_depth: float, block: WallBlock):
        P, self.m = len(basis.head_X), basis.count
        self.X = basis.head_X  # (P, 2)
        self.phi = basis.head_phi  # (P, 2, m)
        self.weights = basis.head_weights  # (P,) boundary quadrature weights
        self._phi_flat = basis.head_phi.reshape(-1, self.m)  # (2P, m): x and y rows interleaved
        self._phi_pairs = basis.head_phi.reshape(P, -1)  # (P, 2m): a point's x row, then its y row
        self.phi_peak = np.max(np.linalg.norm(basis.head_phi, axis=1), axis=0)  # (m,) largest displacement per mode
        self.centre = (0.0, -head_centre_depth)
        self.radius = float(np.max(np.linalg.norm(basis.head_X - self.centre, axis=1)))
        self.runs = HeadRuns.of(basis.head_X, basis.head_phi)
        self.block = block
        self.box = Box.of(block)

    def positions(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(deformed positions (P, 2), body-frame positions (P, 2)) of all head points."""
        local = self.X + (self._phi_flat @ z[1:]).reshape(-1, 2)
        s, c = math.sin(z[0]), math.cos(z[0])
        return local @ np.array([[c, s], [-s, c]]), local

    def circle(self, z: np.ndarray) -> tuple[float, float, float]:
        """(centre x, centre y, radius) of a circle that holds every head point at z."""
        s, c = math.sin(z[0]), math.cos(z[0])
        cx, cy = self.centre
        radius = self.radius + float(self.phi_peak @ np.abs(z[1:]))
        return c * cx - s * cy, s * cx + c * cy, radius

    def may_touch(self, z: np.ndarray) -> bool:
        """Cheap exclusion: False when no head point can reach the block."""
        return rigid_contact.circle_may_touch(*self.circle(z), self.block)

    def candidates(self, z: np.ndarray, band: float, cutoff: float | None) -> tuple[np.ndarray, np.ndarray]:
        """(indices, positions (k, 2)) of the head points in the runs that may have a point within
        `cutoff` of the block (default: within `band` of the closest point). The distance is
        1-Lipschitz, so a run whose centre is d from the block has its points within d +- (its radius
        + its largest modal displacement)."""
        s, c = math.sin(z[0]), math.cos(z[0])
        rotation = np.array([[c, s], [-s, c]])
        q, runs = z[1:], self.runs
        reach = runs.radius + runs.peak @ np.abs(q)
        centre_gap = self.distances(runs.centre @ rotation)
        if cutoff is None:
            cutoff = float(np.min(centre_gap + reach)) + band
        points = np.flatnonzero((centre_gap - reach <= cutoff)[runs.of_point])
        displacement = (self._phi_pairs[points].reshape(-1, self.m) @ q).reshape(-1, 2)
        return points, (self.X[points] + displacement) @ rotation

    def near(self, z: np.ndarray, band: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(indices, positions (k, 2), signed distances to the block (k,)) of the head points, in their
        order, leaving out only runs of points certainly more than `band` farther from the block than
        the closest point."""
        points, world = self.candidates(z, band, None)
        return points, world, self.distances(world)

    def distances(self, world: np.ndarray) -> np.ndarray:
        """Signed distances of points (k, 2) to the block."""
        return self.box.distances(world[:, 0], world[:, 1])

    def gap(self, z: np.ndarray) -> float:
        """The smallest signed distance of the head points to the block (the gap output; numpy form
        of the compiled kernel's gap)."""
        return float(np.min(self.near(z, 0.0)[2]))
