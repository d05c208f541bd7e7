"""Open-loop master: a torque profile in, a results CSV and a PNG plot out (fmpy).

    fem-pendulum run [--fmu dist/FemPendulum.fmu] [--torque examples/torque_pulse.csv]
                     [--stop-time 2] [--step 1e-3] [--set model.fidelity=fem ...] [--out out/run]
                     [--animate out/run.gif [--deformation-scale 1000]]

The torque CSV has columns time,torque; fmpy interpolates linearly, so a step
needs two rows at the same time. Without --torque the torque is zero.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

DEFAULT_FMU = Path("dist") / "FemPendulum.fmu"


def read_torque_csv(path: Path) -> np.ndarray:
    data = np.genfromtxt(path, delimiter=",", names=True)
    names = data.dtype.names or ()
    if "time" not in names or "torque" not in names:
        raise SystemExit(f"{path}: need the columns time,torque (found {data.dtype.names})")
    return np.array(list(zip(data["time"], data["torque"], strict=True)), dtype=[("time", float), ("torque", float)])


def parse_start_values(items: list[str]) -> dict[str, float | int | bool | str]:
    """NAME=VALUE pairs to start values; an enumeration takes its item name (model.fidelity=auto)
    or number, a Boolean true/false, a String the text as it is (output.vtk_folder=out/fields)."""
    from ..fmi import interface

    ifc = interface.load()
    values: dict[str, float | int | bool | str] = {}
    for item in items:
        name, _, text = item.partition("=")
        if not _:
            raise SystemExit(f"--set {item!r}: expected NAME=VALUE")
        try:
            var = ifc.by_name(name)
        except KeyError:
            raise SystemExit(f"--set {item!r}: {name} is not a variable of the FMU (see the README's table)") from None
        if var.items and text in var.items:
            values[name] = var.item_number(text)
        elif var.type == "Boolean" and text.lower() in ("true", "false"):
            values[name] = text.lower() == "true"
        elif var.type == "String":
            values[name] = text
        else:
            try:
                values[name] = float(text) if any(c in text for c in ".eE") else int(text)
            except ValueError:
                allowed = f"one of {', '.join(var.items)} or their numbers" if var.items else f"a {var.type} number"
                raise SystemExit(f"--set {item!r}: {text!r} is not allowed for {name}: use {allowed}") from None
    return values


def run(
    fmu: Path, torque: np.ndarray | None, stop_time: float, step: float, start_values: dict, progress: bool = True
) -> np.ndarray:
    from fmpy import read_model_description, simulate_fmu

    variables = read_model_description(str(fmu)).modelVariables
    recorded = [v.name for v in variables if v.causality in ("output", "input")]  # the torque too, for the plot
    callback = None
    bar = None
    if progress and stop_time / step > 2000:
        from tqdm import tqdm

        bar = tqdm(total=round(stop_time / step), unit="step", desc="simulating")

        def callback(time: float, recorder: object) -> bool:
            bar.update(1)
            return True

    try:
        return simulate_fmu(
            str(fmu),
            stop_time=stop_time,
            step_size=step,
            output_interval=step,
            output=recorded,
            start_values=start_values,
            input=torque,
            step_finished=callback,
        )
    finally:
        if bar is not None:
            bar.close()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fmu", type=Path, default=DEFAULT_FMU)
    parser.add_argument("--torque", type=Path, help="CSV with columns time,torque")
    parser.add_argument("--stop-time", type=float, default=2.0)
    parser.add_argument("--step", type=float, default=1e-3, help="communication step (s)")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="start value of a parameter")
    parser.add_argument("--out", type=Path, default=Path("out") / "run", help="prefix of the CSV and PNG written")
    parser.add_argument(
        "--animate",
        type=Path,
        metavar="PATH",
        help="also write an animation (.gif; .mp4 with ffmpeg) from the FMU's field output, which goes to "
        "output.vtk_folder (default: the --out prefix + '_fields')",
    )
    parser.add_argument(
        "--deformation-scale", type=float, default=1.0, help="magnify the elastic deformation in the animation"
    )


def command(args: argparse.Namespace) -> None:
    from fmpy.util import write_csv

    from .plots import impacts, plot_results

    torque = read_torque_csv(args.torque) if args.torque else None
    start_values = parse_start_values(args.set)
    if args.animate and not start_values.get("output.vtk_folder"):
        start_values["output.vtk_folder"] = str(args.out.parent / f"{args.out.name}_fields")
    result = run(args.fmu, torque, args.stop_time, args.step, start_values)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    csv = args.out.with_suffix(".csv")
    write_csv(str(csv), result)
    png = plot_results(result, args.out.with_suffix(".png"), f"{args.fmu.name}: open loop")
    err = result["energy.total"] - result["energy.total"][0] - result["energy.torque_work"]
    names = result.dtype.names or ()
    force = result["contact_force_max" if "contact_force_max" in names else "contact_force"]
    gap = result["gap_min" if "gap_min" in names else "gap"]
    print(
        f"wrote {csv} and {png}; {impacts(result)} impacts, min gap {gap.min():.3e} m, "
        f"max contact force {force.max():.1f} N, max |E - E0 - W| {np.abs(err).max():.2e} J"
    )
    if args.animate:
        from ..fmi.vtk_output import INDEX_NAME
        from .animation import animate

        frames = animate(
            Path(str(start_values["output.vtk_folder"])) / INDEX_NAME, args.animate, args.deformation_scale
        )
        print(f"wrote {args.animate}: {frames} frames of the field output in {start_values['output.vtk_folder']}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    command(parser.parse_args(argv))


if __name__ == "__main__":
    main()
