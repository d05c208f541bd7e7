"""The options every command that runs the pendulum FMU shares: which FMU, how long, how finely,
which start values (`fem-pendulum run` and `control`)."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_FMU = Path("dist") / "FemPendulum.fmu"


def add_run_options(parser: argparse.ArgumentParser, step_help: str = "communication step (s)") -> None:
    """--fmu, --stop-time, --step and --set (repeatable NAME=VALUE, read by open_loop.parse_start_values)."""
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU, help="the pendulum FMU `fem-pendulum build` wrote")
    parser.add_argument("--stop-time", type=float, default=2.0, help="simulated time (s)")
    parser.add_argument("--step", type=float, default=1e-3, help=step_help)
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start value of a pendulum parameter (repeatable; `fem-pendulum interface` lists them)",
    )
