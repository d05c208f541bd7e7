"""What the number of steps per contact buys and costs on the steel scene: accuracy against the tail.

    python benchmarks/contact_steps.py [--counts 58 29 16 12 10 8 6 4 3 2] [--t-end 2.0] [--repeat 3]

The default fem model on the steel scene (steel(), rigid wall, released at 20
degrees, no torque), advanced in 1 ms communication steps as a master drives
it, once for each forced count of internal steps per contact duration (the
step control's `contact_steps` replaced by the count; the count 0 is the
rule of physics/stepping.py as it is). For each count it prints:

- theta's largest error before the reference's second impact, against the
  L2 reference of benchmarks/references (what the accuracy target bounds) and
  against the run with the first count given (the count's own error, with
  the mesh's taken out: give the finest count first);
- the first impact's largest contact force and penetration at the internal
  steps;
- the largest energy error over the swing energy;
- the internal steps and the Newton iterations of the impact doSteps (those
  of more than two internal steps), and the doStep latency: median, 99.9th
  percentile and slowest over the median (perf_counter around each advance),
  the median of --repeat runs with their spread (the runs of a count are
  otherwise identical: one thread, deterministic).

The latency ratios are those of the model alone, without the FMU's own cost per
doStep, which adds the same to every doStep and so lowers the ratios a little
(docs/notes/latency.md has them through the FMU). Timings are wall times in one
process: run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from dataclasses import dataclass, fields

import numpy as np
from speed_vs_error import early_window, load_reference

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import steel
from fem_pendulum_fmu.physics.stepping import StepControl

FIRST_IMPACT = slice(200, 300)  # the communication steps around the first impact (at 0.240 s)


@dataclass(frozen=True)
class ForcedCount(StepControl):
    """The step control with a fixed number of steps per contact duration."""

    count: int = 16

    def contact_steps(self, t_contact: float) -> int:
        return self.count if t_contact < math.inf else self.steps_per_contact


def forced(control: StepControl, count: int) -> StepControl:
    """`control` with `count` steps per contact (0: unchanged)."""
    if count == 0:
        return control
    return ForcedCount(**{f.name: getattr(control, f.name) for f in fields(control)}, count=count)


def run(count: int, t_end: float) -> dict:
    """One run of the steel scene with `count` steps per contact; its series and figures."""
    model = FemModel(steel())
    model.control = forced(model.control, count)
    swing, e0 = swing_energy(model.scene), model.outputs().energy_total
    theta, latency, outputs = [model.outputs().theta], [], []
    iterations_before = 0
    impact_steps, impact_iterations = [], []
    for i in range(1, round(t_end / 1e-3) + 1):
        t0 = time.perf_counter()
        o = model.advance(i * 1e-3, 0.0)
        latency.append(time.perf_counter() - t0)
        theta.append(o.theta)
        outputs.append(o)
        its = model.newton.counts.iterations
        if o.solver_substeps > 2:
            impact_steps.append(o.solver_substeps)
            impact_iterations.append(its - iterations_before)
        iterations_before = its
    lat = np.array(latency)
    median = float(np.median(lat))
    first = outputs[FIRST_IMPACT]
    return {
        "theta": np.array(theta),
        "force": max(o.contact_force_max for o in first),
        "penetration": -min(o.gap_min for o in first),
        "energy": max(abs(o.energy_total - o.energy_torque_work - e0) for o in outputs) / swing,
        "impact_steps": impact_steps,
        "impact_iterations": impact_iterations,
        "median_ms": 1e3 * median,
        "p999": float(np.percentile(lat, 99.9)) / median,
        "slowest": float(lat.max()) / median,
    }


def _median_and_spread(values: list[float]) -> str:
    v = sorted(values)
    return f"{np.median(v):.3g} ({v[0]:.3g}-{v[-1]:.3g})" if len(v) > 1 else f"{v[0]:.3g}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--counts", type=int, nargs="+", default=[58, 29, 16, 12, 10, 8, 6, 4, 3, 2])
    parser.add_argument("--t-end", type=float, default=2.0)
    parser.add_argument("--repeat", type=int, default=3, help="runs per count; the latency's median is printed")
    args = parser.parse_args()
    reference = load_reference("steel")
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} at {time.strftime('%H:%M:%S')}")
    print(
        "| steps per contact | theta error vs reference (rad) | vs the first count (rad) | first impact: "
        "peak force N, penetration um | energy error / swing | internal steps of the "
        "impact doSteps | their Newton iterations | doStep median ms | 99.9th / median | slowest / median |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    baseline = None
    for count in args.counts:
        runs = [run(count, args.t_end) for _ in range(args.repeat)]
        r = runs[0]
        assert all(np.array_equal(x["theta"], r["theta"]) for x in runs), "runs of one count differ"
        timing = {key: _median_and_spread([x[key] for x in runs]) for key in ("median_ms", "p999", "slowest")}
        n = early_window(reference) if reference is not None else len(r["theta"])
        n = min(n, len(r["theta"]))
        vs_ref = np.max(np.abs(r["theta"][:n] - reference["theta"][:n])) if reference is not None else math.nan
        baseline = r["theta"] if baseline is None else baseline
        vs_first = np.max(np.abs(r["theta"][:n] - baseline[:n]))
        print(
            f"| {count or 'the rule'} | {vs_ref:.2e} | {vs_first:.2e} | {r['force']:.0f}, {1e6 * r['penetration']:.2f} "
            f"| {r['energy']:.1e} | {' '.join(map(str, r['impact_steps']))} "
            f"| {' '.join(map(str, r['impact_iterations']))} | {timing['median_ms']} | {timing['p999']} "
            f"| {timing['slowest']} |",
            flush=True,
        )
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} at {time.strftime('%H:%M:%S')}")


if __name__ == "__main__":
    main()
