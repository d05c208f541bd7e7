"""`fem-pendulum control`: a controller FMU in the loop with the pendulum FMU; CSV, plot and metrics.

    fem-pendulum control [--controller dist/PidController.fmu] [--connect FROM=TO ...]
                         [--controller-set Kp=20 ...] [--setpoint sine:20deg,0.75]
                         [--disturbance step:2] [--drive-limit 15] [--hold auto]
                         [--set NAME=VALUE ...]

Defaults: the project's PID FMU with its own gains (Kp 10, Ki 4, Kd 0.15, u_max 15), a 20-degree
sine set-point at 0.75 Hz, no disturbance and a drive that limits the torque to 15 N.m. The wall
stands at theta = 0, so every swing to negative angles ends on the wall.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..failures import (
    IncompleteRun,
    UsageError,
    check_fmu,
    check_output_prefix,
    check_start_values,
    check_times,
    fidelity_choice,
    what_to_try,
)
from ..run_options import DEFAULT_FMU, add_run_options

if TYPE_CHECKING:
    from .metrics import Metrics
    from .signals import Signal

DEFAULT_SETPOINT = "sine:20deg,0.75"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_run_options(parser, "communication step of both FMUs (s)")
    add = parser.add_argument
    add(
        "--controller",
        type=Path,
        default=DEFAULT_FMU.parent / "PidController.fmu",
        help="an FMI 2.0 co-simulation controller FMU (default: the PID FMU `fem-pendulum build` wrote)",
    )
    add(
        "--connect",
        action="append",
        default=[],
        metavar="FROM=TO",
        help="a connection (repeatable): FROM pendulum.OUTPUT, setpoint or controller.OUTPUT, TO controller.INPUT "
        "or pendulum.torque; without it inputs named like pendulum outputs or `setpoint` are connected by name",
    )
    add(
        "--controller-set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start value of a controller parameter (repeatable), such as Kp=20",
    )
    add(
        "--setpoint",
        default=DEFAULT_SETPOINT,
        help="the angle to track: a number, step:A[,T], sine:A,F, ramp:R (rad, or deg as in step:10deg) or a CSV "
        "file time,value (value_deg for degrees)",
    )
    add("--disturbance", default="0", help="a torque added at the hinge (N.m), in the forms of --setpoint")
    add("--drive-limit", type=float, default=15.0, help="the drive delivers the demand up to this torque (N.m)")
    add(
        "--hold",
        default="auto",
        metavar="{auto,0,1,2}",
        help="how values vary over a step: 0 held, 1 ramps, 2 parabolas from the FMUs' output derivatives "
        "(docs/notes/coupling.md); auto (default): the highest order both FMUs declare",
    )
    add("--out", type=Path, default=Path("out") / "control", help="prefix of the CSV, PNG and JSON written")


def command(args: argparse.Namespace) -> None:
    """Check every argument, run the loop, write the CSV, the plot and the metrics, and fail with
    IncompleteRun (after writing) when an FMU stopped before the stop time."""
    from ..open_loop import parse_start_values
    from .controllers import controller_fmu
    from .hold import fmu_hold_order, loop_hold, parse_hold
    from .loop import LoopInputs, run_loop
    from .signals import parse_signal

    check_times(args.stop_time, args.step)
    if not (math.isfinite(args.drive_limit) and args.drive_limit > 0):
        raise UsageError(f"--drive-limit {args.drive_limit!r} is not allowed: it must be a finite torque > 0 (N.m)")
    check_fmu(args.fmu)
    check_fmu(args.controller, "--controller")
    setpoint = parse_signal(args.setpoint, "angle", "--setpoint")
    disturbance = parse_signal(args.disturbance, "torque", "--disturbance")
    values = {"theta0": 0.0, **parse_start_values(args.set)}
    scene = check_start_values(values)
    spec = controller_fmu(args.controller, args.connect, args.controller_set)
    hold = parse_hold(args.hold)
    loop_hold(hold, fmu_hold_order(args.fmu), spec.hold, args.controller.name)
    check_output_prefix(args.out)  # the last check: it makes the output folder
    choice = fidelity_choice(scene)
    if choice is not None:
        print(choice)
    inputs = LoopInputs(args.fmu, setpoint, disturbance, args.stop_time, args.step, values, args.drive_limit, hold=hold)
    run = run_loop(inputs, spec.open())
    wrote = write_outputs(run.table, args, setpoint)
    if run.stopped is not None and "KeyboardInterrupt" in run.stopped:  # Ctrl-C inside an FMU's Python
        raise KeyboardInterrupt
    if run.stopped is not None:
        raise IncompleteRun(
            f"{run.stopped}. Wrote {wrote} up to there. {what_to_try(run.stopped, 'a smaller drive limit')}"
        )
    print(f"wrote {wrote}; {summary(run.table, args, setpoint)}")


def _metrics(table: np.ndarray, args: argparse.Namespace, setpoint: Signal) -> Metrics:
    import pandas as pd

    from .metrics import loop_metrics

    return loop_metrics(pd.DataFrame(table), step_size=args.step, drive_limit=args.drive_limit, setpoint=setpoint)


def write_outputs(table: np.ndarray, args: argparse.Namespace, setpoint: Signal) -> str:
    """Write PREFIX.csv, PREFIX.png and PREFIX.json (the metrics); what was written, as text."""
    from .figure import plot_loop
    from .metrics import metrics_json

    csv = args.out.with_suffix(".csv")
    names = table.dtype.names or ()
    np.savetxt(csv, table.view((float, len(names))), delimiter=",", header=",".join(names), comments="")
    png = plot_loop(table, args.out.with_suffix(".png"), f"{args.controller.name} in the loop with the FE pendulum")
    report = {
        "controller": str(args.controller),
        "connect": args.connect,
        "controller_set": args.controller_set,
        "disturbance": args.disturbance,
        "hold": args.hold,
        **metrics_json(_metrics(table, args, setpoint)),
    }
    path = args.out.with_suffix(".json")
    path.write_text(json.dumps(report, indent=2) + "\n")
    return f"{csv}, {png} and {path}"


def summary(table: np.ndarray, args: argparse.Namespace, setpoint: Signal) -> str:
    """The metrics a complete run prints."""
    m = _metrics(table, args, setpoint)
    return (
        f"RMS tracking error {math.degrees(m['rms_error']):.2f} deg, {m['impacts']:.0f} wall impacts, "
        f"largest contact force {m['max_contact_force']:.1f} N, {m['time_at_drive_limit']:.3f} s at the drive limit"
    )
