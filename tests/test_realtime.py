"""Pacing to the wall clock (masters/realtime.py), on a simulated clock: early steps wait for their
deadline, late ones are overruns against a fixed schedule, and `fem-pendulum run --realtime` says so."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from fem_pendulum_fmu.masters.realtime import Pacer


class Wall:
    """A wall clock that moves only when the run computes (`work`) or the pacer sleeps."""

    def __init__(self) -> None:
        self.now = 100.0
        self.slept = 0.0

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds > 0.0
        self.now += seconds
        self.slept += seconds


def test_steps_faster_than_real_time_wait_and_none_overruns():
    wall = Wall()
    pacer = Pacer(wall.clock, wall.sleep)
    for k in range(1, 11):
        wall.now += 0.4e-3  # each 1 ms step computes in 0.4 ms
        pacer.step_done(k * 1e-3)
    assert pacer.overruns == [] and pacer.steps == 10
    assert wall.slept == pytest.approx(9 * 0.6e-3)  # the first step sets the schedule
    assert pacer.slowest.late == pytest.approx(0.4e-3)
    assert pacer.report().startswith("real time: all 9 paced steps ended by their deadlines")


def test_a_slow_step_overruns_and_the_schedule_stays_fixed():
    wall = Wall()
    pacer = Pacer(wall.clock, wall.sleep)
    costs = [0.4e-3, 0.4e-3, 5.0e-3, 0.4e-3, 0.4e-3, 0.4e-3, 0.4e-3, 0.4e-3]  # an impact in step 3
    for k, cost in enumerate(costs, start=1):
        wall.now += cost
        pacer.step_done(k * 1e-3)
    # step 3 ends 4 ms late; the later steps catch up 0.6 ms each, so all up to step 8 are still behind
    late = [o.late * 1e3 for o in pacer.overruns]
    assert [o.time for o in pacer.overruns] == pytest.approx([3e-3, 4e-3, 5e-3, 6e-3, 7e-3, 8e-3])
    assert late == pytest.approx([4.0, 3.4, 2.8, 2.2, 1.6, 1.0])
    assert pacer.slowest.time == pytest.approx(3e-3) and pacer.slowest.late == pytest.approx(5e-3)
    report = pacer.report()
    assert "6 of 7 paced steps overran, the worst by 4 ms at t = 0.003 s (the first at t = 0.003 s)" in report
    assert "the slowest step took 5 ms" in report


@pytest.mark.slow
def test_run_realtime_prints_the_pacing(fmus, tmp_path):
    command = [str(Path(sys.executable).parent / "fem-pendulum"), "run", "--fmu", str(fmus[0])]
    run = subprocess.run(
        [*command, "--set", "model.fidelity=rigid", "--realtime", "--stop-time", "0.2", "--out", "o/run"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    last = run.stdout.strip().splitlines()[-1]
    assert last.startswith("real time: ") and "199 paced steps" in last and "the slowest step took" in last, last
