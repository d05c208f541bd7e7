"""The FE step's fast residual and linear solve (fem/residual.py, fem/lu.py, the compiled core)
against the NGSolve form they stand in for."""

from __future__ import annotations

import ngsolve as ngs
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from fem_pendulum_fmu.physics.core import lib, pointer
from fem_pendulum_fmu.physics.fem.iteration import ANDERSON_DEPTH
from fem_pendulum_fmu.physics.fem.lu import SUPERNODE_MOST, HeldFactor, Pattern, Symbolic, supernodes
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.fem.residual import point_blocks
from fem_pendulum_fmu.physics.fem.split_jacobian import SplitJacobian
from fem_pendulum_fmu.physics.scene import compliant, stiff
from fem_pendulum_fmu.physics.sparse import scipy_matrix

# the stress term sums terms of mu ~ 1e11 Pa (steel) to stresses of ~1e5 Pa: the two evaluations differ
# in the order of those sums, measured 3.7e-10 of the largest residual entry (steel, torque 0.7 N.m)
RESIDUAL_RTOL = 1e-8


def _residuals(model: FemModel, torque: float) -> tuple[np.ndarray, np.ndarray]:
    """(full form's Apply, split residual) at the current state's next step, with a perturbed iterate."""
    xs = model._state
    model.load_step(xs, 1e-3, torque)
    nw = model.newton
    w = nw.w.vec
    w.FV().NumPy()[: model.space.nV] = xs.u + 1e-3 * xs.v + 1e-7 * np.sin(np.arange(model.space.nV))
    w.FV().NumPy()[model.space.nV :] = [3.0, -2.0]
    full, split = w.CreateVector(), w.CreateVector()
    model.form.form.Apply(w, full)
    assert model.form.split is not None
    model.form.split(w, split)
    return full.FV().NumPy().copy(), split.FV().NumPy().copy()


@pytest.mark.parametrize("preset", [stiff, compliant])
def test_split_residual_equals_the_form(preset) -> None:
    model = FemModel(preset())
    for k in range(3):
        model.advance((k + 1) * 1e-3, 0.0)
    full, split = _residuals(model, 0.7)
    assert np.max(np.abs(full - split)) <= RESIDUAL_RTOL * np.max(np.abs(full))


def test_split_residual_in_contact_equals_the_form() -> None:
    """With head elements in the contact set the rigid-wall term is integrated by NGSolve, on the same set."""
    model = FemModel(stiff())
    _in_contact(model)
    active = model.form.active
    assert active is not None
    full, split = _residuals(model, 0.0)
    assert active.NumSet() > 0
    assert np.max(np.abs(full - split)) <= RESIDUAL_RTOL * np.max(np.abs(full))


def test_compiled_rigid_wall_term_equals_its_form_in_penetration() -> None:
    """The rigid-wall contact term of the kernel (fem/rigid_contact.py) against the contact form's Apply, with
    the head inside the block: equal to 2.3e-16 of the largest entry (measured), so to 1e-13."""
    model = FemModel(stiff())
    t = 0.0
    while model.outputs().gap >= 0.0:
        t += 1e-4
        model.advance(t, 0.0)
        assert t < 0.3, "the pendulum never reached the wall"
    split, xs, nV = model.form.split, model._state, model.space.nV
    assert split is not None and split.compiled_contact_address
    for dt in (1e-5, 3e-5):
        model.load_step(xs, dt, 0.0)
        w = model.newton.w.vec
        w.FV().NumPy()[:nV] = xs.u + dt * xs.v
        form, compiled = w.CreateVector(), w.CreateVector()
        split._contact.Apply(w, form)
        assert split.apply_contact(w, compiled)
        expected = form.FV().NumPy()
        assert np.max(np.abs(expected)) > 100.0  # newtons: the head is in the block
        assert np.max(np.abs(compiled.FV().NumPy() - expected)) <= 1e-13 * np.max(np.abs(expected))


@pytest.mark.slow
def test_compiled_contact_force_and_impulse_equal_the_integrals() -> None:
    """The step control's contact force and impulse summed by the kernel at the head points against NGSolve's
    Integrate of the same laws, through the first impact: equal to 2.6e-16 of their size (measured)."""
    model = FemModel(stiff())
    if model.measures._compiled is None:
        pytest.fail("no C compiler: the compiled kernel cannot be tested on this machine")
    t, steps = 0.0, []
    while len(steps) < 6:
        t, x0 = t + 2e-5, model._state
        model.advance(t, 0.0)
        if model.outputs().gap < 0.0 or steps:
            steps.append((x0.u, model._state.u))
    measures, compiled = model.measures, model.measures._compiled
    for u0, u1 in steps:
        fast = measures.contact_force_vector(u1), measures.contact_impulse(u0, u1, 2e-5, False)
        measures._compiled = None
        slow = measures.contact_force_vector(u1), measures.contact_impulse(u0, u1, 2e-5, False)
        measures._compiled = compiled
        for a, b in zip(fast, slow, strict=True):
            assert np.max(np.abs(b)) > 0.0 and np.max(np.abs(a - b)) <= 1e-14 * np.max(np.abs(b))


def test_min_det_F_at_the_forms_points_equals_the_outputs() -> None:
    model = FemModel(compliant())
    for k in range(5):
        model.advance((k + 1) * 1e-3, 0.5)
    assert model.min_det_F() == pytest.approx(model.measures.min_det_F(model._state.u), abs=1e-14)


def _in_contact(model: FemModel) -> None:
    """Advance the steel pendulum (released at 20 degrees, at the wall at 0.24 s) to the first step with
    head elements in the contact set, and load that step."""
    active = model.form.active
    assert active is not None
    t = 0.0
    while True:
        model.load_step(model._state, 1e-3, 0.0)
        if active.NumSet() > 0:
            return
        t += 1e-3
        model.advance(t, 0.0)
        assert t < 0.3, "the pendulum never came near the wall"


def _loaded_at_an_iterate(case: str) -> FemModel:
    """A compiled model ("steel", "rubber..." or "steel in contact") with its next step loaded and a
    perturbed iterate set (a torque of 0.7 N.m out of contact)."""
    model = FemModel(compliant() if case.startswith("rubber") else stiff())
    if case == "steel in contact":
        _in_contact(model)
    else:
        for k in range(3):
            model.advance((k + 1) * 1e-3, 0.0)
    _residuals(model, 0.0 if case == "steel in contact" else 0.7)  # loads the step, sets the iterate
    return model


@pytest.mark.parametrize("case", ["steel", "rubber", "steel in contact"])
def test_compiled_jacobian_equals_the_forms_linearisation(case: str) -> None:
    """The Newton Jacobian from the kernel's stress tangent, the linear terms' matrices and the contact
    term's own linearisation (fem_residual.SplitJacobian) against NGSolve's linearisation of the full form,
    at a perturbed iterate with a torque: equal to 5e-16 of the largest entry (measured), so to 1e-12. (The
    solver's own leaves the contact out and updates its factors for it: tests/test_contact_update.py.)"""
    model = _loaded_at_an_iterate(case)
    nw = model.newton
    assert nw._jacobian is not None and model.form.split is not None
    free = nw._factor.free
    pattern = nw._factor._pattern
    mine = SplitJacobian(model.form.split, free, pattern.indptr, pattern.indices)(nw.w.vec)
    model.form.form.AssembleLinearization(nw.w.vec)
    full = scipy_matrix(model.form.form.mat)[free][:, free].tocsc()
    full.sort_indices()
    assert np.max(np.abs(full.data - mine)) <= 1e-12 * np.max(np.abs(full.data))


def _anderson(f: list[np.ndarray], g: list[np.ndarray], depth: int) -> tuple[np.ndarray, np.ndarray]:
    """The Anderson step in numpy: x = g_k - sum_j gamma_j (g_j+1 - g_j) over the last `depth` differences,
    gamma minimising |f_k - sum_j gamma_j (f_j+1 - f_j)| (least squares); also gamma."""
    k = len(f) - 1
    m = min(depth, k)
    df = np.column_stack([f[k - j] - f[k - j - 1] for j in range(m)])
    dg = np.column_stack([g[k - j] - g[k - j - 1] for j in range(m)])
    gamma = np.linalg.lstsq(df, f[k], rcond=None)[0]
    return g[k] - dg @ gamma, gamma


@pytest.mark.parametrize("case", ["rubber, turned", "steel in contact"])
def test_fused_iteration_equals_the_separate_calls(case: str) -> None:
    """femp_iterate (fem/iteration.py) makes the residual's and the update's operations in their order: the
    same iterate and correction size bit for bit, turned or not, with the contact term or without, for the
    first iteration after prepare. The later ones are combined with the earlier by the Anderson step of
    depth ANDERSON_DEPTH (core/fem_elastic.c, secant_step): here the same step in numpy from the separate
    calls, whose dot products sum in another order (5e-16 of the change g2 - g1 measured; 1e-12 allowed)."""
    model = _loaded_at_an_iterate(case)
    nw = model.newton
    assert nw._fused is not None and nw._split is not None
    w, start, nV = nw.w.vec, nw._w_np.copy(), model.space.nV
    turn = 0.0 if case == "steel in contact" else 2e-3
    assert nw._split.apply_contact(w, nw._res) == (case == "steel in contact")
    sizes, f, g, combined = [], [], [], []
    for k in range(ANDERSON_DEPTH + 1):  # the separate calls, each from the combined iterate before
        nw._apply(w, nw._res)
        sizes.append(nw._update(turn))
        g.append(nw._w_np.copy())
        f.append(-nw._corr_np[:nV].copy())
        if k > 0:
            x, gamma = _anderson(f, g, ANDERSON_DEPTH)
            assert np.all(gamma != 0.0)
            combined.append(x)
            nw._w_np[:] = x
    for _ in range(2):  # prepare starts a new sequence: the first iteration is not combined again
        nw._w_np[:] = start
        nw._fused.prepare(turn)
        assert nw._fused.iterate(nw._split.apply_contact(w, nw._res)) == sizes[0]
        assert np.array_equal(nw._w_np, g[0])
        for k in range(1, ANDERSON_DEPTH + 1):
            size = nw._fused.iterate(nw._split.apply_contact(w, nw._res))
            change = np.max(np.abs(g[k] - g[k - 1]))
            assert abs(size - sizes[k]) <= 1e-12 * change
            assert np.max(np.abs(nw._w_np - combined[k - 1])) <= 1e-12 * change
            assert not np.array_equal(nw._w_np, g[k])


def test_held_factor_solves_and_rescales() -> None:
    """The LU solve equals scipy's, and the rescaled inertia term equals a matrix assembled at that step;
    with the kernel the factors are its own (multipliers last) and SuperLU's where a pivot vanishes."""
    model = FemModel(stiff())
    model.advance(1e-3, 0.0)
    nw, split = model.newton, model.form.split
    assert split is not None
    free = np.ones(model.space.X.ndof, dtype=bool)

    def assembled(dt: float) -> sp.csc_matrix:
        model.load_step(model._state, dt, 0.0)
        model.form.form.AssembleLinearization(nw.w.vec)
        rows, cols, vals = model.form.form.mat.COO()
        return sp.csc_matrix((np.array(vals), (np.array(rows), np.array(cols))))

    b = np.cos(np.arange(model.space.X.ndof))
    multipliers = np.arange(model.space.X.ndof) >= model.space.nV
    # ordered last, the multipliers get their pivots; ordered with the rest (no `last`), their zero diagonal
    # comes first in the minimum-degree order, is refused by the kernel and SuperLU pivots instead
    for last in (multipliers, np.zeros_like(multipliers)):
        factor = HeldFactor(free, split.linear.mass, last)
        a1 = assembled(1e-3)
        factor.factorise(model.form.form.mat)
        x = np.zeros_like(b)
        factor.solve(b, x)
        reference = spl.spsolve(a1, b)
        assert np.max(np.abs(x - reference)) <= 1e-9 * np.max(np.abs(reference))
        assert (factor._lu is None) == (last is multipliers)
        coeff = split.linear.inertia_coefficient
        assert factor.factorise_shifted(coeff(0.4e-3) - coeff(1e-3))
        factor.solve(b, x)
        reference = spl.spsolve(assembled(0.4e-3), b)
        assert np.max(np.abs(x - reference)) <= 1e-9 * np.max(np.abs(reference))


def test_supernodes_share_the_rows_below_them() -> None:
    """The solve's supernodes (fem/lu.py, supernodes) on the steel mesh: runs that cover every column, each
    column holding the next one's rows after that column itself, none wider than the kernel takes."""
    model = FemModel(stiff())
    model.advance(1e-3, 0.0)
    symbolic = model.newton._factor._symbolic
    assert symbolic is not None
    sn, Lp, Li = symbolic.sn, symbolic.Lp, symbolic.Li
    starts = sn[1:]
    assert sn[0] == len(starts) - 1 and starts[0] == 0 and starts[-1] == len(Lp) - 1
    widths = np.diff(starts)
    assert widths.min() >= 1 and widths.max() <= SUPERNODE_MOST and widths.mean() > 2.0  # measured 3.3

    def continues(j: int) -> bool:  # column j + 1 holds column j's rows after its first, which is j + 1
        own, following = Li[Lp[j] : Lp[j + 1]], Li[Lp[j + 1] : Lp[j + 2]]
        return len(own) == len(following) + 1 and own[0] == j + 1 and np.array_equal(own[1:], following)

    for s, e in zip(starts[:-1], starts[1:], strict=True):
        assert all(continues(j) for j in range(s, e - 1))
        if e < len(Lp) - 1 and e - s < SUPERNODE_MOST:  # a run goes on as long as the next column continues it
            assert not continues(e - 1)


def test_supernodes_are_cut_at_the_widest_the_kernel_takes() -> None:
    # a dense unit lower triangle of 200 columns is one run, cut every SUPERNODE_MOST (64) columns
    columns = [np.arange(j + 1, 200) for j in range(200)]
    Lp = np.concatenate([[0], np.cumsum([len(c) for c in columns])]).astype(np.int32)
    sn = supernodes(Lp, np.concatenate(columns).astype(np.int32))
    assert sn.tolist() == [4, 0, 64, 128, 192, 200]


def test_point_blocks_share_one_block_among_an_elements_points() -> None:
    # points 0 and 1 on basis functions (0, 2), point 2 on (1, 2, 3): blocks of 4^2 and 6^2 entries; n_scalar 4
    rows = [[0, 2], [0, 2], [1, 2, 3]]
    indptr = np.concatenate([[0], np.cumsum([len(r) for r in rows * 2])])
    grad = sp.csr_matrix((np.ones(indptr[-1]), np.concatenate(rows * 2), indptr), shape=(6, 4))
    starts, pairs = point_blocks(grad, 3, 4)
    assert starts.tolist() == [0, 0, 16] and starts.dtype == np.int32
    first = [0, 2, 4, 6]  # x then y unknowns of the first block
    assert pairs[:16].tolist() == [[r, c] for r in first for c in first]
    second = [1, 2, 3, 5, 6, 7]
    assert pairs[16:].tolist() == [[r, c] for r in second for c in second] and len(pairs) == 16 + 36


def test_supernodal_solve_reads_many_rows_below_in_chunks() -> None:
    """femp_lu_solve takes the rows below a supernode 256 at a time (core/fem_elastic.c, SOLVE_CHUNK): 300
    unknowns ordered last and coupled to all the others put 300 rows below every supernode before them.
    The kernel's factors solve as scipy does (1e-9 of the solution; measured 2e-15)."""
    n_lead, n_tail = 200, 300
    n = n_lead + n_tail
    rng = np.random.default_rng(7)
    dense = np.zeros((n, n))
    chain = np.arange(n_lead - 1)
    dense[chain, chain + 1] = dense[chain + 1, chain] = -1.0  # the lead unknowns in a chain
    dense[n_lead:, :n_lead] = rng.uniform(-0.01, 0.01, (n_tail, n_lead))
    dense[:n_lead, n_lead:] = dense[n_lead:, :n_lead].T
    dense += np.diag(np.full(n, 4.0))
    matrix = sp.csc_matrix(dense)
    matrix.sort_indices()
    last = np.arange(n) >= n_lead
    symbolic = Symbolic.of(Pattern.of(matrix), last)
    below = [symbolic.Lp[e] - symbolic.Lp[e - 1] for e in symbolic.sn[2:]]
    assert max(below) >= n_tail > 256
    assert symbolic.factorise(np.ascontiguousarray(matrix.data))
    free = np.arange(n, dtype=np.int32)
    b, x, work = np.cos(np.arange(n)), np.zeros(n), np.zeros(n)
    lib.femp_lu_solve(*symbolic.kernel_args(free), pointer(b), pointer(work), pointer(x))
    reference = spl.spsolve(matrix, b)
    assert np.max(np.abs(x - reference)) <= 1e-9 * np.max(np.abs(reference))


@pytest.mark.parametrize("preset", [stiff, compliant])
def test_strain_energy_of_the_kernel_equals_the_integral(preset) -> None:
    """The outputs' strain energy (the stress term's rule, in the compiled core) against NGSolve's
    Integrate of the same density at the same order. Rubber: equal to 1e-15 relative. Steel: the density
    mu/2 (tr C - 2 - ln det C) cancels terms of mu ~ 8e10 Pa down to strains of 1e-6, so the two sums
    differ in round-off by up to 1.5e-10 J (measured) of a 1.7e-6 J strain energy, a 1e-9 share of the
    0.117 J swing energy the energy outputs are judged against."""
    model = FemModel(preset())
    for k in range(20):
        model.advance((k + 1) * 1e-3, 0.5)
    space, u = model.space, model._state.u
    split = model.form.split
    assert split is not None
    space.gf_u.vec.FV().NumPy()[:] = u
    mesh = space.mesh
    reference = sum(
        float(ngs.Integrate(cf, mesh, order=2 * model.scene.model.order, definedon=mesh.Materials(region)))
        for region, cf in model.measures._strain_cf
    )
    assert reference > 0.0
    assert split.elastic.strain_energy(u) == pytest.approx(reference, rel=1e-12, abs=1e-9)
