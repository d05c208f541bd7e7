"""The meshed (deformable) wall block's face, as the FE model's outputs and step forms need it.

* `WallFace`: the wall's displacement on its face x = x_max as a function of
  the height y, evaluated on the face's own boundary elements (a point lookup
  in the mesh at the face also finds the pendulum's head, whose hanging
  reference boundary touches the face, and then returned the head's
  displacement: the gap read -5e-5 m with the head 9 mm away);
* `WallContact`: the contact energy and force exactly as the step forms'
  ContactBoundary counts them (penalty on the gap at the wall face's Gauss
  points, each paired with its closest head point), so that the reported
  energy balances during contact too;
* `discrete_gradient_contact`: the energy-momentum step's contact force, the
  exact discrete gradient of that energy for the pairs of the step start;
* `WallResidual`: that contact term alone, for the split residual of
  fem/residual.py.
(fem/head.py's `PairGuard` gives the pairing radius a step needs: none while
the head cannot reach the wall within the step.)
"""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import scipy.sparse
from ngsolve import BND, CF, InnerProduct, IntegrationRule, specialcf
from ngsolve.fem import BaseMappedIntegrationPoint

from ..scene import WallBlock
from .space import FemSpace

WALL_SEARCH_DISTANCE = 0.005  # m; the largest ContactBoundary pairing radius
WALL_CONTACT_INTORDER = 6  # Gauss rule on the wall face's elements (4 points at order 6)
# a head sampled this far clear of the deformed face leaves every penalty integrand 0 (sagitta < 1 um)
CLEAR_OF_FACE = 1e-5  # m
# pairing radius of an update that must leave no pairs (0 would mean NGSolve's default, 2 element sizes)
NO_PAIRS = 1e-12  # m
# head points farther from the face than this have the undeformed face's distance as their gap: the wall
# moves by a few um (3.5e-8 m out of contact, tests/test_deformable_wall.py), the gap there is > 1 cm
SHIFT_RANGE = 0.01  # m


def contact_boundary(
    space: FemSpace, um: ngs.CoefficientFunction, um_head: ngs.CoefficientFunction, factor: float
) -> ngs.ContactBoundary:
    """ContactBoundary with the energy factor * h k/2 g^2 of the gap g at the wall displacement um and
    the head's um_head, integrated on the reference wall face (deformed=False)."""
    mesh, pos = space.mesh, space.pos
    h, k = space.scene.pendulum.thickness, space.scene.contact.stiffness
    cb = ngs.ContactBoundary(mesh.Boundaries("wall_face"), mesh.Boundaries("head"))
    pen = InnerProduct((pos + um) - (pos.Other() + um_head), specialcf.normal(2))
    cb.AddEnergy(ngs.IfPos(pen, factor * h * 0.5 * k * pen * pen, 0.0), deformed=False)
    return cb


def penalty_slope(g0: ngs.CoefficientFunction, g1: ngs.CoefficientFunction, k: float) -> ngs.CoefficientFunction:
    """(Phi(g1) - Phi(g0)) / (g1 - g0) of the penalty Phi(g) = k/2 max(g, 0)^2, in closed form on each side
    of the contact's entry and exit (the denominators there are positive; the guards only keep the branches
    IfPos discards finite)."""

    def safe(d: ngs.CoefficientFunction) -> ngs.CoefficientFunction:
        return ngs.IfPos(d, d, 1.0)

    both = 0.5 * k * (g0 + g1)
    enters = 0.5 * k * g1 * g1 / safe(g1 - g0)  # g0 <= 0 < g1
    leaves = 0.5 * k * g0 * g0 / safe(g0 - g1)  # g1 <= 0 < g0
    return ngs.IfPos(g0, ngs.IfPos(g1, both, leaves), ngs.IfPos(g1, enters, 0.0))


def discrete_gradient_contact(
    space: FemSpace, u0: ngs.CoefficientFunction, u: ngs.CoefficientFunction, du: ngs.CoefficientFunction
) -> ngs.ContactBoundary:
    """The energy-momentum step's wall contact: with the pairs of the step start the gap g is affine in
    the displacement, so the force (Phi(g1) - Phi(g0)) / (g1 - g0) dg is the exact discrete gradient of
    the penalty energy, also for the wall face's Gauss points that enter or leave contact within the step
    (the midpoint force Phi'(gm) is exact only while a point stays in contact: the energy gained 1e-3 of
    the swing energy as the points entered on the coarse mesh, tests/test_deformable_wall.py)."""
    mesh, pos, n = space.mesh, space.pos, specialcf.normal(2)
    h, k = space.scene.pendulum.thickness, space.scene.contact.stiffness
    cb = ngs.ContactBoundary(mesh.Boundaries("wall_face"), mesh.Boundaries("head"))
    g0 = InnerProduct((pos + u0) - (pos.Other() + u0.Other()), n)
    g1 = InnerProduct((pos + u) - (pos.Other() + u.Other()), n)
    cb.AddIntegrator(h * penalty_slope(g0, g1, k) * InnerProduct(du - du.Other(), n), deformed=False)
    return cb


class WallResidual:
    """The wall contact term alone, on a form of its own, for a step residual evaluated apart from the full
    step form (fem/residual.py): a second ContactBoundary, paired with the step form's, and a one-bit set
    that is empty while it has no pairs (the residual then skips the form)."""

    def __init__(self, space: FemSpace, contact: ngs.ContactBoundary):
        self.form = ngs.BilinearForm(space.X)
        self.present = ngs.BitArray(1)
        self.present.Clear()
        self._cb = contact

    def update(self, u0: ngs.GridFunction, maxdist: float) -> None:
        """Pair as the step form was paired: at u0 within maxdist (NO_PAIRS: none)."""
        self._cb.Update(u0, self.form, intorder=WALL_CONTACT_INTORDER, maxdist=maxdist)
        if maxdist > NO_PAIRS:
            self.present.Set(0)
        else:
            self.present.Clear()


class WallFace:
    """The wall's displacement at heights y on its face, exact on the face's elements.

    Each face element is a straight segment in y; its displacement is a polynomial of the model's order
    in the segment's parameter, kept as its values at order + 1 nodes (a sparse matrix of u)."""

    def __init__(self, space: FemSpace):
        mesh, V, order = space.mesh, space.V, space.scene.model.order
        self.nodes = np.linspace(0.0, 1.0, order + 1)
        # points mapped from the MeshPoints of a rule, which Python owns: trafo(t) hands over a point that is
        # never freed (residual.volume_rule says more), 47 kB a model here; the numbers are the same
        ends_rule, nodes_rule = IntegrationRule([(0.0,), (1.0,)]), IntegrationRule([(float(t),) for t in self.nodes])
        segments = []
        gf = ngs.GridFunction(V)
        vec = gf.vec.FV().NumPy()
        rows, cols, vals = [], [], []
        face = [el for el in mesh.Elements(BND) if el.mat == "wall_face"]
        for el in face:
            trafo = mesh.GetTrafo(ngs.ElementId(el))
            ends = [float(space.pos(BaseMappedIntegrationPoint(p))[1]) for p in trafo(ends_rule)]
            segments.append((min(ends), ends[0], ends[1], trafo, V.GetDofNrs(ngs.ElementId(el))))
        segments.sort(key=lambda s: s[0])
        n = len(self.nodes)
        for i, (_, _, _, trafo, dofs) in enumerate(segments):
            mips = [BaseMappedIntegrationPoint(p) for p in trafo(nodes_rule)]
            for d in dofs:
                vec[:] = 0.0
                vec[d] = 1.0
                for j, mip in enumerate(mips):
                    ux, uy = gf(mip)
                    for comp, value in ((0, ux), (1, uy)):
                        if value != 0.0:
                            rows.append(comp * len(segments) * n + i * n + j)
                            cols.append(d)
                            vals.append(value)
        shape = (2 * len(segments) * n, V.ndof)
        self._sample = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=shape)
        self._lower = np.array([s[0] for s in segments])
        self._start = np.array([s[1] for s in segments])
        self._end = np.array([s[2] for s in segments])
        self._n_seg = len(segments)

    def displacement(self, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(len(y), 2): the wall's displacement at the face points of reference heights y (within the face)."""
        seg = np.clip(np.searchsorted(self._lower, y, side="right") - 1, 0, self._n_seg - 1)
        t = (y - self._start[seg]) / (self._end[seg] - self._start[seg])
        # Lagrange basis of the nodes at t
        basis = np.ones((len(y), len(self.nodes)))
        for j, tj in enumerate(self.nodes):
            for m, tm in enumerate(self.nodes):
                if m != j:
                    basis[:, j] *= (t - tm) / (tj - tm)
        values = (self._sample @ u).reshape(2, self._n_seg, len(self.nodes))
        return np.stack([np.sum(basis * values[c, seg], axis=1) for c in (0, 1)], axis=1)

    def shift(self, p: np.ndarray, u: np.ndarray, block: WallBlock) -> np.ndarray:
        """Displacement of the face point level with each point p (zero for points not level with the face,
        or farther than SHIFT_RANGE from it): the reference height y0 of the face point whose deformed
        height is p_y, y0 + u_y(y0) = p_y, by one fixed-point step from y0 = p_y (u_y is of the order of um)."""
        out = np.zeros_like(p)
        level = (p[:, 1] > block.y_min) & (p[:, 1] < block.y_max) & (p[:, 0] < block.x_max + SHIFT_RANGE)
        if np.any(level):
            y = p[level, 1]
            y0 = np.clip(y - self.displacement(y, u)[:, 1], block.y_min, block.y_max)
            out[level] = self.displacement(y0, u)
        return out


class WallContact:
    """Contact energy and force of a displacement, counted as the step forms count them: the same
    ContactBoundary energy (the wall face's Gauss points paired with their closest head points at this
    displacement), evaluated by NGSolve on a form of its own."""

    def __init__(self, space: FemSpace):
        u = space.V.TrialFunction()
        self._cb = contact_boundary(space, u, u.Other(), 1.0)
        self._form = ngs.BilinearForm(space.V)
        self._gf = ngs.GridFunction(space.V)
        self._res = self._gf.vec.CreateVector()
        # the pendulum translated by one metre in x: the residual along it is minus the wall's force in x
        shift = ngs.GridFunction(space.V)
        shift.Set(CF((1.0, 0.0)), definedon=space.mesh.Materials("pendulum"))
        self._ex = shift.vec.FV().NumPy().copy()
        # (u, result) of the last two u asked about: a contact step asks for each end twice (impulse, force)
        self._known: list[tuple[np.ndarray, tuple[float, float]]] = []

    def energy_and_force(self, u: np.ndarray) -> tuple[float, float]:
        """(contact energy, x force of the wall on the pendulum) at displacement u (never changed in place)."""
        for known in self._known:
            if known[0] is u:
                return known[1]
        self._gf.vec.FV().NumPy()[:] = u
        self._cb.Update(self._gf, self._form, intorder=WALL_CONTACT_INTORDER, maxdist=WALL_SEARCH_DISTANCE)
        energy = float(self._form.Energy(self._gf.vec))
        self._form.Apply(self._gf.vec, self._res)
        result = energy, -float(self._ex @ self._res.FV().NumPy())
        self._known = [(u, result), *self._known[:1]]
        return result
