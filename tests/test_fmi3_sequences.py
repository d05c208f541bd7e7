"""Random FMI 3.0 call sequences against the FMI 3.0 FMU, judged by FMI 3.0's state machine (tests/fmi3_sequences.py).

The fast lane runs 100 sequences of 40 calls (about 4,000 calls, a few seconds) in a child process; the
slow lane 1,000. Every violation kind must be zero, and the sequences must reach the states worth
reaching (else a zero would say little).
"""

from __future__ import annotations

import pytest
from fmu3_instance import child

SEQUENCES = "fmi3_sequences"


def check(got: dict, sequences: int) -> None:
    assert got["violations"] == []
    assert got["calls"] >= 30 * sequences and "4" not in got["statuses"]  # never fmi3Fatal
    assert got["statuses"]["0"] > 0.3 * got["calls"] and got["statuses"]["3"] > 0.2 * got["calls"]
    reached = got["reached"]
    for key in ("instantiated", "init", "event", "step", "terminated", "early return", "restored", "resumed"):
        assert reached.get(key, 0) >= sequences // 10, (key, reached)


@pytest.mark.slow
def test_random_fmi3_sequences_get_the_answers_the_state_machine_promises(fmu3):
    check(child(SEQUENCES, "run_sequences", str(fmu3), 100, 1), 100)


@pytest.mark.slow
def test_a_thousand_random_fmi3_sequences_find_no_violation(fmu3):
    check(child(SEQUENCES, "run_sequences", str(fmu3), 1000, 2), 1000)
