"""Open-loop master: a torque profile in, a results CSV and a PNG plot out (fmpy).

    fem-pendulum run [--fmu dist/FemPendulum.fmu] [--torque examples/torque_pulse.csv]
                     [--stop-time 2] [--step 1e-3] [--set model.fidelity=fem ...] [--out out/run]
                     [--animate out/run.gif [--deformation-scale 1000]]

The torque CSV has columns time,torque; fmpy interpolates linearly, so a step
needs two rows at the same time. Without --torque the torque is zero.
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .failures import (
    IncompleteRun,
    UsageError,
    check_fmu,
    check_output_prefix,
    check_start_values,
    check_times,
    fidelity_choice,
    finite_cell,
    not_instantiated,
    what_to_try,
)
from .realtime import Pacer
from .run_options import add_run_options
from .run_progress import RunProgress


def read_torque_csv(path: Path) -> np.ndarray:
    """The torque profile of a CSV with the columns time,torque (others are ignored); UsageError naming
    the file, the row and the column of a cell that is not a finite number, or times that go back."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as exc:
        raise UsageError(f"--torque {str(path)!r}: {exc.strerror or exc}") from None
    header = [name.strip() for name in rows[0]] if rows else []
    if "time" not in header or "torque" not in header:
        raise UsageError(f"--torque {str(path)!r}: need the columns time,torque (found {', '.join(header) or 'none'})")
    columns = {name: header.index(name) for name in ("time", "torque")}
    data = []
    for number, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue  # blank lines
        data.append(tuple(_cell(path, row, number, name, k) for name, k in columns.items()))
    if not data:
        raise UsageError(f"--torque {str(path)!r}: no rows below the header")
    times = [t for t, _ in data]
    if any(b < a for a, b in zip(times, times[1:], strict=False)):
        raise UsageError(f"--torque {str(path)!r}: the times must not decrease (a step is two rows at one time)")
    return np.array(data, dtype=[("time", float), ("torque", float)])


def _cell(path: Path, row: list[str], number: int, name: str, k: int) -> float:
    """Cell k of CSV row `number` as a finite number, or UsageError naming where it is."""
    value, text = finite_cell(row, k)
    if value is None:
        raise UsageError(f"--torque {str(path)!r}, row {number}, column {name}: {text!r} is not a finite number")
    return value


def parse_start_values(items: list[str], option: str = "--set") -> dict[str, float | int | bool | str]:
    """NAME=VALUE pairs to start values, each by its declared type (interface.parse_text): an enumeration
    takes its item name (model.fidelity=auto) or number, a Boolean true/false, a String the text as it is
    (output.vtk_folder=out/fields); enumerations are returned by number, as the FMU takes them."""
    from ..fmi import interface

    ifc = interface.load()
    values: dict[str, float | int | bool | str] = {}
    for item in items:
        name, _, text = item.partition("=")
        if not _:
            raise UsageError(f"{option} {item}: expected NAME=VALUE")
        try:
            var = interface.parameter(ifc, name)
            value = interface.parse_text(var, text)
        except ValueError as exc:
            raise UsageError(f"{option} {item}: {exc}") from None
        values[name] = var.item_number(str(value)) if var.items else value
    return values


@dataclass
class RunResult:
    """What `run` recorded (None if nothing), the FMU's Discard and Error messages, and why the run
    ended early: fmpy stops at a Discard the FMU cannot recover from (the data then end there) and
    raises at an fmi2Error (`error`); `interrupted` by Ctrl-C."""

    data: np.ndarray | None
    problems: list[str] = field(default_factory=list)
    error: str | None = None
    interrupted: bool = False

    def end_time(self) -> float:
        return float(self.data["time"][-1]) if self.data is not None and len(self.data) else 0.0


def run(
    fmu: Path,
    torque: np.ndarray | None,
    stop_time: float,
    step: float,
    start_values: dict,
    progress: bool = True,
    pacer: Pacer | None = None,
) -> RunResult:
    """simulate_fmu of `fmu`, recording every output and input, with the FMU's problems kept; paced
    to the wall clock by `pacer` if given."""
    from fmpy import read_model_description, simulate_fmu
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2Discard

    variables = read_model_description(str(fmu)).modelVariables
    recorded = [v.name for v in variables if v.causality in ("output", "input")]  # the torque too, for the plot
    problems: list[str] = []
    recorders: list[Any] = []  # fmpy's recorder, for what it holds when the run ends in an exception

    def logger(environment: object, instance: object, status: int, category: object, message: bytes) -> None:
        if status >= fmi2Discard:
            problems.append(message.decode(errors="replace"))

    def finished(time: float, recorder: Any) -> bool:
        if not recorders:
            recorders.append(recorder)
        if pacer is not None:
            pacer.step_done(time)
        return bar.step()

    bar = RunProgress(round(stop_time / step), enabled=progress)
    try:
        data = simulate_fmu(
            str(fmu),
            stop_time=stop_time,
            step_size=step,
            output_interval=step,
            output=recorded,
            start_values=start_values,
            input=torque,
            step_finished=finished,
            logger=logger,
        )
    except FMICallException as exc:  # an fmi2Error: Ctrl-C inside the FMU's Python arrives as one
        said = "; ".join(problems) or str(exc)
        kept = recorders[0].result() if recorders else None
        return RunResult(kept, problems, said, interrupted="KeyboardInterrupt" in said)
    except KeyboardInterrupt:
        return RunResult(recorders[0].result() if recorders else None, problems, interrupted=True)
    except Exception as exc:
        if str(exc).startswith("Failed to instantiate"):  # fmpy's words; the FMU's log says why
            raise not_instantiated(fmu, problems) from None
        raise
    finally:
        bar.close()
    return RunResult(data, problems)


def incomplete(result: RunResult, stop_time: float, wrote: str) -> IncompleteRun | None:
    """The IncompleteRun of a run that ended in an error or whose data end before the stop time,
    saying where, what the FMU said and what to try; None for a complete run."""
    reached = result.end_time()
    if result.error is None and reached >= stop_time - 1e-9 * max(1.0, stop_time):
        return None
    said = result.error or (result.problems[-1] if result.problems else "the FMU gave no message")
    return IncompleteRun(
        f"the run stopped at t = {reached:.6g} s of {stop_time:g} s: {said}. {wrote}. "
        f"{what_to_try(said, 'a smaller torque')}"
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_run_options(parser)
    parser.add_argument("--torque", type=Path, help="CSV with columns time,torque (N.m); without it the torque is 0")
    parser.add_argument("--out", type=Path, default=Path("out") / "run", help="prefix of the CSV and PNG written")
    parser.add_argument(
        "--animate",
        type=Path,
        metavar="PATH",
        help="also write an animation (.gif; .mp4 with ffmpeg) from the FMU's field output, which goes to "
        "output.vtk_folder (default: the --out prefix + '_fields')",
    )
    parser.add_argument(
        "--realtime",
        action="store_true",
        help="pace the doSteps to the wall clock, as a real-time rig does, and report the steps that overran",
    )
    parser.add_argument(
        "--deformation-scale", type=float, default=1.0, help="magnify the elastic deformation in the animation"
    )


def command(args: argparse.Namespace) -> None:
    """Check every argument, run, write the CSV and the plot of what was recorded, and fail with
    IncompleteRun (after writing) when the FMU stopped before the stop time."""
    from fmpy.util import write_csv

    from .plots import impacts, plot_results

    check_times(args.stop_time, args.step)
    check_fmu(args.fmu)
    torque = read_torque_csv(args.torque) if args.torque else None
    start_values = parse_start_values(args.set)
    choice = fidelity_choice(check_start_values(start_values))
    check_output_prefix(args.out)  # the last check: it makes the output folder
    if choice is not None:
        print(choice)
    if args.animate and not start_values.get("output.vtk_folder"):
        start_values["output.vtk_folder"] = str(args.out.parent / f"{args.out.name}_fields")
    pacer = Pacer() if args.realtime else None
    run_result = run(args.fmu, torque, args.stop_time, args.step, start_values, pacer=pacer)
    result = run_result.data
    csv_path, png = args.out.with_suffix(".csv"), args.out.with_suffix(".png")
    wrote = "Nothing was recorded"
    if result is not None and len(result) > 0:
        write_csv(str(csv_path), result)
        plot_results(result, png, f"{args.fmu.name}: open loop")
        wrote = f"Wrote {csv_path} and {png} up to there"
    if run_result.interrupted:
        raise KeyboardInterrupt
    failure = incomplete(run_result, args.stop_time, wrote)
    if failure is not None:
        raise failure
    assert result is not None
    print(summary(result, f"wrote {csv_path} and {png}", impacts(result)))
    if pacer is not None:
        print(pacer.report())
    if args.animate:
        from ..fmi.vtk_output import INDEX_NAME
        from .animation import animate

        frames = animate(
            Path(str(start_values["output.vtk_folder"])) / INDEX_NAME, args.animate, args.deformation_scale
        )
        print(f"wrote {args.animate}: {frames} frames of the field output in {start_values['output.vtk_folder']}")


def summary(result: np.ndarray, wrote: str, impact_count: int) -> str:
    """The line a complete run prints: what it wrote, impacts, smallest gap, largest force, energy balance."""
    err = result["energy.total"] - result["energy.total"][0] - result["energy.torque_work"]
    names = result.dtype.names or ()
    force = result["contact_force_max" if "contact_force_max" in names else "contact_force"]
    gap = result["gap_min" if "gap_min" in names else "gap"]
    return (
        f"{wrote}; {impact_count} impacts, min gap {gap.min():.3e} m, "
        f"max contact force {force.max():.1f} N, max |E - E0 - W| {np.abs(err).max():.2e} J"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    command(parser.parse_args(argv))


if __name__ == "__main__":
    main()
