"""Cost per simulated second of every fidelity through the FMU, against the seed and against real time.

    python benchmarks/realtime.py [--fmu dist/FemPendulum.fmu] [--repeat 3] [--seed-steps 10] [--runs NAME ...]

Each run is a fresh process that drives FemPendulum.fmu as a master does:
fmpy's FMU2Slave, 1 ms communication steps, every step setReal(torque = 0),
doStep and getReal of every Real output; the clock runs over the stepping loop
only (instantiation and initialisation are timed apart). Runs (--runs picks):

  fem_steel      the default scene (steel, rigid wall, released at 20 degrees), 2 s
  fem_rubber     the rubber preset (E 1 MPa, nu 0.45, rho 1000, k 5e9, order 3), 2 s
  fem_wall       steel against the seed's meshed (deformable) wall block, 0.5 s
  reduced_steel, reduced_rubber, rigid_steel   the other fidelities, 2 s
  fem_mesh_0.01, fem_mesh_0.005   fem steel on finer meshes (model.mesh_size), 0.5 s
  floor          benchmarks/rigid_floor.py's trivial Python FMU with the same variables, 2 s

Printed per run: CPU seconds (time.process_time of the run's process) and wall
seconds per simulated second (median of --repeat runs, with the spread), the
ratio to the seed baseline (../shared/baseline/seed_pendulum.py, --seed-steps
1 ms steps, when that file is there) timed before the first run and after each
one, each run against the mean of the seed's timings just before and after it
(this VM's slow spells last minutes: a seed timed once put the ratios of runs
minutes away 30 % off), and the
accuracy: max |theta - theta_ref| before the reference's second impact against
benchmarks/references (the L2 runs of benchmarks/speed_vs_error.py) and the
energy error max |E_total - E_0 - W_torque| over the swing energy. A second
table gives the latency of each doStep alone (perf_counter around the call):
median, 99th and 99.9th percentile, maximum and when, the tail over the median
(what a real-time rig waits for), and the share of doSteps over 1 ms. Run it on
a quiet machine: the load average is printed before and after.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

# fem_speed (the seed's timing), rigid_floor (the trivial FMU) and speed_vs_error (the references) are imported
# where they are used: they import fem_pendulum_fmu, and a child process that had imported it would run the
# FMU with that copy, not the FMU's own (its preflight now refuses a copy that differs: fmi/preflight.py)

RUBBER = {"pendulum.E": 1e6, "pendulum.nu": 0.45, "pendulum.rho": 1000.0, "contact.stiffness": 5e9}
ORDER3 = {"model.order": 3}
FIDELITY = {"rigid": 2, "reduced": 3, "fem": 4}
# name: (fidelity, Real parameters, Integer parameters, simulated seconds, reference)
RUNS = {
    "fem_steel": ("fem", {}, {}, 2.0, "steel"),
    "fem_rubber": ("fem", RUBBER, ORDER3, 2.0, "rubber"),
    "fem_wall": ("fem", {}, {"wall.kind": 2}, 0.5, "deformable_wall"),
    "reduced_steel": ("reduced", {}, {}, 2.0, "steel"),
    "reduced_rubber": ("reduced", RUBBER, ORDER3, 2.0, "rubber"),
    "rigid_steel": ("rigid", {}, {}, 2.0, "steel"),
    "fem_mesh_0.01": ("fem", {"model.mesh_size": 0.01}, {}, 0.5, None),
    "fem_mesh_0.005": ("fem", {"model.mesh_size": 0.005}, {}, 0.5, None),
}


def child(fmu: str, spec: dict) -> dict:
    """One timed run in this process (called through --child): outputs and CPU and wall time."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    t0 = time.perf_counter()
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    reals = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=extract(fmu),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="realtime",
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    reals_in, ints = spec["reals"], dict(spec["integers"])
    if spec["fidelity"]:
        ints["model.fidelity"] = FIDELITY[spec["fidelity"]]
    if reals_in:
        slave.setReal([vr[k] for k in reals_in], list(reals_in.values()))
    if ints:
        slave.setInteger([vr[k] for k in ints], [int(v) for v in ints.values()])
    slave.exitInitializationMode()
    startup = time.perf_counter() - t0
    out_vrs = [v.valueReference for v in reals]
    names = [v.name for v in reals]
    n = round(spec["t_end"] / 1e-3)
    rows = np.empty((n + 1, len(out_vrs)))
    rows[0] = slave.getReal(out_vrs)
    torque = [vr["torque"]]
    latency = np.empty(n)  # wall time of each doStep alone (s)
    clock = time.perf_counter
    c0, w0 = time.process_time(), clock()
    for k in range(n):
        slave.setReal(torque, [0.0])
        s0 = clock()
        slave.doStep(k * 1e-3, 1e-3)
        latency[k] = clock() - s0
        rows[k + 1] = slave.getReal(out_vrs)
    cpu, wall = time.process_time() - c0, clock() - w0
    slave.terminate()
    slave.freeInstance()
    kept = ("theta", "energy.total", "energy.torque_work")
    series = {name: rows[:, i].tolist() for i, name in enumerate(names) if name in kept}
    return {
        "cpu": cpu / spec["t_end"],
        "wall": wall / spec["t_end"],
        "startup": startup,
        "series": series,
        "latency": latency_figures(latency),
    }


def latency_figures(latency: np.ndarray) -> dict[str, float]:
    """The doStep latency distribution: median, 99th and 99.9th percentile and maximum (s), the time
    of the slowest (s) and the share of doSteps over 1 ms, the communication step."""
    return {
        "median": float(np.median(latency)),
        "p99": float(np.percentile(latency, 99.0)),
        "p999": float(np.percentile(latency, 99.9)),
        "max": float(latency.max()),
        "max_at": float((int(np.argmax(latency)) + 1) * 1e-3),
        "over_1ms": float(np.mean(latency > 1e-3)),
    }


def _median_of(figures: list[dict[str, float]], key: str) -> float:
    return statistics.median(x[key] for x in figures)


def print_latency(results: dict) -> None:
    """The table of doStep latencies: per run the median over the repeats of each figure, and the
    spread of the tail ratios (99.9th percentile and maximum over the median) across the repeats."""
    print(
        "\n| run | doStep median ms | 99th ms | 99.9th ms | max ms (at t s) | 99.9th / median (spread) "
        "| max / median (spread) | share over 1 ms |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, (runs, _, _, _) in results.items():
        lat = [r["latency"] for r in runs]
        med = functools.partial(_median_of, lat)
        tail = [x["p999"] / x["median"] for x in lat]
        top = [x["max"] / x["median"] for x in lat]
        print(
            f"| {name} | {med('median') * 1e3:.3f} | {med('p99') * 1e3:.2f} | {med('p999') * 1e3:.2f} "
            f"| {med('max') * 1e3:.2f} ({lat[0]['max_at']:.3f}) | {statistics.median(tail):.1f} "
            f"({min(tail):.1f}-{max(tail):.1f}) | {statistics.median(top):.1f} ({min(top):.1f}-{max(top):.1f}) "
            f"| {med('over_1ms') * 100:.1f} % |"
        )


def run_once(fmu: Path, spec: dict) -> dict:
    out = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--child", str(fmu), json.dumps(spec)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def accuracy(series: dict, reference: str | None) -> tuple[float, float]:
    """(max |theta - theta_ref| before the reference's second impact, energy error / swing energy)."""
    from speed_vs_error import early_window, load_reference

    from fem_pendulum_fmu.physics.mass_properties import swing_energy
    from fem_pendulum_fmu.physics.scene import steel

    if not series:
        return float("nan"), float("nan")
    total = np.array(series["energy.total"]) - np.array(series["energy.torque_work"])
    scene = steel(**(RUBBER if reference == "rubber" else {}))
    energy = float(np.max(np.abs(total - total[0]))) / swing_energy(scene)
    ref = load_reference(reference) if reference else None
    if ref is None:
        return float("nan"), energy
    theta = np.array(series["theta"])
    n = min(len(theta), early_window(ref))
    return float(np.max(np.abs(theta[:n] - ref["theta"][:n]))), energy


def seed_per_sim_s(steps: int) -> float | None:
    """The seed baseline's wall seconds per simulated second, timed now (None: not timed or not there)."""
    import fem_speed

    cost = fem_speed.seed_cost_per_step(steps) if steps else None
    return None if cost is None else cost * 1000.0


def run_all(names: list[str], fmu: Path, repeat: int, seed_steps: int) -> tuple[dict, list[float | None]]:
    """Each named run `repeat` times, the seed timed before the first and after each: per name (runs, theta
    error, energy error, the mean of the seed's timings around it), and the seed's timings."""
    seeds = [seed_per_sim_s(seed_steps)]
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        import rigid_floor

        floor = rigid_floor.build_floor(Path(tmp)) if "floor" in names else None
        for name in names:
            if name == "floor":
                path, spec = floor, {"fidelity": None, "reals": {}, "integers": {}, "t_end": 2.0, "reference": None}
            else:
                fidelity, reals, integers, t_end, reference = RUNS[name]
                path = fmu
                spec = {
                    "fidelity": fidelity,
                    "reals": reals,
                    "integers": integers,
                    "t_end": t_end,
                    "reference": reference,
                }
            runs = [run_once(path, spec) for _ in range(repeat)]
            seeds.append(seed_per_sim_s(seed_steps))
            around = None if None in seeds[-2:] else (seeds[-2] + seeds[-1]) / 2.0
            results[name] = (runs, *accuracy(runs[0]["series"], spec["reference"]), around)
            print(name, [round(r["cpu"], 4) for r in runs], flush=True)
    return results, seeds


def print_costs(results: dict) -> None:
    """The table of cost per simulated second, against the seed, start-up and accuracy."""
    print(
        "\n| run | CPU s per simulated s (median, spread) | wall s per simulated s | x the seed (wall) | start-up s "
        "| max theta error before the 2nd impact (rad) | energy error / swing |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, (runs, dtheta, energy, seed) in results.items():
        cpu = [r["cpu"] for r in runs]
        wall = statistics.median(r["wall"] for r in runs)
        ratio = f"{seed / wall:.0f}" if seed else "-"
        print(
            f"| {name} | {statistics.median(cpu):.3f} ({min(cpu):.3f}-{max(cpu):.3f}) | {wall:.3f} | {ratio} "
            f"| {statistics.median(r['startup'] for r in runs):.2f} | {dtheta:.2e} | {energy:.1e} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed-steps", type=int, default=10, help="1 ms steps of the seed baseline to time (0: skip)")
    parser.add_argument("--runs", nargs="*", default=[*RUNS, "floor"], choices=[*RUNS, "floor"])
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child[0], json.loads(args.child[1]))))
        return
    load_before = os.getloadavg()
    results, seeds = run_all(args.runs, args.fmu, args.repeat, args.seed_steps)
    load_after = os.getloadavg()
    timed = ", ".join(f"{s:.0f}" for s in seeds if s is not None)
    said = f"{timed} s per simulated s ({args.seed_steps} steps of 1 ms before the first run and after each)"
    print(
        f"\nload average before {load_before[0]:.2f}, after {load_after[0]:.2f}; seed: "
        + (said if None not in seeds else "not timed")
    )
    print_costs(results)
    print_latency(results)


if __name__ == "__main__":
    main()
