"""The coupling error of co-simulation: what first- and second-order hold buy over zero-order hold.

    python benchmarks/coupling.py [--dist dist] [--stop-time 2] [--fidelity rigid] [--plot PNG] [--quick]
                                  [--steps 1 2 5 ...] [--reference-step 0.05]

Two couplings of FemPendulum.fmu (and PidController.fmu from the same folder, as `fem-pendulum
build` writes them), each run with fmpy's FMU2Slave by this script's own fixed-step master:

  pid_loop  the loop of `fem-pendulum control`: a 20-degree sine set-point at 0.75 Hz, the PID
            (Kp 10, Ki 4, Kd 0.15, u_max 15) and a drive limited to 15 N.m, released at theta0 = 0
            beside the wall; in the order of masters/controller_loop.py's run_loop: at each
            communication point the controller's doStep, then the pendulum's with its torque;
  sine      an open-loop torque 0.8 sin(2 pi 2 t) N.m on the pendulum released at 20 degrees.

each at communication steps of 1, 2, 5, 10 and 20 ms, with zero-order hold (each input held over the
step: the FMI default), first-order hold (each input also given its first time derivative: the
pendulum's theta' and the PID's u' from their output derivatives, the set-point's and the sine's
analytically) and second-order hold (first and second derivatives), through
fem_pendulum_fmu/masters/coupling.py. The reference of each coupling is the same loop at 0.05 ms
steps with second-order hold. Printed per run: the error in theta at the communication points
(RMS and max, degrees) and in the torque the pendulum received over time (RMS of the torque
polynomial it was given against the reference's, sampled at the reference's steps, N.m), the
wall-clock and CPU seconds of the run's stepping loop, and which hold at which step is as accurate
as zero-order hold at a smaller step. The times are to be measured on a quiet machine: the
load average is printed before and after. --quick (the test in tests/test_coupling_benchmark.py):
0.2 s, steps of 2 and 10 ms, reference 0.2 ms.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem_pendulum_fmu.masters.coupling import HOLD_ORDERS, limited, output_rates, set_input_rates, taylor_rates
from fem_pendulum_fmu.masters.named_slave import NamedSlave

STEPS = (1e-3, 2e-3, 5e-3, 10e-3, 20e-3)
REFERENCE_STEP = 5e-5
QUICK = {"stop_time": 0.2, "steps": (2e-3, 10e-3), "reference": 2e-4}
FIDELITY_INDEX = {"auto": 1, "rigid": 2, "reduced": 3, "fem": 4}
# the loop of `fem-pendulum control` (masters/controller_loop.py's LoopSettings and PID gains)
AMPLITUDE, FREQUENCY, GAINS, DRIVE_LIMIT = math.radians(20.0), 0.75, (10.0, 4.0, 0.15), 15.0
SINE_AMPLITUDE, SINE_FREQUENCY = 0.8, 2.0  # N.m, Hz


def sine(amplitude: float, frequency: float, t: float) -> list[float]:
    """A sin(w t) and its first two time derivatives."""
    w = 2.0 * math.pi * frequency
    s, c = math.sin(w * t), math.cos(w * t)
    return [amplitude * s, amplitude * w * c, -amplitude * w * w * s]


@dataclass
class Run:
    """One coupled run: theta at the communication points, the torque polynomial of each step
    (value, rates) and the stepping loop's wall and CPU seconds."""

    step: float
    order: int
    theta: np.ndarray
    torque: list[tuple[float, list[float]]]
    wall: float
    cpu: float
    gap_min: np.ndarray  # the smallest gap within each step (m)

    def first_contact(self) -> float:
        """The start of the first step in which the head pressed into the wall by more than 1 nm (inf: none;
        the PID loop starts touching it, at gap 0)."""
        touched = np.flatnonzero(self.gap_min < -1e-9)
        return float(touched[0] * self.step) if touched.size else math.inf

    def torque_at(self, times: np.ndarray) -> np.ndarray:
        """The torque the pendulum was given at `times` (each within the step it falls in)."""
        k = np.minimum((times / self.step + 1e-9).astype(int), len(self.torque) - 1)
        s = times - k * self.step
        values = np.array([v for v, _ in self.torque])[k]
        rates = np.array([(r + [0.0, 0.0])[:2] for _, r in self.torque])[k]
        return values + rates[:, 0] * s + 0.5 * rates[:, 1] * s * s


def pendulum(dist: Path, fidelity: str, theta0: float) -> NamedSlave:
    return NamedSlave(
        dist / "FemPendulum.fmu", "pendulum", {"theta0": theta0, "model.fidelity": FIDELITY_INDEX[fidelity]}
    )


def pid_loop(dist: Path, fidelity: str, step: float, order: int, stop_time: float) -> Run:
    """The PID loop at one communication step and hold order (the module's docstring)."""
    plant = pendulum(dist, fidelity, 0.0)
    pid = NamedSlave(dist / "PidController.fmu", "pid", dict(zip(("Kp", "Ki", "Kd"), GAINS, strict=True)))
    theta_vr, torque_vr = plant.vr["theta"], plant.vr["torque"]
    inputs, u_vr = [pid.vr["setpoint"], pid.vr["measurement"]], pid.vr["u"]
    n = int(round(stop_time / step))
    theta, torques, gaps = [plant.get("theta")[0]], [], []
    wall, cpu = time.perf_counter(), time.process_time()
    for k in range(n):
        t = k * step
        setpoint = sine(AMPLITUDE, FREQUENCY, t)
        pid.fmu.setReal(inputs, [setpoint[0], theta[-1]])
        measured = output_rates(plant.fmu, [theta_vr], order)[0]
        set_input_rates(pid.fmu, inputs, [taylor_rates(setpoint[1:], order), measured])
        pid.fmu.doStep(t, step)
        torque, rates = limited(pid.get("u")[0], output_rates(pid.fmu, [u_vr], order)[0], DRIVE_LIMIT, step)
        plant.fmu.setReal([torque_vr], [torque])
        set_input_rates(plant.fmu, [torque_vr], [rates])
        plant.fmu.doStep(t, step)
        theta_now, gap = plant.get("theta", "gap_min")
        theta.append(theta_now)
        gaps.append(gap)
        torques.append((torque, rates))
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    plant.close()
    pid.close()
    return Run(step, order, np.array(theta), torques, wall, cpu, np.array(gaps))


def sine_run(dist: Path, fidelity: str, step: float, order: int, stop_time: float) -> Run:
    """The open-loop sine torque at one communication step and hold order."""
    plant = pendulum(dist, fidelity, math.radians(20.0))
    torque_vr = plant.vr["torque"]
    n = int(round(stop_time / step))
    theta, torques, gaps = [plant.get("theta")[0]], [], []
    wall, cpu = time.perf_counter(), time.process_time()
    for k in range(n):
        t = k * step
        torque = sine(SINE_AMPLITUDE, SINE_FREQUENCY, t)
        rates = taylor_rates(torque[1:], order)
        plant.fmu.setReal([torque_vr], [torque[0]])
        set_input_rates(plant.fmu, [torque_vr], [rates])
        plant.fmu.doStep(t, step)
        theta_now, gap = plant.get("theta", "gap_min")
        theta.append(theta_now)
        gaps.append(gap)
        torques.append((torque[0], rates))
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    plant.close()
    return Run(step, order, np.array(theta), torques, wall, cpu, np.array(gaps))


COUPLINGS = {"pid_loop": pid_loop, "sine": sine_run}


@dataclass
class Error:
    before_rms: float  # deg, theta before the reference's first contact with the wall
    theta_rms: float  # deg, over the whole run
    theta_max: float  # deg
    torque_rms: float  # N.m


def error(run: Run, reference: Run) -> Error:
    """run against the reference: theta at run's communication points (before the reference's first
    contact and over the whole run), the torque over time."""
    ratio = int(round(run.step / reference.step))
    d_theta = np.degrees(run.theta - reference.theta[::ratio][: len(run.theta)])
    before = d_theta[np.arange(len(d_theta)) * run.step < reference.first_contact()]
    times = np.arange(len(reference.torque)) * reference.step
    d_torque = run.torque_at(times) - reference.torque_at(times)
    return Error(
        float(np.sqrt(np.mean(before**2))),
        float(np.sqrt(np.mean(d_theta**2))),
        float(np.max(np.abs(d_theta))),
        float(np.sqrt(np.mean(d_torque**2))),
    )


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def study(dist: Path, fidelity: str, stop_time: float, steps: tuple, reference_step: float) -> dict:
    """Every coupling at every step and hold order: {coupling: [(run, error), ...]}, printed as they come."""
    found: dict[str, list[tuple[Run, Error]]] = {}
    for name, couple in COUPLINGS.items():
        reference = couple(dist, fidelity, reference_step, 2, stop_time)
        contact = reference.first_contact()
        print(
            f"\n{name}: reference {reference_step * 1e3:g} ms, second-order hold, first contact at {contact:.4g} s, "
            f"{reference.wall:.2f} s wall"
        )
        print(
            "| hold | step (ms) | theta RMS before contact (deg) | theta RMS (deg) | theta max (deg) | "
            "torque RMS (N.m) | wall (s) | CPU (s) |"
        )
        print("|---|---|---|---|---|---|---|---|")
        rows = found[name] = []
        for order in HOLD_ORDERS:
            for step in steps:
                run = couple(dist, fidelity, step, order, stop_time)
                e = error(run, reference)
                rows.append((run, e))
                print(
                    f"| {order} | {step * 1e3:g} | {e.before_rms:.3g} | {e.theta_rms:.3g} | {e.theta_max:.3g} | "
                    f"{e.torque_rms:.3g} | {run.wall:.3f} | {run.cpu:.3f} |",
                    flush=True,
                )
    return found


def as_accurate(rows: list[tuple[Run, Error]]) -> list[str]:
    """For each higher-order hold and step: the largest step at which zero-order hold is at least as
    accurate in theta (RMS before the first contact: after it, the impacts' timing decides), and how
    many doSteps fewer the higher order then takes."""
    zero = sorted(((r.step, e.before_rms) for r, e in rows if r.order == 0), reverse=True)
    lines = []
    for run, e in rows:
        if run.order == 0:
            continue
        match = next((step for step, rms in zero if rms <= e.before_rms), None)
        if match is None:
            lines.append(f"hold {run.order} at {run.step * 1e3:g} ms: more accurate than zero-order hold at any step")
        elif match < run.step:
            lines.append(
                f"hold {run.order} at {run.step * 1e3:g} ms: zero-order hold needs {match * 1e3:g} ms or less to be as "
                f"accurate, {run.step / match:.3g} times the doSteps"
            )
    return lines


def plot(found: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(found), figsize=(5 * len(found), 4))
    for ax, (name, rows) in zip(np.atleast_1d(axes), found.items(), strict=True):
        for order, color in zip(HOLD_ORDERS, ("C0", "C1", "C2"), strict=True):
            steps = [r.step * 1e3 for r, e in rows if r.order == order]
            before = [e.before_rms for r, e in rows if r.order == order]
            whole = [e.theta_rms for r, e in rows if r.order == order]
            ax.loglog(steps, before, "o-", color=color, label=f"hold order {order}, before the first contact")
            ax.loglog(steps, whole, "x--", color=color, alpha=0.6, label=f"hold order {order}, whole run")
        ax.set_xlabel("communication step (ms)")
        ax.set_ylabel("theta error, RMS (deg)")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="x-small")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--dist", type=Path, default=Path("dist"), help="folder with FemPendulum.fmu, PidController.fmu"
    )
    parser.add_argument("--stop-time", type=float, default=2.0)
    parser.add_argument("--fidelity", choices=tuple(FIDELITY_INDEX), default="rigid")
    parser.add_argument("--plot", type=Path, help="write the error against the step here (PNG)")
    parser.add_argument("--quick", action="store_true", help="0.2 s, 2 and 10 ms, reference 0.2 ms")
    parser.add_argument("--steps", type=float, nargs="+", help="communication steps in ms (default 1 2 5 10 20)")
    parser.add_argument("--reference-step", type=float, help="the reference's step in ms (default 0.05)")
    args = parser.parse_args(argv)
    for name in ("FemPendulum.fmu", "PidController.fmu"):
        if not (args.dist / name).is_file():
            sys.exit(f"--dist {args.dist}: no {name} there (build them with `fem-pendulum build`)")
    stop, steps, reference = (
        (QUICK["stop_time"], QUICK["steps"], QUICK["reference"])
        if args.quick
        else (args.stop_time, STEPS, REFERENCE_STEP)
    )
    steps = tuple(x * 1e-3 for x in args.steps) if args.steps else steps
    reference = args.reference_step * 1e-3 if args.reference_step else reference
    print(f"fidelity {args.fidelity}, {stop:g} s; load average before: {load()}")
    found = study(args.dist, args.fidelity, float(stop), tuple(steps), float(reference))
    for name, rows in found.items():
        print(f"\n{name}:")
        for line in as_accurate(rows):
            print(f"  {line}")
    print(f"\nload average after: {load()} (wall and CPU times: measure on a quiet machine)")
    if args.plot:
        plot(found, args.plot)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
