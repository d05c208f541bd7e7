"""The one command line: fem-pendulum build | run | control | sweep | host-env | interface.

Each subcommand is a thin call into the package: the FMU builder (fmi/builder.py
and masters/pid), the open-loop, controller and sweep masters (masters/), the
host environment and the interface table (fmi/). The help says what a user
needs and names no file of the package (DESCRIPTION).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .version import __version__

DESCRIPTION = """\
The pendulum FMU and the masters that drive it: build the FMUs, run one with a
torque profile (run), in a loop with a controller FMU (control) or over a grid
or table of parameter values (sweep); print what a native host needs to load
the FMU (host-env) and the FMU's variables (interface).

Parameters, outputs and enumeration items are named as the FMU names them
(pendulum.E, energy.total, model.fidelity=rigid): `fem-pendulum interface`
lists them."""


def build(args: argparse.Namespace) -> None:
    """Build FemPendulum.fmu (and PidController.fmu beside it) and print their paths; with --fmi-version 3,
    the FMI 3.0 FemPendulum FMU alone."""
    from .fmi.builder import build_pendulum, validate

    if args.fmi_version == 3:
        from .fmi.builder3 import build_pendulum3

        print(build_pendulum3(args.output or Path("dist") / "FemPendulum3.fmu"))
        return
    output = args.output or Path("dist") / "FemPendulum.fmu"
    print(build_pendulum(output))
    if not args.no_controller:
        from .masters.pid.build import build_pid_fmu

        print(validate(build_pid_fmu(output.resolve().parent / "PidController.fmu")))


def add_build_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        help="where to write the FMU (default: dist/FemPendulum.fmu; FMI 3.0: dist/FemPendulum3.fmu)",
    )
    parser.add_argument(
        "--fmi-version",
        type=int,
        choices=(2, 3),
        default=2,
        help="2: the FMI 2.0 FMU and PidController.fmu beside it; 3: the FMI 3.0 FMU (docs/reference/fmi3.md)",
    )
    parser.add_argument("--no-controller", action="store_true", help="do not build PidController.fmu")


class DefaultsHelp(argparse.ArgumentDefaultsHelpFormatter):
    """Help that shows an option's default where it has one worth showing (not None, [] or False)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default in (None, [], False, argparse.SUPPRESS) or "default" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)


def parser() -> argparse.ArgumentParser:
    from .fmi import host_env, interface
    from .masters import open_loop, sweep
    from .masters.control import command as control

    top = argparse.ArgumentParser(
        prog="fem-pendulum", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    top.add_argument("--version", action="version", version=f"fem_pendulum_fmu {__version__}")
    sub = top.add_subparsers(dest="command", required=True, metavar="COMMAND")
    verbs = (
        ("build", "build the FMUs", add_build_arguments, build),
        (
            "run",
            "open loop: a torque profile through the FMU, CSV and plot",
            open_loop.add_arguments,
            open_loop.command,
        ),
        (
            "control",
            "a controller FMU in the loop (the PID FMU, or yours), CSV, plot and metrics",
            control.add_arguments,
            control.command,
        ),
        (
            "sweep",
            "a grid or table of parameter values through the FMU on Dask, results table and plot",
            sweep.add_arguments,
            sweep.command,
        ),
        (
            "host-env",
            "print the environment variables that point a native host's FMU at this Python",
            lambda p: None,
            lambda a: host_env.main(),
        ),
        (
            "interface",
            "print the FMU's variables: name, causality, type, unit and start value",
            interface.add_arguments,
            interface.command,
        ),
    )
    for name, help_text, add_arguments, run in verbs:
        verb = sub.add_parser(name, help=help_text, description=help_text, formatter_class=DefaultsHelp)
        add_arguments(verb)
        verb.set_defaults(run=run)
    return top


def main(argv: list[str] | None = None) -> None:
    """Run a subcommand. Bad input is one line on stderr and exit 2, a run that stopped early its
    message and exit 1, Ctrl-C exit 130: never a traceback (masters/failures.py)."""
    from .masters.failures import IncompleteRun, UsageError

    args = parser().parse_args(argv)
    try:
        args.run(args)
    except UsageError as exc:
        raise SystemExit(_fail(args, f"error: {exc}", 2)) from None
    except IncompleteRun as exc:
        raise SystemExit(_fail(args, f"incomplete: {exc}", 1)) from None
    except KeyboardInterrupt:
        raise SystemExit(_fail(args, "interrupted (what was written so far is kept)", 130)) from None


def _fail(args: argparse.Namespace, message: str, code: int) -> int:
    """Print `fem-pendulum COMMAND: message` on stderr; the exit code."""
    print(f"fem-pendulum {args.command}: {message}", file=sys.stderr)
    return code


if __name__ == "__main__":
    main()
