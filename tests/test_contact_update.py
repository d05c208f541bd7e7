"""The held Jacobian updated for the rigid wall's contact (fem/contact_update.py, core/fem_elastic.c
low_rank_update; used on soft bodies): the contact term's stiffness against its finite differences, one
fused iteration against a direct solve with the contact's Jacobian added, and the Jacobians a rubber
contact takes with and without it."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from fem_pendulum_fmu.physics.core import lib, pointer
from fem_pendulum_fmu.physics.fem import model as fem_model
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.fem.newton import too_slow
from fem_pendulum_fmu.physics.scene import Scene, compliant, stiff

# s, about a contact's step: 16 to a steel contact of 0.34 ms, 29 to a rubber one of about 9 ms
DT = {"steel": 2e-5, "rubber": 2.5e-4}


def _penetrating(body: str) -> FemModel:
    """The steel or rubber pendulum (at the wall at 0.24 s) advanced until its head is inside the block (in
    0.1 ms steps from 0.23 s), with a contact step of DT loaded and the iterate u0 + DT v0 set."""
    model = FemModel(stiff() if body == "steel" else compliant())
    for k in range(230):
        model.advance((k + 1) * 1e-3, 0.0)
    t = 0.23
    while model.outputs().gap >= 0.0:
        t += 1e-4
        model.advance(t, 0.0)
        assert t < 0.3, "the pendulum never reached the wall"
    xs, nV, dt = model._state, model.space.nV, DT[body]
    model.load_step(xs, dt, 0.0)
    model.newton._w_np[:nV] = xs.u + dt * xs.v
    model.newton._w_np[nV:] = xs.hinge_multipliers
    return model


def _contact_jacobian(model: FemModel, w: np.ndarray) -> np.ndarray:
    """sum over the listed points of c g g^T in their positions (RigidContactKernel.stiffness), dense over
    the solver's unknowns."""
    contact = model.form.split.compiled_contact
    c, gx, gy = contact.stiffness(w)
    trace = contact.trace.toarray()
    rows_x, rows_y = trace[contact.points], trace[contact.points + trace.shape[0] // 2]
    a = np.zeros((len(c), len(w)))  # the trace's columns are the displacements, the first unknowns
    a[:, : trace.shape[1]] = gx[:, None] * rows_x + gy[:, None] * rows_y
    return a.T @ (c[:, None] * a)


@pytest.mark.parametrize("body", ["steel", "rubber"])
def test_contact_stiffness_is_the_terms_derivative(body: str) -> None:
    """The stiffness the update adds against central differences of the compiled contact term (steps of
    1e-11 m; 4 and 12 head points pushed): equal to 1.1e-7 (steel) and 7.1e-8 (rubber) of its largest entry
    (measured: the residual's rounding over the step), so to 1e-6."""
    model = _penetrating(body)
    contact = model.form.split.compiled_contact
    w = model.newton._w_np.copy()
    mine = _contact_jacobian(model, w)
    assert np.max(mine) > 1e4  # N/m: points are pushed
    dofs = np.flatnonzero(np.any(mine != 0.0, axis=0))
    h, plus, minus = 1e-11, np.zeros_like(w), np.zeros_like(w)
    for j in dofs:
        step = np.zeros_like(w)
        step[j] = h
        contact.apply(w + step, plus)
        contact.apply(w - step, minus)
        column = (plus - minus) / (2.0 * h)
        assert np.max(np.abs(column - mine[:, j])) <= 1e-6 * np.max(np.abs(mine))
    # arrays sized for another contact set are left alone (the kernel's guard against writing past them)
    n = len(contact.points)
    out = np.full((3, n + 1), 7.0)
    rows = (pointer(row) for row in out)
    assert lib.femp_rigid_contact_stiffness(contact.address, pointer(w), n + 1, *rows) == 0
    assert np.all(out == 7.0)


def test_fused_iteration_solves_with_the_contacts_jacobian_added() -> None:
    """One iteration with the update (a Jacobian assembled without the contact at the iterate, G and S
    solved with its factors, K and M made in the kernel) against scipy's solve of that Jacobian plus the
    contact's, rubber in contact: the same correction, its displacements to 8.6e-14 of their largest and
    the hinge multipliers to 8.5e-12 of theirs (measured; two factorisations of matrices whose penalty
    part is thousands of times the body's), so to 1e-11 and 1e-9; the held Jacobian's alone is off by more
    than 1e-3."""
    model = _penetrating("rubber")
    nw = model.newton
    assert nw._contact_update is not None and nw._jacobian is not None
    step = model.load_step(model._state, DT["rubber"], 0.0)
    nw._refresh(step)  # held at this iterate: no turn
    free = nw._factor.free
    pattern = nw._factor._pattern
    held = sp.csc_matrix((nw._jacobian(nw.w.vec), pattern.indices, pattern.indptr))
    w = nw._w_np.copy()
    full = held + sp.csc_matrix(_contact_jacobian(model, w)[np.ix_(free, free)])
    nw._apply(nw.w.vec, nw._res)
    expected = spl.spsolve(full.tocsc(), nw._res_np[free].copy())
    nw._fused.prepare(0.0)
    nw._contact_update.prepare()
    nw._fused.iterate(nw._split.fused_contact(nw.w.vec, nw._res))
    error = np.abs((w - nw._w_np)[free] - expected)
    moves = free < model.space.nV  # the displacements; the rest are the hinge multipliers
    assert np.max(error[moves]) <= 1e-11 * np.max(np.abs(expected[moves]))
    assert np.max(error[~moves]) <= 1e-9 * np.max(np.abs(expected[~moves]))
    without = spl.spsolve(held, nw._res_np[free].copy())[moves]
    assert np.max(np.abs(without - expected[moves])) > 1e-3 * np.max(np.abs(expected[moves]))  # it matters


def _first_contact(monkeypatch: pytest.MonkeyPatch, update: bool) -> tuple[int, int]:
    """(Newton iterations, Jacobians) of the rubber pendulum's first contact (0.241-0.263 s in 1 ms
    advances), the update on or off."""
    monkeypatch.setattr(fem_model, "use_contact_update", lambda scene: update)
    model = FemModel(compliant())
    assert (model.newton._contact_update is not None) == update
    t, at_start = 0, None
    while at_start is None or model.outputs().gap < 0.0:
        t += 1
        model.advance(t * 1e-3, 0.0)
        counts = model.newton.counts
        if at_start is None and model.outputs().gap < 0.0:
            at_start = (counts.iterations, counts.jacobians)
        assert t < 400, "no contact that ended"
    return counts.iterations - at_start[0], counts.jacobians - at_start[1]


def test_a_rubber_contact_takes_fewer_jacobians_with_the_update(monkeypatch: pytest.MonkeyPatch) -> None:
    """The rubber's first contact: 663 iterations and 36 Jacobians with the update, 715 and 100 with a
    held Jacobian re-assembled with the contact (docs/notes/fem.md, changes 29 and 30); a fifth fewer Jacobians
    at least, and no more iterations."""
    with_update, without = _first_contact(monkeypatch, True), _first_contact(monkeypatch, False)
    assert with_update[1] <= 0.8 * without[1]
    assert with_update[0] <= without[0]


@pytest.mark.parametrize("scene, used", [(stiff(), False), (compliant(), True)])
def test_the_update_is_used_on_soft_bodies(scene: Scene, used: bool) -> None:
    assert fem_model.use_contact_update(scene) == used


def test_the_rate_alone_asks_for_a_new_jacobian_in_an_updated_contact() -> None:
    """newton.too_slow: a contraction by 2 that would not reach the tolerance in the iterations left asks
    for a new Jacobian, unless the held factors are updated for the contact (rate_only); one slower than
    SLOWEST_CONTRACTION always does."""
    assert too_slow(1e10, 2e10, 1.0, 20)
    assert not too_slow(1e10, 2e10, 1.0, 20, rate_only=True)
    assert too_slow(0.9e10, 1e10, 1.0, 20, rate_only=True)
