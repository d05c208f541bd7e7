"""Cost per communication step of the controller loop: the PID FMU against the same PID law as a
Python function (fem_pendulum_fmu.testing.closed_loop), on the rigid and the fem fidelity; both held
over each step (hold order 0), and the PID FMU with second-order hold (`pid_hold2`, the default of
`fem-pendulum control` with the PID FMU: the output derivatives cost a share of each step).

    python benchmarks/controller_loop.py [--fmus dist] [--repeat 5] [--stop-time 2] [--old PATH]

Each run is a fresh process running masters/control/loop.py's master for the default loop of
`fem-pendulum control` (20-degree sine at 0.75 Hz, 15 N.m drive, 1 ms steps); the clock runs over
the steps after the first (StepClock), without the imports and the FMUs' instantiation. The runs
alternate (pid, function, pid, ...) so that a slow spell of the machine hits both. --old PATH
also times the loop of another checkout (a git worktree of an earlier commit, whose
masters/controller_loop.py run_loop it imports) in the same alternation. Printed: CPU and wall
microseconds per step (median and spread of --repeat runs), and the largest difference in theta
between the PID FMU's and the function's series (the two compute the same law, so 0 is expected).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


class StepClock:
    """Stands in for the loop's progress bar (masters/run_progress.py RunProgress, which both loops call
    after every step and at the end): the clocks at the first step's end and at the close, so that the
    time of the steps after the first is measured without the FMUs' instantiation."""

    marks: list[tuple[float, float]] = []

    def __init__(self, n: int, enabled: bool = True) -> None:
        pass

    def step(self) -> bool:
        if not StepClock.marks:
            StepClock.marks.append((time.perf_counter(), time.process_time()))
        return True

    def close(self) -> None:
        StepClock.marks.append((time.perf_counter(), time.process_time()))


def child(kind: str, fidelity: str, fmus: Path, stop_time: float) -> None:
    """One timed loop; prints a JSON line: cpu and wall seconds of the steps after the first, their
    number, the theta series."""
    values = {"model.fidelity": {"rigid": 2, "fem": 4}[fidelity]}
    import fmpy.fmi2  # noqa: F401  (imports before the clock starts)

    if kind == "old":
        import fem_pendulum_fmu.masters.controller_loop as old_module
        from fem_pendulum_fmu.masters.controller_loop import run_loop as old_run_loop

        old_module.RunProgress = StepClock  # type: ignore[attr-defined]
    else:
        import pandas  # noqa: F401

        import fem_pendulum_fmu.masters.control.command
        import fem_pendulum_fmu.masters.control.loop
        import fem_pendulum_fmu.masters.pid.fem_pendulum_pid_entry

        fem_pendulum_fmu.masters.control.loop.RunProgress = StepClock  # type: ignore[attr-defined]
    if kind == "old":
        old = old_run_loop(fmus / "FemPendulum.fmu", fmus / "PidController.fmu", stop_time, 1e-3, values)
        theta = old.data["theta"]
    else:
        theta = new_loop(kind, values, fmus, stop_time)
    (w0, c0), (w1, c1) = StepClock.marks
    steps = round(stop_time / 1e-3) - 1
    print(json.dumps({"cpu": c1 - c0, "wall": w1 - w0, "steps": steps, "theta": list(map(float, theta))}))


def new_loop(kind: str, values: dict, fmus: Path, stop_time: float):
    from fem_pendulum_fmu.masters.control.command import DEFAULT_SETPOINT
    from fem_pendulum_fmu.masters.control.controllers import FunctionController, controller_fmu
    from fem_pendulum_fmu.masters.control.loop import LoopInputs, run_loop
    from fem_pendulum_fmu.masters.control.signals import parse_signal
    from fem_pendulum_fmu.masters.pid.fem_pendulum_pid_entry import Pid

    inputs = LoopInputs(fmus / "FemPendulum.fmu", parse_signal(DEFAULT_SETPOINT, "angle"), stop_time=stop_time,
                        start_values=values, hold=2 if kind == "pid_hold2" else 0)  # fmt: skip
    if kind in ("pid", "pid_hold2"):
        controller = controller_fmu(fmus / "PidController.fmu").open()
    else:
        pid = Pid()  # the PID FMU's law and default gains, in this process
        controller = FunctionController(lambda t, m: pid.update(m.setpoint, m.theta, 1e-3))
    run = run_loop(inputs, controller)
    assert run.stopped is None, run.stopped
    return run.table["theta"]


def timed(kind: str, fidelity: str, args: argparse.Namespace) -> dict:
    env = dict(os.environ)
    if kind == "old":
        env["PYTHONPATH"] = str(Path(args.old).resolve())
    cmd = [sys.executable, __file__, "--child", kind, fidelity, str(args.fmus), str(args.stop_time)]
    run = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmus", type=Path, default=Path("dist"), help="folder of FemPendulum.fmu and PidController.fmu")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--stop-time", type=float, default=2.0)
    p.add_argument("--fidelities", nargs="+", default=["rigid", "fem"])
    p.add_argument("--old", help="a checkout of an earlier commit whose loop to time alongside")
    p.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        kind, fidelity, fmus, stop = args.child
        child(kind, fidelity, Path(fmus), float(stop))
        return
    kinds = ["pid", "pid_hold2", "function"] + (["old"] if args.old else [])
    print(f"load average before: {os.getloadavg()}")
    for fidelity in args.fidelities:
        runs: dict[str, list[dict]] = {k: [] for k in kinds}
        for _ in range(args.repeat):
            for kind in kinds:
                runs[kind].append(timed(kind, fidelity, args))
        diff = max(abs(a - b) for a, b in zip(runs["pid"][0]["theta"], runs["function"][0]["theta"], strict=True))
        print(f"\n{fidelity}: {runs['pid'][0]['steps']} steps; max |theta_pid_fmu - theta_function| = {diff:.3g} rad")
        print("| controller | CPU us/step (median, spread) | wall us/step (median, spread) |")
        print("|---|---|---|")
        for kind in kinds:
            row = []
            for clock in ("cpu", "wall"):
                per_step = [1e6 * r[clock] / r["steps"] for r in runs[kind]]
                row.append(f"{statistics.median(per_step):.1f} ({min(per_step):.1f}-{max(per_step):.1f})")
            print(f"| {kind} | {row[0]} | {row[1]} |")
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
