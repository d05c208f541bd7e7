"""The reduced fidelity's compiled step and terms (physics/core/reduced_step.c, reduced/kernel.py)
against their numpy forms in reduced/step.py, reduced/contact.py, reduced/head.py and reduced/strain.py."""

from __future__ import annotations

import numpy as np
import pytest

from fem_pendulum_fmu.physics.reduced import step as reduced_step
from fem_pendulum_fmu.physics.reduced import strain as reduced_strain
from fem_pendulum_fmu.physics.reduced.model import ReducedModel
from fem_pendulum_fmu.physics.reduced.state import ReducedState
from fem_pendulum_fmu.physics.scene import compliant, stiff

# the two forms sum the same terms in different orders: measured 1e-14 relative (strain energy,
# contact energy and force), 1e-15 (gradients) and 5e-16 (Hessians) on the rubber impact
TERM_RTOL = 1e-12
# over 0.3 s through the first impact the runs drift apart by round-off only: measured 7.8e-14 rad
# (steel) and 6.4e-11 rad (rubber, whose impact takes 3 Newton iterations per step); energies 1.4e-13
THETA_TOL = 1e-9
ENERGY_RTOL = 1e-11
GAP_TOL = 1e-10  # m: the angle's drift times the head's distance from the pivot (~0.2 m)


def _pair(preset, monkeypatch: pytest.MonkeyPatch) -> tuple[ReducedModel, ReducedModel]:
    """(compiled, numpy) models of one scene."""
    compiled = ReducedModel(preset())
    with monkeypatch.context() as patch:  # the model on its numpy forms: no core bound to it
        patch.setattr(reduced_step, "reduced_kernel", lambda **fields: None)
        patch.setattr(reduced_strain, "reduced_kernel", lambda **fields: None)
        plain = ReducedModel(preset())
    assert compiled._kernel is not None and plain._kernel is None
    return compiled, plain


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b)))


@pytest.mark.parametrize("preset", [stiff, compliant])
def test_compiled_and_numpy_runs_agree_through_the_impact(preset, monkeypatch: pytest.MonkeyPatch) -> None:
    compiled, plain = _pair(preset, monkeypatch)
    impulse = 0.0
    for k in range(300):
        a, b = compiled.advance((k + 1) * 1e-3, 0.0), plain.advance((k + 1) * 1e-3, 0.0)
        impulse += a.contact_impulse
        assert abs(a.theta - b.theta) < THETA_TOL
        assert abs(a.total - b.total) < ENERGY_RTOL * abs(b.total)
        assert abs(a.gap - b.gap) < GAP_TOL
    assert impulse > 0.0  # the run went through the impact


def test_contact_gap_and_strain_terms_equal_the_numpy_forms(monkeypatch: pytest.MonkeyPatch) -> None:
    """At a state of the rubber impact (0.246 s, head pressed into the wall)."""
    compiled, plain = _pair(compliant, monkeypatch)
    for k in range(246):
        compiled.advance((k + 1) * 1e-3, 0.0)
    z = compiled._x[0]
    assert compiled._kernel is not None
    terms = compiled._kernel.contact(z)
    reference = plain._contact.evaluate(z)
    assert terms is not None and reference is not plain._contact.none
    for got, want in zip(terms, reference, strict=True):
        assert _rel(got, want) < TERM_RTOL
    assert compiled._kernel.gap(z) == pytest.approx(plain._head.gap(z), rel=TERM_RTOL)
    assert compiled._kernel.gap(z) < 0.0
    q = z[1:]
    strain, reference_strain = compiled._strain, plain._strain
    assert _rel(strain.energy(q), reference_strain.energy(q)) < TERM_RTOL
    assert _rel(strain.gradient(q), reference_strain.gradient(q)) < TERM_RTOL
    assert _rel(strain.hessian(q), reference_strain.hessian(q)) < TERM_RTOL


def test_compiled_step_fails_as_the_numpy_one_on_an_inverted_body(monkeypatch: pytest.MonkeyPatch) -> None:
    """A state whose elements invert on the step: both forms return None (the stepper halves dt)."""
    compiled, plain = _pair(compliant, monkeypatch)
    x = compiled._x
    p = x[1].copy()
    p[1:] = 1e3  # modal momenta that fold the rod within a step
    crushed = ReducedState(x.z, p, 0.0)
    assert compiled.step(crushed, 2e-3, 0.0) is None
    assert plain.step(crushed, 2e-3, 0.0) is None
