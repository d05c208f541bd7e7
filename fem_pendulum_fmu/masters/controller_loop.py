"""Controller in the loop: PID controller FMU + torque-limited drive + pendulum FMU, fixed-step master.

    fem-pendulum control [--fmu dist/FemPendulum.fmu] [--pid dist/PidController.fmu]
                         [--stop-time 2] [--step 1e-3] [--set NAME=VALUE ...] [--out out/control]

The set-point is a 20-degree sine at 0.75 Hz,
PID gains Kp 10, Ki 4, Kd 0.15 with output saturation, and a drive that
limits the torque to 15 N.m. The wall stands at theta = 0, so every swing to
negative angles ends on the wall.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..physics.swing import rebounds
from .failures import IncompleteRun, check_fmu, check_output_prefix, check_start_values, check_times, fidelity_choice
from .named_slave import NamedSlave
from .open_loop import parse_start_values
from .run_progress import RunProgress


@dataclass(frozen=True)
class LoopSettings:
    amplitude: float = math.radians(20.0)
    frequency: float = 0.75
    kp: float = 10.0
    ki: float = 4.0
    kd: float = 0.15
    drive_limit: float = 15.0

    def setpoint(self, t: float) -> float:
        return self.amplitude * math.sin(2 * math.pi * self.frequency * t)


def drive(demand: float, limit: float) -> float:
    """The drive delivers the demanded torque up to its limit."""
    return max(-limit, min(limit, demand))


# what happened within each doStep (an impact lasts ~0.3 ms and falls between 1 ms samples), for the plot
STEP_SUMMARIES = ("gap_min", "contact_force_max", "contact_impulse")
OUTPUTS = ("theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work", *STEP_SUMMARIES)


def both_halves(first: list[float], outputs: list[float]) -> list[float]:
    """The outputs after a step taken in two halves, its STEP_SUMMARIES (at the end of `outputs`) made
    those of the whole step: the smaller gap_min, the larger force, the sum of the impulses."""
    n = len(OUTPUTS) - len(STEP_SUMMARIES)
    (gap0, force0, impulse0), (gap1, force1, impulse1) = first, outputs[n:]
    return [*outputs[:n], min(gap0, gap1), max(force0, force1), impulse0 + impulse1]


def run_loop(
    fmu: Path,
    pid: Path,
    stop_time: float = 2.0,
    step: float = 1e-3,
    start_values: dict | None = None,
    settings: LoopSettings = LoopSettings(),
) -> LoopResult:
    """Co-simulate; returns a structured array with time, setpoint, torque and the pendulum outputs,
    up to where the pendulum FMU could not go on if it stopped early."""
    from fmpy.fmi1 import FMICallException

    values = {"theta0": 0.0}
    values.update(start_values or {})
    pendulum = NamedSlave(fmu, "pendulum", values)
    controller = NamedSlave(
        pid, "pid", {"Kp": settings.kp, "Ki": settings.ki, "Kd": settings.kd, "u_max": settings.drive_limit}
    )
    n = int(round(stop_time / step))
    rows = []
    stopped = None
    bar = RunProgress(n)
    try:
        t = 0.0
        outputs = pendulum.get(*OUTPUTS)
        torque = 0.0
        first: list[float] | None = None  # the STEP_SUMMARIES of the first half of a step retried in two halves
        rows.append((t, settings.setpoint(t), torque, *outputs))
        for k in range(n):
            sp = settings.setpoint(t)
            controller.set("setpoint", sp)
            controller.set("measurement", outputs[0])
            controller.fmu.doStep(t, step)
            torque = drive(controller.get("u")[0], settings.drive_limit)
            pendulum.set("torque", torque)
            try:
                pendulum.fmu.doStep(t, step)
            except FMICallException:  # discarded: the state is unchanged, retry in two halves
                try:
                    pendulum.fmu.doStep(t, step / 2)
                    first = pendulum.get(*STEP_SUMMARIES)
                    pendulum.fmu.doStep(t + step / 2, step / 2)
                except FMICallException:
                    said = pendulum.problems[-1] if pendulum.problems else "the FMU gave no message"
                    stopped = f"the pendulum FMU stopped at t = {t:.6g} s of {stop_time:g} s: {said}"
                    break
            t = (k + 1) * step
            outputs = pendulum.get(*OUTPUTS)
            if first is not None:
                outputs, first = both_halves(first, outputs), None
            rows.append((t, sp, torque, *outputs))
            bar.step()
    finally:
        bar.close()
        pendulum.close()
        controller.close()
    dtype = [("time", float), ("setpoint", float), ("torque", float)] + [(o, float) for o in OUTPUTS]
    return LoopResult(np.array(rows, dtype=dtype), stopped)


@dataclass
class LoopResult:
    """The loop's time series, and why it ended before its stop time (None: it ran to the end)."""

    data: np.ndarray
    stopped: str | None = None


def wall_impacts(result: np.ndarray, band: float = 1e-3) -> np.ndarray:
    """Times of the communication steps in which the pendulum rebounded from the wall (physics.swing.rebounds:
    omega turns from towards the wall to away from it within the step, the gap below `band` at one end)."""
    return result["time"][:-1][rebounds(result["omega"], result["gap"], band)]


def tracking_error(result: np.ndarray) -> float:
    """RMS of setpoint - theta over the swings away from the wall (setpoint > 0), in rad."""
    away = result["setpoint"] > 0
    return float(np.sqrt(np.mean((result["setpoint"][away] - result["theta"][away]) ** 2)))


def loop_figure(result: np.ndarray) -> Any:
    """The loop's figure: set-point and angle, torque, gap with gap_min and the rebounds, contact force
    with contact_force_max and contact_impulse per step (every impact, however short: masters/plots.py)."""
    from .plots import _pyplot, impacts, plot_contact_force, plot_contact_impulse, plot_gap

    plt = _pyplot()
    t = result["time"]
    fig, ax = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    ax[0].plot(t, np.degrees(result["setpoint"]), "--", label="set-point")
    ax[0].plot(t, np.degrees(result["theta"]), label="theta")
    ax[0].set_ylabel("angle (deg)")
    ax[0].legend(loc="upper right")
    ax[1].plot(t, result["torque"])
    ax[1].set_ylabel("torque (N.m)")
    plot_gap(ax[2], result)
    rebound = wall_impacts(result)
    ax[2].plot(rebound, np.zeros_like(rebound), "k^", ms=5, label=f"rebound from the wall ({len(rebound)})")
    ax[2].legend(loc="upper right", fontsize="small")
    plot_contact_force(ax[3], result)
    plot_contact_impulse(ax[4], result)
    ax[4].set_xlabel("time (s)")
    fig.suptitle(f"PID controller in the loop with the FE pendulum ({impacts(result)} impacts)")
    fig.tight_layout()
    return fig


def plot_loop(result: np.ndarray, path: Path) -> Path:
    """Write loop_figure to the PNG `path`."""
    from .plots import save_figure

    return save_figure(loop_figure(result), path)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu", help="the pendulum FMU `fem-pendulum build` wrote"
    )
    parser.add_argument(
        "--pid", type=Path, default=Path("dist") / "PidController.fmu", help="the PID controller FMU it wrote beside it"
    )
    parser.add_argument("--stop-time", type=float, default=2.0, help="simulated time (s)")
    parser.add_argument("--step", type=float, default=1e-3, help="communication step of both FMUs (s)")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start value of a pendulum parameter (repeatable; `fem-pendulum interface` lists them)",
    )
    parser.add_argument("--out", type=Path, default=Path("out") / "control", help="prefix of the CSV and PNG written")


def command(args: argparse.Namespace) -> None:
    """Check every argument, run the loop, write the CSV and the plot, and fail with IncompleteRun
    (after writing) when the pendulum FMU stopped before the stop time."""
    check_times(args.stop_time, args.step)
    check_fmu(args.fmu)
    check_fmu(args.pid, "--pid")
    start_values = parse_start_values(args.set)
    choice = fidelity_choice(check_start_values({"theta0": 0.0, **start_values}))
    check_output_prefix(args.out)  # the last check: it makes the output folder
    if choice is not None:
        print(choice)
    loop = run_loop(args.fmu, args.pid, args.stop_time, args.step, start_values)
    result = loop.data
    csv = args.out.with_suffix(".csv")
    names = result.dtype.names or ()
    np.savetxt(csv, result.view((float, len(names))), delimiter=",", header=",".join(names), comments="")
    png = plot_loop(result, args.out.with_suffix(".png"))
    if loop.stopped is not None and "KeyboardInterrupt" in loop.stopped:  # Ctrl-C inside the FMU's Python
        raise KeyboardInterrupt
    if loop.stopped is not None:
        raise IncompleteRun(
            f"{loop.stopped}. Wrote {csv} and {png} up to there. Try a smaller drive limit or a stiffer "
            "material, a finer mesh (model.mesh_size) or a shorter --step"
        )
    print(
        f"wrote {csv} and {png}; RMS tracking error away from the wall "
        f"{math.degrees(tracking_error(result)):.2f} deg, {len(wall_impacts(result))} wall impacts, "
        f"min gap {result['gap'].min() * 1e3:.3f} mm"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    command(parser.parse_args(argv))


if __name__ == "__main__":
    main()
