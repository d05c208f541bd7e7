"""The start iterate's predicted miss (fem/start_iterate.py): the recurrence it fits, when it declines, the
state entries it keeps, and the Newton iterations it saves the FE model after an impact."""

from __future__ import annotations

import numpy as np
import pytest

from fem_pendulum_fmu.physics.fem import model as fem_model
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.fem.start_iterate import (
    DEPTH,
    FIT_LEFT,
    KEPT,
    RIDGE,
    WINDOW,
    GuessErrors,
    predicted_miss,
    recorded,
)
from fem_pendulum_fmu.physics.scene import stiff

DT = 1e-3


def ringing(steps: int, n: int = 60, modes: int = 3, seed: int = 1) -> np.ndarray:
    """Misses as a few undamped modes at equal steps make them: sum_k a_k cos(k phi_k + psi_k) v_k."""
    rng = np.random.default_rng(seed)
    phases, shifts, shapes = rng.uniform(0.3, 3.0, modes), rng.uniform(0, 6.3, modes), rng.standard_normal((modes, n))
    k = np.arange(steps)[:, None]
    return np.cos(k * phases + shifts) @ shapes * 1e-5


def history_of(misses: np.ndarray) -> GuessErrors | None:
    history = None
    for miss in misses:
        history = recorded(history, DT, miss)
    return history


def fitted_miss(errors: np.ndarray) -> np.ndarray | None:
    """The prediction's definition in numpy, the reference of the core's (core/fem_start_iterate.c): the c that
    fit each of the WINDOW newest misses by the DEPTH before it in least squares (normal equations with the
    ridge), None where the fit leaves more than FIT_LEFT of the window's squared size; else sum_j c_j e_j."""
    g = errors @ errors.T
    window = np.arange(WINDOW)[:, None]
    rows = window + 1 + np.arange(DEPTH)
    normal = g[rows[:, :, None], rows[:, None, :]].sum(axis=0)
    rhs = g[rows, window].sum(axis=0)
    c = np.linalg.solve(normal + RIDGE * np.max(np.diag(normal)) * np.eye(DEPTH), rhs)
    total = float(np.trace(g[:WINDOW, :WINDOW]))
    if not total + float(c @ (normal @ c - 2.0 * rhs)) <= FIT_LEFT * total:
        return None
    return c @ errors[:DEPTH]


def test_the_misses_of_a_few_modes_are_predicted():
    misses = ringing(KEPT + 1)
    predicted = predicted_miss(history_of(misses[:KEPT]), DT)
    assert predicted is not None
    # three modes need six of the eight terms; the ridge (RIDGE) leaves the fit exact to about 1e-9 of the
    # miss (measured 1.1e-11)
    assert np.max(np.abs(predicted - misses[KEPT])) < 1e-8 * np.max(np.abs(misses[KEPT]))


def test_noise_and_short_or_mixed_histories_predict_nothing():
    noise = np.random.default_rng(2).standard_normal((KEPT, 60))
    assert predicted_miss(history_of(noise), DT) is None  # the fit leaves far more than FIT_LEFT
    misses = ringing(KEPT)
    assert predicted_miss(history_of(misses[: KEPT - 1]), DT) is None
    full = history_of(misses)
    assert predicted_miss(full, 2 * DT) is None
    restarted = recorded(full, 2 * DT, misses[0])
    assert len(restarted.errors) == 1 and restarted.dt == 2 * DT
    assert len(recorded(full, DT * (1 + 1e-12), misses[0]).errors) == KEPT  # an advance's last step, landed


def test_the_history_keeps_the_newest_misses_and_their_inner_products():
    misses = ringing(KEPT + 3)
    history = history_of(misses)
    assert history is not None
    assert np.array_equal(history.errors, misses[::-1][:KEPT])
    assert np.allclose(history.gram, history.errors @ history.errors.T, rtol=1e-14, atol=0.0)


def test_the_core_predicts_the_least_squares_fit():
    misses = ringing(KEPT + 1, modes=4)
    history = history_of(misses)
    from_core, reference = predicted_miss(history, DT), fitted_miss(history.errors)
    assert from_core is not None and reference is not None
    # the fit's round-off differs (another order of sums, Cholesky against numpy's LU): measured 1.6e-12 of the miss
    assert np.max(np.abs(from_core - reference)) < 1e-10 * np.max(np.abs(reference))
    noise = np.random.default_rng(3).standard_normal((KEPT, 60))
    assert predicted_miss(history_of(noise), DT) is None and fitted_miss(history_of(noise).errors) is None


def test_state_entries_round_trip_and_misfits_are_refused():
    history = history_of(ringing(5))
    assert history is not None
    scalars, arrays = history.to_entries()
    back = GuessErrors.from_entries(scalars, arrays, 60)
    assert back is not None and back.dt == history.dt
    assert np.array_equal(back.errors, history.errors) and np.array_equal(back.gram, history.gram)
    assert GuessErrors.from_entries({}, {}, 60) is None
    with pytest.raises(ValueError, match=r"\(5, 60\).*do not fit.*61 dofs"):
        GuessErrors.from_entries(scalars, arrays, 61)
    with pytest.raises(ValueError, match="inner products of shape"):
        GuessErrors.from_entries(scalars, {**arrays, "guess_gram": np.zeros((4, 4))}, 60)
    broken = arrays["guess_errors"].copy()
    broken[2, 7] = np.nan
    with pytest.raises(ValueError, match="not all finite"):
        GuessErrors.from_entries(scalars, {**arrays, "guess_errors": broken}, 60)


def iterations_after_the_first_impact(model: FemModel) -> tuple[int, float]:
    """(Newton iterations from 0.26 to 0.36 s, theta at 0.36 s) of the steel swing, released at rest."""
    for i in range(1, 261):
        model.advance(i * DT, 0.0)
    before = model.newton.counts.iterations
    for i in range(261, 361):
        out = model.advance(i * DT, 0.0)
    return model.newton.counts.iterations - before, out.theta


def test_the_prediction_saves_iterations_after_an_impact(monkeypatch):
    predicted, theta = iterations_after_the_first_impact(FemModel(stiff()))
    monkeypatch.setattr(fem_model, "predicted_miss", lambda history, dt: None)
    plain, theta_plain = iterations_after_the_first_impact(FemModel(stiff()))
    # measured 2026-12-05: 457 against 561 iterations (0.81); the ringing plate made the plain guess miss
    # by 1e-5 to 5e-4 m
    assert predicted < 0.9 * plain, (predicted, plain)
    # both solve to the same tolerance (NEWTON_RTOL): they differ by round-off-level amounts (measured 1.6e-12 rad)
    assert abs(theta - theta_plain) < 1e-9
