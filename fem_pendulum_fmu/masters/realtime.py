"""Pacing a run to the wall clock, as a real-time rig steps its FMUs: communication step k must
end by its deadline, the first step's end plus k times the step, and a step that ends later is an
overrun. The schedule is fixed, as a rig's is: a late step does not move the later deadlines, so
a run that falls behind shows every step it is behind for."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Overrun:
    time: float  # simulated time at the end of the late step (s)
    late: float  # how long after its deadline it ended (s)


@dataclass
class Pacer:
    """Call `step_done(t)` when the step ending at simulated time t is done: it waits for the wall
    clock to reach that step's deadline, or records the overrun."""

    clock: Callable[[], float] = time.perf_counter
    sleep: Callable[[float], None] = time.sleep
    overruns: list[Overrun] = field(default_factory=list)
    steps: int = 0
    slowest: Overrun = Overrun(0.0, 0.0)  # the longest wall time a paced step took, and when (time, s)
    _origin: tuple[float, float] | None = None  # (wall, simulated) time at the end of the first step
    _released: float = 0.0  # wall time the last step was let go (its end, or its deadline if it waited)

    def step_done(self, t: float) -> bool:
        """Wait for this step's deadline, or record that it was missed (True: go on)."""
        now = self.clock()
        self.steps += 1
        if self._origin is None:
            self._origin = (now, t)  # the first step sets the schedule: start-up is not a step
            self._released = now
            return True
        if now - self._released > self.slowest.late:
            self.slowest = Overrun(t, now - self._released)
        deadline = self._origin[0] + (t - self._origin[1])
        if now < deadline:
            self.sleep(deadline - now)
            self._released = self.clock()
        else:
            self.overruns.append(Overrun(t, now - deadline))
            self._released = now
        return True

    def report(self) -> str:
        """One line: how many steps missed their deadline, the worst, and when it happened."""
        paced = max(self.steps - 1, 0)
        slowest = f"the slowest step took {self.slowest.late * 1e3:.3g} ms (at t = {self.slowest.time:.6g} s)"
        if not self.overruns:
            return f"real time: all {paced} paced steps ended by their deadlines; {slowest}"
        worst = max(self.overruns, key=lambda o: o.late)
        first = self.overruns[0]
        return (
            f"real time: {len(self.overruns)} of {paced} paced steps overran, the worst by "
            f"{worst.late * 1e3:.3g} ms at t = {worst.time:.6g} s (the first at t = {first.time:.6g} s); {slowest}"
        )
