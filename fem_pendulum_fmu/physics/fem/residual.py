"""The energy-momentum step form's residual without NGSolve's per-call element loop: assembled matrices
for its linear terms, the compiled kernel for its stress, NGSolve only for the wall contact.

Of the step form's 0.18 ms residual on the steel scene's default mesh, the
inertia term alone, linear in the unknowns, cost 0.075 ms: a BilinearForm's
Apply evaluates the shape functions of every element at every call, whatever
the integrand. The terms linear in the unknowns w = (u1, hinge multipliers)
are therefore assembled once:

* inertia  (2 / dt^2) M (u1 - u0 - dt v0), M the mass matrix of every body;
* gravity, a constant vector;
* the hinge's mean-displacement constraint and its multipliers' load, a matrix;
* the follower torque at the midpoint configuration, T (w_t + T1 (u0 + u1) / 2):
  its load Cof(F) N is linear in F for 2 x 2 matrices.

The discrete-gradient stress is summed at the form's own integration points
from precomputed basis gradients (`ElasticTerms`: physics/core/fem_elastic.c),
and only the wall contact, on the head elements within reach, is integrated
by NGSolve. The sum is the same residual
as the full form's up to round-off (tests/test_fem_residual.py), and the full
form stays the source of the Newton Jacobian.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import ngsolve as ngs
import numpy as np
import scipy.sparse as sp
from ngsolve import H1, TRIG, VOL, BilinearForm, Cof, Grad, InnerProduct, IntegrationRule, LinearForm, specialcf
from ngsolve.fem import BaseMappedIntegrationPoint

from .. import material
from ..core import ffi, lib, pointer
from ..scene import Material
from ..sparse import nonzero_entries, require_halves_share_columns, scipy_matrix
from .space import FemSpace

if TYPE_CHECKING:
    from .rigid_contact import RigidContactKernel


class LinearTerms:
    """The step form's terms linear in w, as sparse matrices and vectors over the space X."""

    def __init__(self, space: FemSpace, torque_weight: ngs.CoefficientFunction):
        sc, X = space.scene, space.X
        h, g = sc.pendulum.thickness, sc.gravity
        (u, q1, q2), (du, p1, p2) = X.TnT()
        mass = BilinearForm(X)
        gravity = LinearForm(X)
        for region, mat in space.bodies:
            mass += mat.rho * h * InnerProduct(u, du) * ngs.dx(region)
            gravity += mat.rho * h * g * du[1] * ngs.dx(region)
        hinge = BilinearForm((q1 * du[0] + q2 * du[1] + p1 * u[0] + p2 * u[1]) * ngs.ds("hinge"))
        N = specialcf.normal(2)
        # the torque's line load per unit torque_load: -weight Cof(I + G) N = -weight (N + Cof(G) N)
        torque_rest = LinearForm(-InnerProduct(torque_weight * N, du) * ngs.ds("hinge"))
        torque_grad = BilinearForm(-InnerProduct(torque_weight * (Cof(Grad(u).Trace()) * N), du) * ngs.ds("hinge"))
        # without NGSolve's stored zeros: half the mass's entries, and every iteration reads them
        forms = (mass, hinge, torque_grad)
        self.mass, self.hinge, self.torque_grad = (nonzero_entries(scipy_matrix(f.Assemble().mat)) for f in forms)
        self._args = [
            (m.shape[0], pointer(m.indptr), pointer(m.indices), pointer(m.data))
            for m in (self.mass, self.hinge, self.torque_grad)
        ]
        self.gravity = gravity.Assemble().vec.FV().NumPy().copy()
        self.torque_rest = torque_rest.Assemble().vec.FV().NumPy().copy()
        self._nV = space.nV
        self._coeffs = (0.0, 0.0)
        self._constant, self._w0, self._wv = np.zeros(X.ndof), np.zeros(X.ndof), np.zeros(X.ndof)
        self._moved = np.zeros(X.ndof)  # w - u0 - dt v0 (the multipliers' entries unused: M is 0 there)
        self._moved_at = pointer(self._moved)

    def load(self, u0: np.ndarray, v0: np.ndarray, dt: float, torque_load: float) -> None:
        """The step's inputs: the part of the residual that does not depend on w is computed here, once.
        The inertia term stays (2 / dt^2) M (w - u0 - dt v0), the difference taken first as in the form:
        2 / dt^2 M w - 2 / dt^2 M (u0 + dt v0) lost every digit at the 1e-9 s steps of an impact's onset."""
        nV, w0, wv, constant = self._nV, self._w0, self._wv, self._constant
        w0[:nV] = u0
        np.multiply(v0, dt, out=wv[:nV])
        wv[:nV] += u0
        inertia = self.inertia_coefficient(dt)
        np.copyto(constant, self.gravity)
        if torque_load != 0.0:
            constant += torque_load * self.torque_rest
            self._add_torque_grad(0.5 * torque_load, w0, constant)
        self._coeffs = (inertia, 0.5 * torque_load)

    def kernel_arrays(self) -> tuple[list[tuple], tuple[Any, Any, Any]]:
        """The core's arguments of the mass, hinge and torque matrices (rows, indptr, indices, data
        pointers), and the pointers to the constant part, u0 + dt v0 and the scratch w - u0 - dt v0."""
        return self._args, (pointer(self._constant), pointer(self._wv), self._moved_at)

    @property
    def coefficients(self) -> tuple[float, float]:
        """The loaded step's factors on the mass matrix and on the torque's matrix T1."""
        return self._coeffs

    @staticmethod
    def inertia_coefficient(dt: float) -> float:
        """The inertia term's factor on the mass matrix: (2 / dt^2) M (u1 - u0 - dt v0)."""
        return 2.0 / (dt * dt)

    def _add_torque_grad(self, a: float, x: np.ndarray, y: np.ndarray) -> None:
        """y += a T1 x, T1 the torque load's matrix."""
        lib.femp_csr_axpy(*self._args[2], a, pointer(x), pointer(y))

    def add(self, w: np.ndarray, out: np.ndarray, at: tuple[Any, Any], first: bool) -> None:
        """out += the linear terms' residual at w (both contiguous, at the pointers `at`); first: out
        holds nothing yet, and is overwritten."""
        inertia, half_torque = self._coeffs
        if first:
            np.copyto(out, self._constant)
        else:
            out += self._constant
        np.subtract(w, self._wv, out=self._moved)
        at_vectors = (self._moved_at, at[0], at[0])
        axpy = lib.femp_csr_axpy
        for a, args, x in zip((inertia, 1.0, half_torque), self._args, at_vectors, strict=True):
            if a != 0.0:
                axpy(*args, a, x, at[1])


@dataclass
class VolumeRule:
    """A body's integration points (the step form's rule, exact to 2 order): the gradients of the
    scalar basis there and the points' weights (reference weight x measure x thickness)."""

    grad: sp.csr_matrix  # (2 Q, scalar dofs): rows 0..Q-1 d/dx, rows Q..2Q-1 d/dy
    weights: np.ndarray  # (Q,)


def volume_rule(space: FemSpace, region: str) -> VolumeRule:
    """The rule of the step form's volume terms on a region, as NGSolve integrates them."""
    mesh, order = space.mesh, space.scene.model.order
    scalar = H1(mesh, order=order)
    if 2 * scalar.ndof != space.nV:
        raise ValueError("the displacement space is not two copies of H1 of its order")
    rule = IntegrationRule(TRIG, 2 * order)
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    dx_vals: list[np.ndarray] = []
    dy_vals: list[np.ndarray] = []
    weights: list[float] = []
    for el in mesh.Elements(VOL):
        if el.mat != region:
            continue
        ei = ngs.ElementId(el)
        fel, dofs = scalar.GetFE(ei), np.array(scalar.GetDofNrs(ei))
        # points mapped from the rule's MeshPoints are Python's and freed with it: one made by trafo(x, y) is
        # never freed (NGSolve hands it over by reference; 58 kB a model, tests/test_fmu_memory.py); same numbers
        for point, weight in zip(mesh.GetTrafo(ei)(rule), rule.weights, strict=True):
            mip = BaseMappedIntegrationPoint(point)
            dshape = np.array(fel.CalcDShape(mip))
            rows.append(np.full(len(dofs), len(weights)))
            cols.append(dofs)
            dx_vals.append(dshape[:, 0])
            dy_vals.append(dshape[:, 1])
            weights.append(weight * mip.measure)
    q = len(weights)
    r, c = np.concatenate(rows), np.concatenate(cols)
    grad = sp.csr_matrix(
        (np.concatenate(dx_vals + dy_vals), (np.concatenate((r, r + q)), np.concatenate((c, c)))),
        shape=(2 * q, scalar.ndof),
    )
    return VolumeRule(grad, np.array(weights) * space.scene.pendulum.thickness)


MOST_BASIS = 32  # femp_stress_tangent's local block holds at most this many basis functions a point


def point_blocks(grad: sp.csr_matrix, q: int, n_scalar: int) -> tuple[np.ndarray, np.ndarray]:
    """femp_stress_tangent's blocks of a rule's q points (its d/dx rows of grad): consecutive points with the
    same basis functions (an element's) share one block of (2 k)^2 entries, k their count. Returns the start
    of each point's block and the (row, column) unknowns of every block's entries, row-major, x components
    before y (the d/dy rows hold the d/dx rows' columns in the same order: require_halves_share_columns)."""
    counts = np.diff(grad.indptr[: q + 1])
    if counts.max(initial=0) > MOST_BASIS:
        raise ValueError(f"a point of the rule holds over {MOST_BASIS} basis functions")
    padded = np.full((q, MOST_BASIS), -1, dtype=np.int64)  # each point's basis functions, -1 after them
    within = np.arange(grad.indptr[q]) - np.repeat(grad.indptr[:q], counts)
    padded[np.repeat(np.arange(q), counts), within] = grad.indices[: grad.indptr[q]]
    first = np.ones(q, dtype=bool)  # a point that opens a block: its basis functions differ from the last's
    first[1:] = np.any(padded[1:] != padded[:-1], axis=1)
    opening = np.flatnonzero(first)
    k_of = counts[opening]  # each block's basis functions
    sizes = (2 * k_of) ** 2
    block_start = np.cumsum(sizes) - sizes
    pairs = np.empty((int(sizes.sum()), 2), dtype=np.int64)
    for k in np.unique(k_of):  # the blocks of k basis functions at once (one k per element type)
        ours = opening[k_of == k]
        both = np.concatenate((padded[ours, :k], padded[ours, :k] + n_scalar), axis=1)  # (blocks, 2 k)
        rows = np.repeat(both, 2 * k, axis=1)  # entry (i, j) of a block: row both[i], column both[j]
        cols = np.tile(both, (1, 2 * k))
        at = (block_start[k_of == k][:, None] + np.arange(4 * k * k)).ravel()
        pairs[at] = np.stack((rows.ravel(), cols.ravel()), axis=1)
    starts = block_start[np.cumsum(first) - 1]
    return starts.astype(np.int32), pairs


@dataclass
class _Body:
    """One body's rule and material, in the arrays the kernel reads."""

    rule: VolumeRule
    lame_lambda: float  # Lame's first parameter
    mu: float
    gauss_s: np.ndarray  # the discrete gradient's Gauss points on [0, 1] and weights
    gauss_w: np.ndarray
    indptr: np.ndarray  # rule.grad as int32 CSR arrays
    indices: np.ndarray
    F0: np.ndarray  # (Q, 4) and (Q, 3): F and C of the step's start, set by load
    C0: np.ndarray
    F1: np.ndarray  # the same of the last displacement min_det_F checked: the next step's start, once accepted
    C1: np.ndarray

    def kernel_args(self, nS: int) -> tuple[tuple, tuple]:
        """The core's arguments before u and between u and out (pointers to arrays that stay put)."""
        rule = self.rule
        head = (len(rule.weights), pointer(self.indptr), pointer(self.indices), pointer(rule.grad.data), nS)
        middle: tuple[Any, ...] = (pointer(self.F0), pointer(self.C0), pointer(rule.weights))
        middle += (self.lame_lambda, self.mu, len(self.gauss_w), pointer(self.gauss_s), pointer(self.gauss_w))
        return head, middle


class ElasticTerms:
    """The discrete-gradient stress term h P(F0, F1) : Grad(du) of every body: the same integrand and
    rule as the step form's, in the compiled core (core/fem_elastic.c)."""

    def __init__(self, space: FemSpace, dg_points: Callable[[Material], int]):
        self._bodies = []
        for region, mat in space.bodies:
            rule = volume_rule(space, region)
            gauss = material.GAUSS_ON_UNIT_INTERVAL[dg_points(mat)]
            q = len(rule.weights)
            require_halves_share_columns(rule.grad)
            self._bodies.append(
                _Body(
                    rule,
                    *mat.lame,
                    np.array([s for s, _ in gauss]),
                    np.array([w for _, w in gauss]),
                    rule.grad.indptr.astype(np.int32),
                    rule.grad.indices.astype(np.int32),
                    np.zeros((q, 4)),
                    np.zeros((q, 3)),
                    np.zeros((q, 4)),
                    np.zeros((q, 3)),
                )
            )
        self.nS = space.nV // 2
        self._args = [b.kernel_args(self.nS) for b in self._bodies]
        self._checked: np.ndarray | None = None  # the displacement whose F and C the bodies' F1 and C1 hold

    def load(self, u0: np.ndarray) -> None:
        """The step's start displacement: its F and C (copied where min_det_F made them, at its end)."""
        if u0 is self._checked:
            for b in self._bodies:
                np.copyto(b.F0, b.F1)
                np.copyto(b.C0, b.C1)
            return
        u0 = np.ascontiguousarray(u0, dtype=float)
        for (head, _), b in zip(self._args, self._bodies, strict=True):
            lib.femp_deformation(*head, pointer(u0), pointer(b.F0), pointer(b.C0))

    def add(self, u: np.ndarray, out: np.ndarray, at: tuple[Any, Any]) -> None:
        """out[:nV] += the stress term's residual at the end displacement u (both contiguous, at the
        pointers `at`)."""
        for head, middle in self._args:
            lib.femp_stress_residual(*head, at[0], *middle, at[1])

    @property
    def kernel_args(self) -> list[tuple[tuple, tuple]]:
        """Per body, femp_stress_residual's arguments before u and between u and out (_Body.kernel_args)."""
        return self._args

    def local_unknowns(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per body, femp_stress_tangent's local unknowns: (start of each point's block, shared by the
        consecutive points of an element; the unknowns of the blocks' entries as (row, column) pairs,
        flattened: x components of the element's basis functions, then y)."""
        return [point_blocks(b.rule.grad, len(b.rule.weights), self.nS) for b in self._bodies]

    def add_tangent(self, u: np.ndarray, slots: list[tuple[np.ndarray, np.ndarray]], out: np.ndarray) -> None:
        """out[slots] += the stress term's Jacobian in the end displacement u, each body's slots the positions
        in out of its local_unknowns' pairs."""
        at = pointer(u)
        for (head, middle), (start, slot) in zip(self._args, slots, strict=True):
            lib.femp_stress_tangent(*head, at, *middle, pointer(start), pointer(slot), pointer(out))

    def min_det_F(self, u: np.ndarray) -> float:
        """The smallest det F of the displacement u at the rule's points of every body."""
        return self._deformation_min_det(u)

    def _deformation_min_det(self, u: np.ndarray) -> float:
        """femp_min_det's result by femp_deformation, which keeps u's F and C for load (u known by identity)."""
        at, bodies = pointer(np.ascontiguousarray(u, dtype=float)), zip(self._args, self._bodies, strict=True)
        dets = [lib.femp_deformation(*head, at, pointer(b.F1), pointer(b.C1)) for (head, _), b in bodies]
        self._checked = u
        return min(dets)

    def strain_energy(self, u: np.ndarray) -> float:
        """The strain energy of the displacement u, integrated by the rule of the stress term: over a step
        its change is what the discrete-gradient stress does as work (material.averaged_pk2_stress)."""
        # from u's C where min_det_F kept it (the same sums), else from u
        at, kept = pointer(np.ascontiguousarray(u, dtype=float)), u is self._checked
        return sum(
            lib.femp_strain_energy_of(head[0], pointer(b.C1), pointer(b.rule.weights), b.lame_lambda, b.mu)
            if kept
            else lib.femp_strain_energy(*head, at, pointer(b.rule.weights), b.lame_lambda, b.mu)
            for (head, _), b in zip(self._args, self._bodies, strict=True)
        )


class SplitResidual:
    """residual(w, res): the energy-momentum step form's residual at w into res (ngsolve vectors over X):
    the stress (ElasticTerms), the linear terms as matrices, the wall contact integrated by NGSolve
    while it can act (the rigid wall's head elements within reach, or the meshed wall's pairs)."""

    def __init__(
        self, elastic: ElasticTerms, linear: LinearTerms, contact: BilinearForm | None, active: ngs.BitArray | None
    ):
        self.elastic, self.linear, self._contact, self._active = elastic, linear, contact, active
        self._nV = 2 * elastic.nS
        self._views: dict[int, tuple[ngs.BaseVector, np.ndarray, Any]] = {}
        self._compiled: RigidContactKernel | None = None

    def use_compiled_contact(self, compiled: RigidContactKernel | None) -> None:
        """Apply the rigid-wall contact term with this (fem/rigid_contact.py) instead of its form."""
        self._compiled = compiled

    def load(self, u0: np.ndarray, v0: np.ndarray, dt: float, torque_load: float) -> None:
        """The step's inputs (the same as the full form's StepInputs)."""
        self.elastic.load(u0)
        self.linear.load(u0, v0, dt, torque_load)
        if self._compiled is not None:
            self._compiled.load(u0)

    def contact_set(self, elements: np.ndarray) -> None:
        """The rigid-wall contact set (head elements, local indices) as the form's BitArray now marks it."""
        if self._compiled is not None:
            self._compiled.activate(elements)

    def allocate_contact_matrix(self) -> None:
        """Assemble the contact term's Jacobian once (at w = 0) with every head element in its set: NGSolve
        sizes a form's matrix at its first assembly, for the elements in the set then."""
        form, active = self._contact, self._active
        if form is None or active is None:
            return
        now = [i for i in range(len(active)) if active[i]]
        active.Set()
        form.AssembleLinearization(ngs.GridFunction(form.space).vec)
        active.Clear()
        for i in now:
            active.Set(i)

    def contact_linearisation(self, w: ngs.BaseVector) -> ngs.BaseMatrix | None:
        """The contact term's Jacobian at w, assembled by NGSolve (None while it cannot act)."""
        form = self._contact
        if form is None or self._active is None or self._active.NumSet() == 0:
            return None
        form.AssembleLinearization(w)
        return form.mat

    @property
    def compiled_contact(self) -> RigidContactKernel | None:
        """The rigid wall's compiled term, where it is used."""
        return self._compiled

    @property
    def compiled_contact_address(self) -> Any:
        """The compiled term's struct for the fused iteration (fem/iteration.py); NULL without one."""
        return ffi.NULL if self._compiled is None else self._compiled.address

    def fused_contact(self, w: ngs.BaseVector, res: ngs.BaseVector) -> int:
        """The contact part of a fused iteration: 2 where the kernel makes the compiled term itself, else
        whether res now holds the form's (apply_contact)."""
        return 2 if self._compiled is not None else int(self.apply_contact(w, res))

    def apply_contact(self, w: ngs.BaseVector, res: ngs.BaseVector) -> bool:
        """res = the wall contact term at w, if it can act (True), else res untouched (False)."""
        if self._compiled is not None:
            return self._compiled.apply(self._view(w)[0], self._view(res)[0])
        form = self._contact
        if form is None or self._active is None or self._active.NumSet() == 0:
            return False
        form.Apply(w, res)
        return True

    def __call__(self, w: ngs.BaseVector, res: ngs.BaseVector) -> None:
        (wn, w_at), (out, out_at) = self._view(w), self._view(res)
        first = not self.apply_contact(w, res)
        self.linear.add(wn, out, (w_at, out_at), first=first)
        self.elastic.add(wn, out, (w_at, out_at))

    def _view(self, vec: ngs.BaseVector) -> tuple[np.ndarray, Any]:
        """The numpy view of an ngsolve vector and its pointer, taken once per vector (3 us per call)."""
        key = id(vec)
        if key not in self._views:
            view = vec.FV().NumPy()
            self._views[key] = (vec, view, pointer(view))
        return self._views[key][1:]
