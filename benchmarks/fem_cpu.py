"""CPU time per simulated second of the default fem fidelity on the steel scene, 1 ms communication steps.

    python benchmarks/fem_cpu.py [--t-end 1.0] [--repeat 3] [--preset steel|rubber] [--deformable-wall]
                                 [--mesh-size H] [--profile N [--impacts]]

The steel scene (steel(): rigid wall, released at 20 degrees, no torque; or the
rubber one, rubber(), order 3; --deformable-wall: the seed's meshed wall
block instead of the rigid one) on the default mesh (or that of --mesh-size, model.mesh_size),
advanced in 1 ms communication steps as an FMU master drives it
(outputs computed at every step), timed with time.process_time (CPU time of
this process, less disturbed than wall time by other jobs on a shared
machine); prints the best of `repeat` runs, the wall time of that run, the
load average, the internal steps, the wall times of every run's impact doSteps
(those of more than two internal steps), the solver's counts (Newton iterations,
Jacobians assembled, refactorisations for a new step size, factorisations
left to SuperLU: measures of cost that load does not disturb), and the
accuracy figures (theta at the end,
the largest energy error over the swing energy) so that a faster run can be
checked to be the same run. With --profile N it runs once under cProfile and
prints the N entries with the most internal time (the profile of docs/notes/fem.md),
then NGSolve's own timers of that run with the most time (calls and seconds:
residuals, assemblies, factorisations, contact pairs). With --impacts as well,
the profile is of the impact doSteps alone (those of more than two internal
steps), and their wall times are printed (docs/notes/fem.md, "Each change and what
it bought").
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import time

import ngsolve as ngs
import numpy as np

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import PRESETS


def run(t_end: float, preset: str, values: dict[str, object] | None = None) -> dict[str, float]:
    """One timed run from a fresh model (set-up not timed)."""
    model = FemModel(PRESETS[preset](**(values or {})))
    e0 = model.outputs().energy_total
    swing = swing_energy(model.scene)
    steps = round(t_end / 1e-3)
    e_err, substeps, impacts = 0.0, 0, []
    c0, w0 = time.process_time(), time.perf_counter()
    for i in range(1, steps + 1):
        s0 = time.perf_counter()
        o = model.advance(i * 1e-3, 0.0)
        if o.solver_substeps > 2:  # an impact doStep: its wall time, in ms
            impacts.append(round(1e3 * (time.perf_counter() - s0), 2))
        e_err = max(e_err, abs(o.energy_total - o.energy_torque_work - e0))
        substeps += o.solver_substeps
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    counts = model.newton.counts
    return {
        "cpu_per_sim_s": cpu / t_end,
        "wall_per_sim_s": wall / t_end,
        "substeps": substeps,
        "iterations": counts.iterations,
        "jacobians": counts.jacobians,
        "rescaled": counts.rescaled,
        "by_superlu": model.newton.by_superlu,
        "theta_end": o.theta,
        "energy_error_rel": e_err / swing,
        "impact_ms": impacts,
    }


def profile_impacts(t_end: float, preset: str, values: dict[str, object], entries: int) -> None:
    """Profile the doSteps of more than two internal steps (the impacts) of one run; print their wall times."""
    model = FemModel(PRESETS[preset](**values))
    stats, impacts = None, []
    for i in range(1, round(t_end / 1e-3) + 1):
        profiler = cProfile.Profile()
        w0 = time.perf_counter()
        out = profiler.runcall(model.advance, i * 1e-3, 0.0)
        wall = time.perf_counter() - w0
        if out.solver_substeps > 2:
            impacts.append(f"{i * 1e-3:.3f} s: {out.solver_substeps} steps {1e3 * wall:.2f} ms")
            stats = pstats.Stats(profiler) if stats is None else stats.add(profiler)
    if stats is not None:
        stats.sort_stats("tottime").print_stats(entries)
    print("impact doSteps (under cProfile):", "; ".join(impacts), "load average", os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--t-end", type=float, default=1.0, help="simulated seconds per run")
    parser.add_argument("--repeat", type=int, default=3, help="runs; the one with the least CPU time is printed")
    parser.add_argument("--preset", choices=PRESETS, default="steel", help="the scene")
    parser.add_argument("--deformable-wall", action="store_true", help="the meshed (deformable) wall block")
    parser.add_argument("--mesh-size", type=float, default=0.0, help="model.mesh_size (0: the scene's default)")
    parser.add_argument("--profile", type=int, default=0, help="run once under cProfile, print this many entries")
    parser.add_argument("--impacts", action="store_true", help="with --profile: the impact doSteps alone")
    args = parser.parse_args()
    values: dict[str, object] = {"wall.kind": "deformable"} if args.deformable_wall else {}
    if args.mesh_size:
        values["model.mesh_size"] = args.mesh_size
    if args.profile and args.impacts:
        profile_impacts(args.t_end, args.preset, values, args.profile)
        return
    if args.profile:
        profiler = cProfile.Profile()
        result = profiler.runcall(run, args.t_end, args.preset, values)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(args.profile)
        timers = sorted(ngs.Timers(), key=lambda t: -t["time"])[: args.profile]
        print("NGSolve timers (s, calls):")
        for t in timers:
            print(f"  {t['time']:8.3f} {t['counts']:7d}  {t['name']}")
        print(result, "load average", os.getloadavg())
        return
    runs = [run(args.t_end, args.preset, values) for _ in range(args.repeat)]
    best = min(runs, key=lambda r: r["cpu_per_sim_s"])
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    cpus = ", ".join(f"{r['cpu_per_sim_s']:.3f}" for r in runs)
    print(
        f"cpu {best['cpu_per_sim_s']:.3f} s/sim s (runs: {cpus}), "
        f"wall {best['wall_per_sim_s']:.3f} s/sim s, load average {load}, {best['substeps']} internal steps, "
        f"theta(end) {best['theta_end']:.12f} rad, energy error / swing {best['energy_error_rel']:.2e}; "
        f"Newton iterations {best['iterations']}, Jacobians {best['jacobians']}, rescaled refactorisations "
        f"{best['rescaled']}, factorisations by SuperLU {best['by_superlu']}; impact doSteps (ms, wall): "
        f"{', '.join(' '.join(map(str, r['impact_ms'])) for r in runs)}"
    )
    assert np.isfinite(best["theta_end"])


if __name__ == "__main__":
    main()
