"""`fem-pendulum sweep`: a grid or a table of parameter values through the FMU on Dask.

    fem-pendulum sweep --param pendulum.E=1e6,1e7,2.1e11 --param theta0=0.2,0.35 \\
        --set model.fidelity=rigid --stop-time 1 --out out/sweep [--workers 2 | --scheduler tcp://HOST:8786]

    fem-pendulum sweep --control --param controller.Kp=5,10,20 --param 'setpoint=step:10deg;step:20deg' \
        --set model.fidelity=rigid --stop-time 1 --out out/tuning

Writes OUT/results.parquet (one row a sample), OUT/series.parquet (the time
series, keyed by sample_id), OUT/summary.png, and OUT/results.csv with --csv.
Started again with the same OUT, it runs only the samples OUT does not hold.
With --control each sample is the controller loop of `fem-pendulum control`
(loop_command.py): its figures are the loop's metrics, its series the loop's table.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..failures import IncompleteRun, UsageError, check_fmu, check_output_prefix, check_times
from ..run_options import DEFAULT_FMU
from .loop_command import DEFAULT_PLOT, add_loop_arguments, loop_sample_list, loop_sweep

if TYPE_CHECKING:
    from .driver import SweepSettings
    from .loop_samples import LoopSweep

EXTRA = ("dask", "distributed", "pandas", "pyarrow")
CURVES_UP_TO = 8  # a loop sweep's plot draws a curve per value of --y up to this many values (else colour)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU, help="the pendulum FMU `fem-pendulum build` wrote")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=V1,V2,...",
        help="a grid axis: the samples are the product of all axes (enumerations by item name; with --control "
        "also controller.NAME=V1,V2 and setpoint=S1;S2 or disturbance=S1;S2)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start value of a pendulum parameter every sample shares (repeatable)",
    )
    parser.add_argument("--table", type=Path, help="CSV, one row a sample, columns parameter names (and torque)")
    parser.add_argument("--torque", type=Path, help="CSV time,torque for every sample (a table's torque column wins)")
    parser.add_argument("--stop-time", type=float, default=2.0, help="simulated time of every sample (s)")
    parser.add_argument("--step", type=float, default=1e-3, help="communication step = output interval (s)")
    parser.add_argument("--outputs", default="", metavar="NAME,...", help="outputs kept in the series (default: all)")
    parser.add_argument("--workers", type=int, help="local cluster of N >= 1 worker processes (default: one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    parser.add_argument("--out", type=Path, default=Path("out") / "sweep", help="output folder (resumed if it exists)")
    parser.add_argument("--csv", action="store_true", help="also write results.csv")
    parser.add_argument("--retry-failed", action="store_true", help="run again the samples that ended in error")
    parser.add_argument(
        "--plot",
        metavar="FIGURE,...",
        help="figures of the summary plot, one panel each (default: largest_penetration; with --control "
        f"{','.join(DEFAULT_PLOT)})",
    )
    parser.add_argument("--x", help="parameter on the plot's x axis (default: the first --param)")
    parser.add_argument("--y", help="a second parameter, shown as the y axis (figure as colour)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_loop_arguments(parser)


def _need_extra() -> None:
    missing = [name for name in EXTRA if importlib.util.find_spec(name) is None]
    if missing:
        raise UsageError(f"fem-pendulum sweep needs {', '.join(missing)}: pip install 'fem_pendulum_fmu[sweep]'")


def _axes(items: list[str], option: str) -> list:
    """NAME=V1,V2 items parsed; every unreadable one reported at once."""
    from . import samples

    axes, problems = [], []
    for item in items:
        try:
            axes.append(samples.parse_param(item, "NAME=VALUE" if option == "--set" else "NAME=VALUE1,VALUE2,..."))
        except ValueError as exc:
            problems.append(f"{option} {item}: {exc}")
    if problems:
        raise UsageError("; ".join(problems))
    return axes


def _samples(args: argparse.Namespace, loop: LoopSweep | None = None) -> list:
    from . import samples

    fixed = dict(_axes(args.set, "--set"))
    if any(len(values) != 1 for values in fixed.values()):
        raise UsageError("--set takes one value: NAME=VALUE (a list is a grid axis: --param)")
    if args.table and args.param:
        raise UsageError("give the samples as --param axes or as a --table, not both")
    if loop is not None:
        return loop_sample_list(args, loop, {name: values[0] for name, values in fixed.items()})
    rows = samples.read_table(args.table) if args.table else samples.grid(_axes(args.param, "--param"))
    rows = [{**row, **{name: values[0] for name, values in fixed.items()}} for row in rows]
    return samples.samples(rows, args.torque)


def _auto_choices(chosen: list, loop: bool) -> list[str]:
    """What model.fidelity = auto picks for the samples that ask for it, as lines to print: each pick,
    how many samples, and why for the first of them (masters/failures.py auto_choice). A loop sample's
    pendulum is read as the loop starts it (loop_samples.pendulum_values)."""
    from ...fmi.interface import scene_from_values
    from ..failures import auto_choice
    from .loop_samples import pendulum_values

    picks: dict[str, list[str]] = {}
    for sample in chosen:
        values = pendulum_values(sample.values) if loop else sample.values
        choice = auto_choice(scene_from_values(values)) if "model.fidelity" in values else None
        if choice is not None:
            picks.setdefault(choice.fidelity, []).append(f"{sample.sample_id}: {choice.reason}")
    return [
        f"model.fidelity = auto picks {picked} for {len(whys)} sample(s) ({whys[0]}{'; ...' if len(whys) > 1 else ''})"
        for picked, whys in picks.items()
    ]


def _plot_figures(args: argparse.Namespace) -> list[str] | None:
    """The figures --plot names, checked (None: the default, chosen once the table is there)."""
    from .plot import FIGURES, LOOP_FIGURES

    allowed = LOOP_FIGURES if args.control else FIGURES
    if args.plot is None:
        return None
    names = [name.strip() for name in args.plot.split(",") if name.strip()]
    wrong = [name for name in names if name not in allowed] or ([] if names else [args.plot])
    if wrong:
        raise UsageError(f"--plot {', '.join(map(repr, wrong))}: choose from {', '.join(allowed)}")
    return names


def _check(args: argparse.Namespace) -> tuple[list, SweepSettings, list[str] | None]:
    """Every check before anything runs: the samples, the shared settings (with the loop of --control),
    the plot's figures."""
    from .driver import SweepSettings, kept_outputs

    figures = _plot_figures(args)
    check_times(args.stop_time, args.step)
    check_fmu(args.fmu)
    if args.workers is not None and args.workers < 1:
        raise UsageError(
            f"--workers {args.workers} is not allowed: it must be a number of worker processes >= 1 (or leave it out)"
        )
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {str(args.out)!r} is a file: give a folder (made if missing)")
    loop = loop_sweep(args)
    settings = SweepSettings(
        fmu=args.fmu,
        out=args.out,
        stop_time=args.stop_time,
        step=args.step,
        outputs=tuple(n for n in args.outputs.split(",") if n),
        workers=args.workers,
        scheduler=args.scheduler,
        csv=args.csv,
        progress=not args.no_progress,
        retry_failed=args.retry_failed,
        loop=loop,
    )
    try:
        kept_outputs(settings)
        chosen = _samples(args, loop)
    except UsageError:
        raise
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    check_output_prefix(args.out / "results", "--out")  # the last check: it makes the output folder
    return chosen, settings, figures


def _plot(args: argparse.Namespace, table: Any, chosen: list, figures: list[str] | None) -> None:
    """The summary plot against the swept parameters (--x, --y, or the first two that vary)."""
    from .plot import FIGURE_UNITS, LOOP_UNITS, summary_plot

    swept = [name for name in table.columns if name in chosen[0].values and table[name].nunique() > 1]
    x = args.x or (swept[0] if swept else None)
    if x is None:
        return
    y = args.y or (swept[1] if len(swept) > 1 and not args.x else None)
    absent = [name for name in (x, y) if name is not None and name not in table.columns]
    if absent:
        raise UsageError(f"--x/--y {', '.join(absent)}: not a parameter of this sweep (the table is written)")
    if figures is None and args.control:  # the default panels that have a value (no step metrics without a step)
        ok = table[table["status"] == "ok"]
        figures = [name for name in DEFAULT_PLOT if ok[name].notna().any()] or [DEFAULT_PLOT[0]]
    units = LOOP_UNITS if args.control else FIGURE_UNITS
    curves = args.control and y is not None and table[y].nunique() <= CURVES_UP_TO
    print(summary_plot(table, figures or "largest_penetration", x, y, args.out / "summary.png", units, curves))


def command(args: argparse.Namespace) -> None:
    _need_extra()
    from .driver import run_sweep

    chosen, settings, figures = _check(args)
    for line in _auto_choices(chosen, settings.loop is not None):
        print(line)
    try:
        table = run_sweep(chosen, settings)
    except ValueError as exc:  # a folder that holds a sweep with other settings
        raise UsageError(str(exc)) from None
    ok = int((table["status"] == "ok").sum())
    print(
        f"{len(table)} samples: {ok} ok, {len(table) - ok} error; wrote {args.out / 'results.parquet'} and "
        f"{args.out / 'series.parquet'}"
    )
    _plot(args, table, chosen, figures)
    for row in table[table["status"] != "ok"].head(10).itertuples():
        print(f"  {row.sample_id}: {row.message}")
    if ok < len(table):
        raise IncompleteRun(
            f"{len(table) - ok} of {len(table)} samples ended in error (their messages above and in "
            f"{args.out / 'results.parquet'}); run again with --retry-failed after changing what they name"
        )
