"""Throughput of `fem-pendulum sweep`: samples per minute with 1 and 2 local workers, and its overhead per
sample against a bare fmpy loop over the same samples in one process.

    python benchmarks/sweep_throughput.py [--fmu dist/FemPendulum.fmu] [--samples 8] [--stop-time 0.5]

The samples are fem runs (steel, default mesh) released at --samples angles
between 0.15 and 0.35 rad, 1 ms steps. The bare loop is `simulate_fmu(fmu, ...)`
per sample in this process (fmpy extracts and instantiates the FMU every
time, as a user's loop would); the sweep is `run_sweep` into a fresh folder,
timed whole (cluster start and stop included) and without the cluster's start
and stop (measured alone just before, and subtracted). Run it on a quiet
machine: with other jobs on the two cores the 2-worker figure measures them.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu

from fem_pendulum_fmu.masters.sweep.driver import SweepSettings, connect, run_sweep
from fem_pendulum_fmu.masters.sweep.samples import grid, samples, start_values


def bare_loop(fmu: Path, chosen, stop_time: float) -> float:
    t0 = time.perf_counter()
    for sample in chosen:
        simulate_fmu(str(fmu), stop_time=stop_time, output_interval=1e-3, start_values=start_values(sample.values))
    return time.perf_counter() - t0


def cluster_start_stop(workers: int) -> float:
    """Seconds to start a local cluster, connect, and close it (what a sweep pays once)."""
    t0 = time.perf_counter()
    with connect(SweepSettings(fmu=Path(), out=Path(), workers=workers)):
        pass
    return time.perf_counter() - t0


def swept(fmu: Path, chosen, stop_time: float, workers: int) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        table = run_sweep(chosen, SweepSettings(fmu=fmu, out=Path(out), stop_time=stop_time, workers=workers))
        return time.perf_counter() - t0, int((table["status"] == "ok").sum())


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
    bare = bare_loop(args.fmu, chosen, args.stop_time)
    rows = []
    for workers in (1, 2):
        start_stop = cluster_start_stop(workers)
        total, ok = swept(args.fmu, chosen, args.stop_time, workers)
        rows.append((workers, total, total - start_stop, ok))
    print("| run | wall s | samples/min | samples/min without cluster start/stop | overhead/sample vs bare |")
    print("|---|---|---|---|---|")
    print(f"| bare fmpy loop, one process | {bare:.1f} | {60 * n / bare:.1f} | | |")
    for workers, total, net, ok in rows:
        over = f"{(total - bare) / n:+.2f} s ({(total - bare) / bare:+.0%})"
        over += f"; without start/stop {(net - bare) / bare:+.0%}"
        print(
            f"| sweep, {workers} worker(s), {ok} ok | {total:.1f} | {60 * n / total:.1f} | {60 * n / net:.1f} | "
            f"{over if workers == 1 else ''} |"
        )
    print(
        f"2 workers / 1 worker (without start/stop): {rows[0][2] / rows[1][2]:.2f}x; "
        f"load average after: {os.getloadavg()[0]:.2f}"
    )


if __name__ == "__main__":
    main()
