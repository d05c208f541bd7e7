"""The step control (core/stepping.c, the rules of stepping.py) asks for a state's contact scales only where
a step needs them, and steps
exactly as if it asked at every step."""

from __future__ import annotations

import dataclasses

import pytest

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.scene import PRESETS, stiff

FIRST_CONTACT = 0.240  # s, the steel scene's first impact (tests/test_fem.py measures it)


def _run(t_end: float, eager: bool = False) -> tuple[list[tuple], int]:
    """The outputs at each 1 ms step to t_end and how many times the contact scales were asked for; `eager`
    asks for them with every gap as well, as a step control that made them at every step would."""
    model = FemModel(stiff())
    asked = 0
    scales, gap = model.contact_scales, model.gap_and_rate

    def counted(x):
        nonlocal asked
        asked += 1
        return scales(x)

    def gap_and_scales(x):
        counted(x)
        return gap(x)

    model.contact_scales = counted  # type: ignore[method-assign]
    if eager:
        model.gap_and_rate = gap_and_scales  # type: ignore[method-assign]
    rows = [dataclasses.astuple(model.advance(i * 1e-3, 0.0)) for i in range(1, round(t_end / 1e-3) + 1)]
    return rows, asked


def test_free_flight_far_from_the_wall_never_asks_for_the_contact_scales() -> None:
    _, asked = _run(0.2)
    assert asked == 0


def test_lazy_scales_step_exactly_as_eager_ones_through_an_impact() -> None:
    """Through the first impact the scales are asked for (more than once a step in contact), and the
    outputs are bit-identical to those of scales computed at every step."""
    lazy, asked = _run(FIRST_CONTACT + 0.01)
    eager, asked_eagerly = _run(FIRST_CONTACT + 0.01, eager=True)
    assert lazy == eager
    assert 16 <= asked < asked_eagerly


def _contact_steps(preset: str, t_end: float) -> list[tuple[float, float, float]]:
    """(start time of the advance the step is in, its size, the contact's step there) of every step the FE
    model takes from inside the wall (gap < 0), in 1 ms advances to t_end."""
    model = FemModel(PRESETS[preset]())
    taken, step = [], model.step

    def recorded(x, dt, torque):
        if model.gap_and_rate(x)[0] < 0.0:
            t_contact, _ = model.contact_scales(x)
            taken.append((model.time, dt, t_contact / model.control.contact_steps(t_contact)))
        return step(x, dt, torque)

    model.step = recorded  # type: ignore[method-assign]
    for i in range(1, round(t_end / 1e-3) + 1):
        model.advance(i * 1e-3, 0.0)
    return taken


@pytest.mark.parametrize(("preset", "t_end"), [("stiff", FIRST_CONTACT + 0.002), ("compliant", 0.25)])
def test_contact_steps_are_even_and_never_longer_than_the_contacts_step(preset: str, t_end: float) -> None:
    """The FE model's steps in contact (StepControl.even_contact_steps): none longer than the contact's own
    step (up to round-off), and most of them the same size as the step before them in their advance: the
    factorised Jacobian serves them without a refactorisation. Measured: 15 of the 15 steps after the first
    on steel's first impact, 28 of 39 in rubber's first 10 ms of contact; half is asked."""
    taken = _contact_steps(preset, t_end)
    assert len(taken) >= 16
    assert all(dt <= own * (1.0 + 1e-9) for _, dt, own in taken)
    same = sum(a[0] == b[0] and a[1] == b[1] for a, b in zip(taken, taken[1:], strict=False))
    assert same >= len(taken) // 2
