"""`fem-pendulum sweep --control`: the options of `fem-pendulum control` that a loop sweep takes, and its samples.

    fem-pendulum sweep --control [--controller dist/PidController.fmu] [--connect FROM=TO ...]
        [--controller-set NAME=VALUE ...] [--setpoint TEXT] [--disturbance TEXT] [--drive-limit N.m]
        --param controller.Kp=5,10,20 --param 'setpoint=step:10deg;step:20deg' --set model.fidelity=rigid

Every check runs before anything does, each bad input one line (UsageError). A name fixed for every
sample (--set, --controller-set, --setpoint, --disturbance) may not be an axis or a table column too.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..control.hold import fmu_hold_order, loop_hold, parse_hold
from ..failures import UsageError, check_fmu
from .loop_samples import (
    CONTROLLER,
    DEFAULT_DRIVE_LIMIT,
    DEFAULT_SIGNALS,
    SIGNAL_SEPARATOR,
    LoopSweep,
    loop_samples,
    parse_loop_param,
)
from .samples import Sample, grid, read_table

LOOP_OPTIONS = ("controller", "connect", "controller_set", "setpoint", "disturbance", "drive_limit", "hold")
DEFAULT_PLOT = ("rms_error", "overshoot", "settling_time", "max_contact_force")


def add_loop_arguments(parser: argparse.ArgumentParser) -> None:
    add = parser.add_argument
    add(
        "--control",
        action="store_true",
        help="run each sample as the controller loop of `fem-pendulum control` (the figures are its metrics) "
        "instead of a torque profile; axes may then be controller.NAME, setpoint and disturbance",
    )
    add("--controller", type=Path, help="with --control: the controller FMU (default: PidController.fmu beside --fmu)")
    add("--connect", action="append", default=[], metavar="FROM=TO", help="with --control: as `fem-pendulum control`")
    add(
        "--controller-set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="with --control: a controller parameter every sample shares, such as Ki=4",
    )
    add(
        "--setpoint",
        help=f"with --control: the set-point every sample tracks, as `fem-pendulum control` takes it "
        f"(default: {DEFAULT_SIGNALS['setpoint']}); an axis: --param 'setpoint=S1{SIGNAL_SEPARATOR}S2'",
    )
    add("--disturbance", help="with --control: the hinge torque added in every sample (N.m) (default: 0)")
    limit = f"with --control: the drive's torque limit (N.m) (default: {DEFAULT_DRIVE_LIMIT:g})"
    add("--drive-limit", type=float, help=limit)
    add("--hold", metavar="{auto,0,1,2}", help="with --control: the loop's hold order, as `fem-pendulum control`")


def loop_sweep(args: argparse.Namespace) -> LoopSweep | None:
    """The loop every sample shares (None without --control), checked; UsageError for a loop option
    without --control, a controller FMU that is missing or unreadable, a bad wiring or drive limit."""
    if not args.control:
        given = [name for name in LOOP_OPTIONS if getattr(args, name) not in (None, [])]
        if given:
            options = ", ".join("--" + name.replace("_", "-") for name in given)
            raise UsageError(f"{options}: only with --control (a sweep of the controller loop)")
        return None
    controller = args.controller if args.controller is not None else args.fmu.parent / "PidController.fmu"
    check_fmu(controller, "--controller")
    drive_limit = DEFAULT_DRIVE_LIMIT if args.drive_limit is None else args.drive_limit
    hold = parse_hold("auto" if args.hold is None else args.hold)
    loop = LoopSweep(controller, tuple(args.connect), drive_limit, hold)
    spec = loop.spec()
    loop_hold(hold, fmu_hold_order(check_fmu(args.fmu)), spec.hold, controller.name)
    return loop


def _fixed(args: argparse.Namespace, loop: LoopSweep, pendulum: dict) -> dict:
    """The values every sample shares: --set, --controller-set (as controller.NAME), --setpoint, --disturbance."""
    from ..control.controllers import parameter_values

    controller = parameter_values(args.controller_set, loop.parameter_types())
    signals = {name: getattr(args, name) for name in DEFAULT_SIGNALS if getattr(args, name) is not None}
    signals = {name: str(Path(t).resolve()) if Path(t).is_file() else t for name, t in signals.items()}  # from here
    return {**pendulum, **{CONTROLLER + k: v for k, v in controller.items()}, **signals}


def _axes(items: list[str], loop: LoopSweep) -> list:
    """--param items of a loop sweep; every unreadable one reported at once, on one line."""
    types = loop.parameter_types()
    axes, problems = [], []
    for item in items:
        try:
            axes.append(parse_loop_param(item, types))
        except ValueError as exc:
            problems.append(f"--param {item}: {exc}")
    if problems:
        raise UsageError("; ".join(problems))
    return axes


def loop_sample_list(args: argparse.Namespace, loop: LoopSweep, pendulum: dict) -> list[Sample]:
    """The loop sweep's samples from --param axes or a --table, and the values every sample shares
    (`pendulum`: the --set values, already read); UsageError (one line)."""
    if args.torque is not None:
        raise UsageError("--torque: a loop sweep's torque comes from the controller; leave --torque out with --control")
    fixed = _fixed(args, loop, pendulum)
    rows = read_table(args.table) if args.table else grid(_axes(args.param, loop))
    varied = set(rows[0]) if rows else set()
    twice = sorted(varied & set(fixed))
    if twice:
        where = "--table columns" if args.table else "--param axes"
        raise UsageError(f"{', '.join(twice)}: both {where} and fixed for every sample; give each once")
    try:
        return loop_samples([{**row, **fixed} for row in rows], loop, args.table.parent if args.table else None)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
