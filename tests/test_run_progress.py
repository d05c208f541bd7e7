"""The run's progress bar (masters/run_progress.py): shown when the first steps make the whole run
expected to last more than 2 s, whatever its step count; never when stderr is not a terminal."""

from __future__ import annotations

import sys

import pytest

from fem_pendulum_fmu.masters import run_progress


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock(monkeypatch):
    fake = Clock()
    monkeypatch.setattr(run_progress.time, "perf_counter", fake)
    return fake


def steps(progress: run_progress.RunProgress, clock: Clock, n: int, seconds_each: float) -> None:
    for _ in range(n):
        clock.now += seconds_each
        assert progress.step() is True


@pytest.mark.parametrize("tty", [True, False])
def test_a_long_run_of_few_steps_gets_a_bar_on_a_terminal_only(monkeypatch, clock, tty):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: tty)
    progress = run_progress.RunProgress(total=500)  # 500 steps of 50 ms: 25 s expected
    steps(progress, clock, 10, 0.05)
    assert (progress._bar is not None) == tty
    steps(progress, clock, 490, 0.05)
    assert progress.done == 500 and (progress._bar is None or progress._bar.n == 500)
    progress.close()


def test_a_short_run_of_many_steps_gets_none(monkeypatch, clock):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    progress = run_progress.RunProgress(total=100_000)  # 100,000 steps of 10 us: 1 s expected
    steps(progress, clock, 100_000, 1e-5)
    assert progress._bar is None
    progress.close()


def test_expected_seconds():
    assert run_progress.expected_seconds(10, 1000, 0.5) == pytest.approx(50.0)
