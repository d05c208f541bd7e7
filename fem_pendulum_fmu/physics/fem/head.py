"""The FE model's sample points on the head's outer boundary.

Positions X + u are evaluated there vectorised (numpy: a sparse matrix maps
the displacement dofs to the points, and the last two displacements' distances
to the block are kept, as every step asks for them twice) for what the step
control and the contact set need: the gap and its rate at the closest point,
which head elements can reach the block within a step (contact is assembled on
those only); for the meshed wall the gap is taken to its deformed face
(fem/wall.py), and `PairGuard` tells when no contact pair can form.
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse

from ..box import Box
from ..contact_time import ClosestPoint
from ..fe_boundary import head_points
from ..sparse import MatVec, int32_indices
from .space import FemSpace, FemState
from .wall import WALL_SEARCH_DISTANCE, WallFace

# added to the reach of a step (PairGuard): it covers the wall face's displacement (um) and the head curve
# between its sample points (< 1 um)
PAIR_MARGIN = 1e-4  # m


def trace_matrix(space: FemSpace, points: ngs.comp.MeshPoints, elements: np.ndarray) -> scipy.sparse.csr_matrix:
    """The (2P x nV) matrix E with E @ u = (x components, y components) of the displacement u at the P
    points on the head elements: columns only for the dofs of those elements, the others vanish there."""
    gf = ngs.GridFunction(space.V)
    vec = gf.vec.FV().NumPy()
    dofs = sorted({d for e in elements for d in space.V.GetDofNrs(ngs.ElementId(ngs.BND, int(e))) if d >= 0})
    columns = []
    for d in dofs:
        vec[:] = 0.0
        vec[d] = 1.0
        columns.append(np.asarray(gf(points)).T.ravel())
    dense = np.array(columns).T
    rows, cols = np.nonzero(dense)
    shape = (dense.shape[0], space.nV)
    return int32_indices(scipy.sparse.csr_matrix((dense[rows, cols], (rows, np.array(dofs)[cols])), shape=shape))


class HeadBoundary:
    """Gauss points of the head boundary (the contact forms' rule) and the contact set they decide."""

    def __init__(self, space: FemSpace):
        head = head_points(space.mesh, space.contact_order)
        self._space = space
        self.points = head.points
        self.X = space.pos(head.points)  # reference positions (P, 2)
        self.weights = head.weights
        self.elements = head.elements
        self.point_element = np.repeat(np.arange(len(head.elements)), len(head.rule))
        self.active_local = np.zeros(0, dtype=int)  # head elements (local indices) with contact assembled
        self._is_active = np.zeros(len(head.elements), dtype=bool)  # the same as a mask
        self._closest: tuple[FemState, ClosestPoint] | None = (
            None  # (state, closest point) of the last state asked about
        )
        self._trace = trace_matrix(space, head.points, head.elements)
        self._trace_of = MatVec(self._trace)
        self._face = WallFace(space) if space.deformable_wall else None
        self._box = Box.of(space.scene.block)
        # (u, positions, signed distances to the undeformed block) of the last two u asked about
        self._distances: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._velocities: tuple[np.ndarray | None, np.ndarray] = (None, np.zeros((0, 2)))  # (v, values) of the last v

    @property
    def trace(self) -> scipy.sparse.csr_matrix:
        """The (2P x nV) matrix of a displacement's values at the points (trace_matrix)."""
        return self._trace

    def positions(self, u: np.ndarray) -> np.ndarray:
        return self.X + self.values(u)

    def values(self, w: np.ndarray) -> np.ndarray:
        """A displacement (or velocity) field's values at the points, (P, 2)."""
        return self._trace_of(w).reshape(2, -1).T

    def velocities(self, v: np.ndarray) -> np.ndarray:
        """The velocity field v's values at the points, (P, 2), kept for the last v asked about (known by
        identity): a step's end state is asked for its closest point's rate, then for its reach."""
        if self._velocities[0] is not v:
            self._velocities = (v, self.values(v))
        return self._velocities[1]

    def distances(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the points at displacement u and their signed distances to the undeformed block
        (the block's normal only where it is asked for, at the closest point: at every point it cost
        twice the distances). The arrays of a state are never changed in place, so u is known by identity."""
        for known in self._distances:
            if known[0] is u:
                return known[1], known[2]
        p = self.positions(u)
        dist = self._box.distances(p[:, 0], p[:, 1])
        self._distances = [(u, p, dist), *self._distances[:1]]
        return p, dist

    def reachable(self, xs: FemState, dt: float) -> np.ndarray:
        """Head elements (local indices) whose points could reach the block during a step of dt from xs."""
        dist = self.distances(xs.u)[1]
        speed = np.hypot(*self.velocities(xs.v).T)
        reach = 3.0 * float(np.max(speed)) * dt + 1e-4
        return np.unique(self.point_element[dist < reach])

    def activate(self, bits: ngs.BitArray, elements: np.ndarray) -> None:
        """Assemble contact on exactly these head elements (bits: the step form's BitArray)."""
        if np.array_equal(elements, self.active_local):
            return  # the bits as they are (a step in contact mostly keeps the set of the step before)
        bits.Clear()
        for e in self.elements[elements]:
            bits.Set(int(e))
        self.active_local = np.array(elements, dtype=int)
        self._is_active[:] = False
        self._is_active[self.active_local] = True

    def widened_contact_set(self, u1: np.ndarray) -> np.ndarray | None:
        """None if every head point inside the block at the step's end u1 is on the active set; else the
        set widened to their elements (fem/step_loader.py activates it)."""
        touching = self.point_element[self.distances(u1)[1] < 0.0]
        if self._is_active[touching].all():
            return None
        return np.union1d(self.active_local, touching)

    def closest_point(self, xs: FemState) -> ClosestPoint:
        """The head point closest to the (deformed) wall and its rate.

        The stepper asks for the gap and then for the contact scales of the same
        state; the last answer is kept so the boundary is evaluated once."""
        if self._closest is not None and self._closest[0] is xs:
            return self._closest[1]
        if self._face is not None:
            p = self.positions(xs.u)
            p = p - self._face.shift(p, xs.u, self._space.scene.block)
            dist = self._box.distances(p[:, 0], p[:, 1])
        else:
            p, dist = self.distances(xs.u)
        i = int(np.argmin(dist))
        nx, ny = self._box.normal(float(p[i, 0]), float(p[i, 1]))
        vel = self.velocities(xs.v)[i]
        result = ClosestPoint(p, dist, i, (nx, ny), float(nx * vel[0] + ny * vel[1]))
        self._closest = (xs, result)
        return result


class PairGuard:
    """The pairing radius a step needs: the reach of the step, 3 times the largest velocity coefficient
    of the start state (the nodal velocities of pendulum and wall) times the step (as for the rigid
    wall's contact set) plus PAIR_MARGIN, plus the head's depth in the wall (a wall point inside the
    head is that close to it); 0 when the head is farther from the face than its reach, as no pair could
    then act within the step."""

    def __init__(self, space: FemSpace, v0: ngs.GridFunction, dt: ngs.Parameter):
        head = head_points(space.mesh, space.contact_order)
        self._x = space.pos(head.points)[:, 0]
        self._trace_x = trace_matrix(space, head.points, head.elements)[: len(self._x)]
        self._face_x = space.scene.block.x_max
        self._v0, self._dt = v0, dt

    def radius(self, u0: np.ndarray) -> float:
        """At the step start u0 (the step's v0 and dt as loaded); the x distance bounds the distance."""
        gap_x = float(np.min(self._x + self._trace_x @ u0)) - self._face_x
        reach = 3.0 * float(np.max(np.abs(self._v0.vec.FV().NumPy()))) * self._dt.Get() + PAIR_MARGIN
        if gap_x > reach:
            return 0.0
        return min(reach + max(-gap_x, 0.0), WALL_SEARCH_DISTANCE)
