"""The held Jacobian updated for the rigid wall's contact instead of re-assembled with it (Woodbury's identity).

In an impact the held Jacobian, assembled in free flight, lacks the penalty's
stiffness, which at a contact's 20 us steps is of the order of the inertia's
at the head: without it the iterations contract by 1/20 to 1/50 where a
Jacobian with the contact in it contracts by 1e-4, and on rubber the held
Jacobian would be re-assembled for nearly every change of the contact set.
The contact term's Jacobian is small and simple: at each listed
head point it is c g g^T in the point's position X + E u
(core/fem_rigid_contact.c, femp_rigid_contact_stiffness), so on the unknowns V
of the contact set's elements (both components of their basis functions,
10 to 14 on the steel and rubber meshes) it is V K V^T. With A the held
Jacobian, assembled without the contact (SplitJacobian's with_contact), the
correction of A + V K V^T is z - G M V^T z with z = A^-1 r, G = A^-1 V and
M = (I + K V^T G)^-1 K. G takes one solve per unknown of V and is kept while
the factors and the set stay (here); K and M are made in the kernel at each
iterate, the normals turned into the held Jacobian's frame (V holds both
components of each node, so the turn maps it onto itself; core/fem_elastic.c,
low_rank_prepare and low_rank_update).
"""

from __future__ import annotations

import numpy as np

from ..core import ffi, pointer
from ..scene import Scene
from .iteration import FusedIteration
from .lu import HeldFactor
from .rigid_contact import RigidContactKernel


def use_contact_update(scene: Scene) -> bool:
    """Whether the FE model updates its held factors for the rigid wall's contact: on soft bodies
    (scene.Material.soft), whose penalty is thousands of times the body's own stiffness (rubber: 10 %
    fewer instructions over 2 s, 59 % fewer Jacobians). On steel, whose body is 40 times stiffer than
    the penalty, the held Jacobian without the contact takes one iteration more a contact step, and the
    update costs more than it saves (+0.3 % over 2 s, +2 % on the 0.005 m mesh)."""
    return scene.pendulum.soft


class ContactUpdate:
    """prepare(): hand the fused iteration the update for the loaded contact set and the held factors
    (none while the set is empty); the kernel makes K and M at each iterate."""

    def __init__(self, contact: RigidContactKernel, factor: HeldFactor, size: int, iteration: FusedIteration):
        self._contact, self._factor, self._size, self._iteration = contact, factor, size, iteration
        self._points = np.zeros(0, dtype=np.int32)
        self._version = -1  # of the factors G was solved with
        self._arrays: tuple[np.ndarray, ...] = ()  # what the struct points to
        self._struct = ffi.new("struct femp_low_rank *")
        self._handed = False  # whether the fused iteration has the struct

    def prepare(self) -> None:
        points = self._contact.points
        if len(points) == 0 or self._factor.version == 0:  # no contact set, or no factors yet
            if self._handed:
                self._iteration.low_rank(ffi.NULL)
                self._handed = False
            return
        if len(points) != len(self._points) or not np.array_equal(points, self._points):
            self._points = points.copy()
            self._for_set(points)
        if self._version != self._factor.version:
            self._solve()
        if not self._handed:
            self._iteration.low_rank(self._struct)
            self._handed = True

    @property
    def in_use(self) -> bool:
        """Whether the fused iteration has the update (a contact set and factors)."""
        return self._handed

    def _for_set(self, points: np.ndarray) -> None:
        """V's unknowns (the columns of the points' rows of E), those rows on them, and the scratch."""
        trace = self._contact.trace
        rows_x, rows_y = trace[points], trace[points + trace.shape[0] // 2]
        dofs = np.union1d(rows_x.indices, rows_y.indices).astype(np.int32)
        m, n = len(dofs), len(points)
        ex, ey = (np.ascontiguousarray(rows[:, dofs].toarray()) for rows in (rows_x, rows_y))
        g, s = np.zeros((m, self._size)), np.zeros((m, m))
        self._arrays = (dofs, g, s, ex, ey, np.zeros((3, n)), np.zeros((2, m, m)), np.zeros(2 * m))
        dofs, g, s, ex, ey, stiffness, km, y = self._arrays
        st = self._struct
        st.m, st.n_points, st.dofs, st.G, st.S = m, n, pointer(dofs), pointer(g), pointer(s)
        st.ex, st.ey, st.y = pointer(ex), pointer(ey), pointer(y)
        st.c, st.gx, st.gy = (pointer(row) for row in stiffness)
        st.K, st.B = (pointer(block) for block in km)
        self._version = -1

    def _solve(self) -> None:
        """G = A^-1 V (its rows: the columns) and S = V^T G with the factors as they are now."""
        dofs, g, s = self._arrays[:3]
        unit = np.zeros(self._size)
        for j, dof in enumerate(dofs):
            unit[dof] = 1.0
            self._factor.solve(unit, g[j])
            unit[dof] = 0.0
        s[:] = g[:, dofs].T
        self._version = self._factor.version
