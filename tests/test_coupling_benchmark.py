"""benchmarks/coupling.py --quick: the coupling error of the PID loop and of the open-loop sine against
their 0.2 ms references, by hold order (docs/notes/coupling.md has the full run). It asserts accuracy only
(no timing), and the master-side helpers of fem_pendulum_fmu/masters/coupling.py."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from fem_pendulum_fmu.masters.coupling import check_hold, limited, output_rates, set_input_rates, taylor_rates

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "coupling.py"


def rows(text: str) -> dict[tuple[str, int, float], float]:
    """(coupling, hold order, step in ms) -> theta RMS error over the run (deg) of the printed tables."""
    found, coupling = {}, None
    for line in text.splitlines():
        head = re.match(r"(\w+): reference", line)
        if head:
            coupling = head.group(1)
        cells = [c.strip() for c in line.strip("|").split("|")]
        if coupling and len(cells) == 8 and cells[0].isdigit():
            found[(coupling, int(cells[0]), float(cells[1]))] = float(cells[3])
    return found


def test_the_quick_coupling_study_shows_what_higher_order_hold_buys(fmus):
    run = subprocess.run(
        [sys.executable, str(BENCHMARK), "--quick", "--dist", str(fmus[0].parent)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    error = rows(run.stdout)
    assert len(error) == 2 * 3 * 2, run.stdout  # two couplings, three holds, two steps
    for coupling in ("pid_loop", "sine"):
        # measured at 10 ms (deg): pid_loop 0.229 / 0.0954 / 0.0206, sine 0.358 / 0.0124 / 0.000702
        assert error[(coupling, 1, 10.0)] < 0.6 * error[(coupling, 0, 10.0)], coupling
        assert error[(coupling, 2, 10.0)] < 0.6 * error[(coupling, 1, 10.0)], coupling
        assert error[(coupling, 0, 2.0)] < error[(coupling, 0, 10.0)]  # and a shorter step helps every hold
    assert "hold 1 at 10 ms: zero-order hold needs 2 ms or less to be as accurate, 5 times the doSteps" in run.stdout


class Recorder:
    """A stand-in of fmpy's FMU2Slave for the helpers: it answers derivatives 10 vr + order and keeps
    what is set."""

    def __init__(self) -> None:
        self.set: list[tuple[list[int], list[int], list[float]]] = []

    def getRealOutputDerivatives(self, vr, order):
        return [10.0 * v + k for v, k in zip(vr, order, strict=True)]

    def setRealInputDerivatives(self, vr, order, value):
        self.set.append((list(vr), list(order), list(value)))


def test_the_coupling_helpers_pass_the_orders_they_are_asked_for():
    source, target = Recorder(), Recorder()
    assert output_rates(source, [1, 4], 2) == [[11.0, 12.0], [41.0, 42.0]]
    assert output_rates(source, [1, 4], 0) == [[], []]
    set_input_rates(target, [7, 8], [[11.0, 12.0], [3.0]])
    set_input_rates(target, [7], [[]])  # held: nothing set
    assert target.set == [([7, 7, 8], [1, 2, 1], [11.0, 12.0, 3.0])]
    assert limited(20.0, [5.0, 1.0], 15.0) == (15.0, [0.0, 0.0]) and limited(3.0, [5.0], 15.0) == (3.0, [5.0])
    assert taylor_rates([1.5, -2.0], 1) == [1.5]
    with pytest.raises(ValueError, match="hold order 3 is not allowed"):
        check_hold(3)
