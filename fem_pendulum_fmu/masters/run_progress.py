"""A progress bar for a run that is expected to take longer than about 2 s, judged by the time its
first steps take, not by its step count (a rigid run of 10,000 steps is over in a second, a soft
FE run of 500 takes minutes); quiet when stderr is not a terminal."""

from __future__ import annotations

import sys
import time
from typing import Any

SHOW_ABOVE = 2.0  # s: expected runs longer than this get a bar
JUDGE_AFTER = 0.25  # s of wall time before the expectation is judged


class RunProgress:
    """Call `step()` after each communication step of `total`; `close()` at the end."""

    def __init__(self, total: int, enabled: bool = True) -> None:
        self.total, self.done = total, 0
        self.enabled = enabled and sys.stderr.isatty()
        self._start = time.perf_counter()
        self._judged = False
        self._bar: Any = None

    def step(self) -> bool:
        """Count a step (True: go on, as fmpy's step_finished callback wants)."""
        self.done += 1
        if self._bar is not None:
            self._bar.update(1)
        elif self.enabled and not self._judged:
            elapsed = time.perf_counter() - self._start
            if elapsed >= JUDGE_AFTER:
                self._judged = True
                if expected_seconds(self.done, self.total, elapsed) > SHOW_ABOVE:
                    self._bar = _bar(self.total, self.done)
        return True

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def _bar(total: int, done: int) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="step", desc="simulating")


def expected_seconds(done: int, total: int, elapsed: float) -> float:
    """The whole run's wall time expected from `done` of `total` steps taking `elapsed` s."""
    return elapsed / max(done, 1) * total
