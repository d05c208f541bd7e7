"""Throughput of `fem-pendulum sweep`: samples per minute with 1 and 2 local workers, and its overhead per
sample against a bare fmpy loop over the same samples in one process.

    python benchmarks/sweep_throughput.py [--fmu dist/FemPendulum.fmu] [--samples 8] [--stop-time 0.5]

The samples are fem runs (steel, default mesh) released at --samples angles
between 0.15 and 0.35 rad, 1 ms steps. The bare loop is `simulate_fmu(fmu, ...)`
per sample in this process (fmpy extracts and instantiates the FMU every
time, as a user's loop would); the sweep is `run_sweep` into a fresh folder,
timed whole (cluster start and stop included) and without the cluster's start
and stop (measured alone just before, and subtracted). CPU s (this process and
its finished children, the workers included) tells whether the cores were
free: near 2x the wall time for 2 workers on an idle 2-core machine. Run it
on a quiet machine: with other jobs on the two cores the 2-worker figure
measures them.
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu

from fem_pendulum_fmu.masters.sweep.driver import SweepSettings, connect, run_sweep
from fem_pendulum_fmu.masters.sweep.samples import grid, samples, start_values


def cpu_seconds() -> float:
    """CPU time of this process and its finished children (a sweep's workers are, once its cluster closed)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def bare_loop(fmu: Path, chosen, stop_time: float) -> list[float]:
    """Seconds per sample of simulate_fmu on the FMU file, one after the other in this process."""
    times = []
    for sample in chosen:
        t0 = time.perf_counter()
        simulate_fmu(str(fmu), stop_time=stop_time, output_interval=1e-3, start_values=start_values(sample.values))
        times.append(time.perf_counter() - t0)
    return times


def cluster_start_stop(workers: int) -> float:
    """Seconds to start a local cluster, connect, and close it (what a sweep pays once)."""
    t0 = time.perf_counter()
    with connect(SweepSettings(fmu=Path(), out=Path(), workers=workers)):
        pass
    return time.perf_counter() - t0


def swept(fmu: Path, chosen, stop_time: float, workers: int) -> tuple[float, float, int, float]:
    """(wall s, CPU s, samples ok, median wall time of one sample on its worker)."""
    with tempfile.TemporaryDirectory() as out:
        t0, c0 = time.perf_counter(), cpu_seconds()
        table = run_sweep(chosen, SweepSettings(fmu=fmu, out=Path(out), stop_time=stop_time, workers=workers))
        wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
        return wall, cpu, int((table["status"] == "ok").sum()), float(table["wall_time"].median())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--stop-time", type=float, default=0.5)
    args = parser.parse_args()
    angles = [float(a) for a in np.linspace(0.15, 0.35, args.samples)]
    chosen = samples(grid([("theta0", angles), ("model.fidelity", ["fem"])]))
    n = len(chosen)
    print(f"load average before: {os.getloadavg()[0]:.2f}; {n} fem samples of {args.stop_time} s")
    c0 = cpu_seconds()
    per_sample = bare_loop(args.fmu, chosen, args.stop_time)
    bare, bare_cpu = sum(per_sample), cpu_seconds() - c0
    rows = []
    for workers in (1, 2):
        start_stop = cluster_start_stop(workers)
        rows.append((workers, start_stop, *swept(args.fmu, chosen, args.stop_time, workers)))
    print("| run | wall s | CPU s | samples/min | without cluster start/stop | median s/sample | overhead vs bare |")
    print("|---|---|---|---|---|---|---|")
    print(
        f"| bare fmpy loop, one process | {bare:.1f} | {bare_cpu:.1f} | {60 * n / bare:.1f} | | "
        f"{float(np.median(per_sample)):.2f} | |"
    )
    for workers, start_stop, total, cpu, ok, median in rows:
        net = total - start_stop
        over = f"{(total - bare) / n:+.2f} s/sample ({(total - bare) / bare:+.0%})"
        over += f", without start/stop {(net - bare) / bare:+.0%}"
        print(
            f"| sweep, {workers} worker(s), {ok} ok | {total:.1f} | {cpu:.1f} | {60 * n / total:.1f} | "
            f"{60 * n / net:.1f} | {median:.2f} | {over if workers == 1 else ''} |"
        )
    ratio = (rows[0][2] - rows[0][1]) / (rows[1][2] - rows[1][1])
    print(f"2 workers / 1 worker (without start/stop): {ratio:.2f}x; load average after: {os.getloadavg()[0]:.2f}")
    print("CPU s near the wall s of the 2-worker row means the two cores were not both free for it")


if __name__ == "__main__":
    main()
