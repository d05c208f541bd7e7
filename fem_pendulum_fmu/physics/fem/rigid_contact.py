"""The rigid wall's contact term of the step residual in the compiled core (femp_rigid_contact,
core/fem_rigid_contact.c), in place of its NGSolve form's `Apply`.

In an impact every Newton iteration would apply that form: on the steel scene's
mesh about 20 us a call, an eighth of an impact's time with the rest of the
iteration compiled. The term is a sum
over the head boundary's Gauss points of the form's own rule (fe_boundary.head_points):
the discrete-gradient force of contact_law.py from the step's start position to
the iterate's, times the test functions there (fem/head.py's trace matrix), the
point's ds weight and the thickness. The kernel makes it on the points of the
contact set's elements only. Its Jacobian at the points (`stiffness`) updates the solver's held
factors (fem/contact_update.py).
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from ngsolve import specialcf

from ..core import ffi, lib, pointer
from .head import HeadBoundary
from .space import FemSpace


def compiled_contact(space: FemSpace, head: HeadBoundary) -> RigidContactKernel | None:
    """The compiled term for a rigid wall with contact on; else None."""
    return RigidContactKernel(space, head) if space.contact_on else None


def ds_weights(space: FemSpace, head: HeadBoundary) -> np.ndarray:
    """Each head point's weight in the form's boundary integral: its rule weight times the length of the
    element map's tangent there (the curved elements' arc length per reference length)."""
    tangent = np.asarray(specialcf.JacobianMatrix(2, 1)(head.points)).reshape(len(head.weights), 2)
    rule = np.array([ip.weight for ip in ngs.IntegrationRule(ngs.SEGM, space.contact_order)])
    return np.tile(rule, len(head.elements)) * np.hypot(tangent[:, 0], tangent[:, 1])


class RigidContactKernel:
    """apply(w, res): res = the rigid-wall contact term at w on the loaded contact set (False, res untouched,
    while the set is empty); load(u0) and activate(elements) follow the step's inputs. `address` is its
    struct, for the fused iteration (fem/iteration.py), which makes the term in the same call."""

    def __init__(self, space: FemSpace, head: HeadBoundary):
        self._head = head
        trace = head.trace
        indptr = np.ascontiguousarray(trace.indptr, dtype=np.int32)
        indices = np.ascontiguousarray(trace.indices, dtype=np.int32)
        data = np.ascontiguousarray(trace.data, dtype=float)
        self._X = np.ascontiguousarray(head.X.T.ravel())  # x coordinates, then y
        self._p0 = self._X.copy()
        self._u0 = np.zeros(head.trace.shape[1])
        weights = space.scene.pendulum.thickness * ds_weights(space, head)
        b = space.scene.block
        block = np.array([b.x_min, b.x_max, b.y_min, b.y_max])
        self._points: np.ndarray = np.zeros(0, dtype=np.int32)
        self._per_element = len(weights) // len(head.elements)  # the points of local element e: nq e + 0..nq-1
        self._keep = (indptr, indices, data, weights, block)  # the arrays the struct points to
        c = self._c = ffi.new("struct femp_rigid_contact *")
        c.n, c.points, c.P = 0, pointer(self._points), len(weights)
        c.indptr, c.indices, c.data = pointer(indptr), pointer(indices), pointer(data)
        c.X, c.p0, c.weights = pointer(self._X), pointer(self._p0), pointer(weights)
        c.block, c.k = pointer(block), space.scene.contact.stiffness
        self.address = c

    def load(self, u0: np.ndarray) -> None:
        """The step's start displacement: its positions at the points are made once a point is listed."""
        self._u0 = u0

    def activate(self, elements: np.ndarray) -> None:
        """The contact set: these head elements (local indices), as HeadBoundary.activate marks them. Free
        flight, an empty set, costs neither the points' list nor their start positions."""
        if len(elements) == 0 and self._c.n == 0:
            return
        nq = self._per_element
        self._points = (np.asarray(elements, dtype=np.int32)[:, None] * nq + np.arange(nq, dtype=np.int32)).ravel()
        self._c.n, self._c.points = len(self._points), pointer(self._points)
        if len(self._points):  # X + trace u0 as the head's positions at u0 hold it (made for the contact set)
            self._p0.reshape(2, -1)[:] = self._head.distances(self._u0)[0].T

    def apply(self, w: np.ndarray, res: np.ndarray) -> bool:
        """res = the term at w (float64 arrays over the solver's unknowns, displacements first)."""
        return bool(lib.femp_rigid_contact(self._c, pointer(w), len(res), pointer(res)))

    @property
    def points(self) -> np.ndarray:
        """The listed points (the contact set's elements' points), indices into the head's points."""
        return self._points

    @property
    def trace(self) -> sp.csr_matrix:
        """E: the head points' positions X + E u, 2P rows (x components, then y) over the solver's unknowns."""
        return self._head.trace

    def stiffness(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c, gx, gy) at the listed points for w: the term's Jacobian is c g g^T in each point's position
        (femp_rigid_contact_stiffness)."""
        n = len(self._points)
        out = np.empty((3, n))
        lib.femp_rigid_contact_stiffness(self._c, pointer(w), n, *(pointer(row) for row in out))
        return out[0], out[1], out[2]

    def resultant(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """The force of the wall on the pendulum that the term applies from the points' positions p0 to p1
        ((P, 2) arrays, C order) over all points; p0 = p1: the penalty force at them (N, vector)."""
        out, a, b = np.empty(2), np.ascontiguousarray(p0, dtype=float), np.ascontiguousarray(p1, dtype=float)
        lib.femp_rigid_contact_resultant(self._c, pointer(a), pointer(b), pointer(out))
        return out
