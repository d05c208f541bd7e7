"""`fem-pendulum sweep`: a grid or a table of parameter values through the FMU on Dask.

    fem-pendulum sweep --param pendulum.E=1e6,1e7,2.1e11 --param theta0=0.2,0.35 \\
        --set model.fidelity=rigid --stop-time 1 --out out/sweep [--workers 2 | --scheduler tcp://HOST:8786]

Writes OUT/results.parquet (one row a sample), OUT/series.parquet (the time
series, keyed by sample_id), OUT/summary.png, and OUT/results.csv with --csv.
Started again with the same OUT, it runs only the samples OUT does not hold.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

from ..failures import IncompleteRun, UsageError, check_fmu, check_output_prefix, check_times
from ..run_options import DEFAULT_FMU

EXTRA = ("dask", "distributed", "pandas", "pyarrow")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU, help="the FMU `fem-pendulum build` wrote")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=V1,V2,...",
        help="a grid axis: the samples are the product of all axes (enumerations by item name)",
    )
    parser.add_argument(
        "--set", action="append", default=[], metavar="NAME=VALUE", help="a parameter value every sample shares"
    )
    parser.add_argument("--table", type=Path, help="CSV, one row a sample, columns parameter names (and torque)")
    parser.add_argument("--torque", type=Path, help="CSV time,torque for every sample (a table's torque column wins)")
    parser.add_argument("--stop-time", type=float, default=2.0, help="simulated time of every sample (s)")
    parser.add_argument("--step", type=float, default=1e-3, help="communication step = output interval (s)")
    parser.add_argument("--outputs", default="", metavar="NAME,...", help="outputs kept in the series (default all)")
    parser.add_argument("--workers", type=int, help="local cluster of N >= 1 worker processes (default: one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786")
    parser.add_argument("--out", type=Path, default=Path("out") / "sweep", help="output folder (resumed if it exists)")
    parser.add_argument("--csv", action="store_true", help="also write results.csv")
    parser.add_argument("--retry-failed", action="store_true", help="run again the samples that ended in error")
    parser.add_argument("--plot", default="largest_penetration", metavar="FIGURE", help="figure of the summary plot")
    parser.add_argument("--x", help="parameter on the plot's x axis (default: the first --param)")
    parser.add_argument("--y", help="a second parameter, shown as the y axis (figure as colour)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


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
            axes.append(samples.parse_param(item))
        except ValueError as exc:
            problems.append(f"{option} {item}: {exc}")
    if problems:
        raise UsageError("; ".join(problems))
    return axes


def _samples(args: argparse.Namespace) -> list:
    from . import samples

    fixed = dict(_axes(args.set, "--set"))
    if any(len(values) != 1 for values in fixed.values()):
        raise UsageError("--set takes one value: NAME=VALUE (a list is a grid axis: --param)")
    if args.table and args.param:
        raise UsageError("give the samples as --param axes or as a --table, not both")
    rows = samples.read_table(args.table) if args.table else samples.grid(_axes(args.param, "--param"))
    rows = [{**row, **{name: values[0] for name, values in fixed.items()}} for row in rows]
    return samples.samples(rows, args.torque)


def _auto_choices(chosen: list) -> list[str]:
    """What model.fidelity = auto picks for the samples that ask for it, as lines to print: each pick,
    how many samples, and why for the first of them (masters/failures.py auto_choice)."""
    from ...fmi.interface import scene_from_values
    from ..failures import auto_choice

    picks: dict[str, list[str]] = {}
    for sample in chosen:
        choice = auto_choice(scene_from_values(sample.values)) if "model.fidelity" in sample.values else None
        if choice is not None:
            picks.setdefault(choice.fidelity, []).append(f"{sample.sample_id}: {choice.reason}")
    return [
        f"model.fidelity = auto picks {picked} for {len(whys)} sample(s) ({whys[0]}{'; ...' if len(whys) > 1 else ''})"
        for picked, whys in picks.items()
    ]


def command(args: argparse.Namespace) -> None:
    _need_extra()
    from .driver import SweepSettings, run_sweep
    from .plot import FIGURES, summary_plot

    if args.plot not in FIGURES:
        raise UsageError(f"--plot {args.plot!r}: choose one of {', '.join(FIGURES)}")
    check_times(args.stop_time, args.step)
    check_fmu(args.fmu)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers {args.workers}: give a number of worker processes >= 1 (or leave it out)")
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {str(args.out)!r} is a file: give a folder (made if missing)")
    try:
        chosen = _samples(args)
    except UsageError:
        raise
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    check_output_prefix(args.out / "results", "--out")  # the last check: it makes the output folder
    for line in _auto_choices(chosen):
        print(line)
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
    )
    try:
        table = run_sweep(chosen, settings)
    except ValueError as exc:  # a folder that holds a sweep with other settings
        raise UsageError(str(exc)) from None
    ok = int((table["status"] == "ok").sum())
    print(
        f"{len(table)} samples: {ok} ok, {len(table) - ok} error; wrote {args.out / 'results.parquet'} and "
        f"{args.out / 'series.parquet'}"
    )
    swept = [name for name in table.columns if name in chosen[0].values and table[name].nunique() > 1]
    x = args.x or (swept[0] if swept else None)
    if x is not None:
        y = args.y or (swept[1] if len(swept) > 1 and not args.x else None)
        absent = [name for name in (x, y) if name is not None and name not in table.columns]
        if absent:
            raise UsageError(f"--x/--y {', '.join(absent)}: not a parameter of this sweep (the table is written)")
        print(summary_plot(table, args.plot, x, y, args.out / "summary.png"))
    for row in table[table["status"] != "ok"].head(10).itertuples():
        print(f"  {row.sample_id}: {row.message}")
    if ok < len(table):
        raise IncompleteRun(
            f"{len(table) - ok} of {len(table)} samples ended in error (their messages above and in "
            f"{args.out / 'results.parquet'}); run again with --retry-failed after changing what they name"
        )
