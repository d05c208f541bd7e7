"""stepping.py's step control asks for a state's contact scales only where a step needs them, and steps
exactly as if it asked at every step."""

from __future__ import annotations

import dataclasses

import pytest

from fem_pendulum_fmu.physics import stepping
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.scene import stiff

FIRST_CONTACT = 0.240  # s, the steel scene's first impact (tests/test_fem.py measures it)


class _EagerView(stepping._ContactView):
    """The scales computed at every step, as step control did before it asked lazily."""

    def __init__(self, model, x, control):
        super().__init__(model, x, control)
        self._get()


def _run(t_end: float) -> tuple[list[tuple], int]:
    """The outputs at each 1 ms step to t_end and how many times the contact scales were asked for."""
    model = FemModel(stiff())
    asked = 0
    scales = model.contact_scales

    def counted(x):
        nonlocal asked
        asked += 1
        return scales(x)

    model.contact_scales = counted  # type: ignore[method-assign]
    rows = [dataclasses.astuple(model.advance(i * 1e-3, 0.0)) for i in range(1, round(t_end / 1e-3) + 1)]
    return rows, asked


def test_free_flight_far_from_the_wall_never_asks_for_the_contact_scales() -> None:
    _, asked = _run(0.2)
    assert asked == 0


def test_lazy_scales_step_exactly_as_eager_ones_through_an_impact(monkeypatch: pytest.MonkeyPatch) -> None:
    """Through the first impact the scales are asked for (more than once a step in contact), and the
    outputs are bit-identical to those of scales computed at every step."""
    lazy, asked = _run(FIRST_CONTACT + 0.01)
    monkeypatch.setattr(stepping, "_ContactView", _EagerView)
    eager, asked_eagerly = _run(FIRST_CONTACT + 0.01)
    assert lazy == eager
    assert 16 <= asked < asked_eagerly
