"""Wall time per simulated second of the FE model against the seed baseline.

    python benchmarks/fem_speed.py [--seed-steps N] [--no-seed]

Runs the steel scene (steel(), rigid wall, released at 20 degrees, no torque)
for 1 s on the default mesh and on the seed's own mesh, once in a single
advance and once in 1 ms communication steps as an FMU master drives it,
and prints wall time per simulated second next to the accuracy it reached
(first rebound peak, largest penetration, energy error over the swing energy).
When ../shared/baseline/seed_pendulum.py is there it also times the seed on a
short run at dt = 1 ms in the same session and prints the ratio.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import steel

SEED = Path(__file__).resolve().parents[1].parent / "shared" / "baseline" / "seed_pendulum.py"


def run_fem(refine_like_seed: bool, comm_step: float | None, t_end: float = 1.0) -> dict:
    t0 = time.perf_counter()
    model = FemModel(steel(), refine_like_seed=refine_like_seed)
    setup = time.perf_counter() - t0
    e0 = model.outputs().energy_total
    swing = swing_energy(model.scene)
    times = [t_end] if comm_step is None else list(np.arange(1, round(t_end / comm_step) + 1) * comm_step)
    theta, min_gap, e_err, substeps = [], [], [], 0
    t0 = time.perf_counter()
    for t in times:
        o = model.advance(float(t), 0.0)
        theta.append(o.theta)
        min_gap.append(model.last_min_gap)
        e_err.append(abs(o.energy_total - o.energy_torque_work - e0))
        substeps += o.solver_substeps
    wall = time.perf_counter() - t0
    th = np.degrees(theta)
    peak = float(th[len(th) // 3 : len(th) * 2 // 3].max()) if len(th) > 10 else float("nan")
    return {
        "ndof": model.X.ndof,
        "ne": model.mesh.ne,
        "setup_s": setup,
        "wall_per_sim_s": wall / t_end,
        "substeps": substeps,
        "first_rebound_deg": peak,
        "penetration_um": -min(min_gap) * 1e6,
        "energy_error_rel": max(e_err) / swing,
    }


def seed_cost_per_step(steps: int) -> float | None:
    """Seconds per 1 ms step of the seed baseline, measured now on this machine."""
    if not SEED.exists():
        return None
    out = subprocess.run(
        [sys.executable, str(SEED), str(steps * 1e-3), "1e-3"], capture_output=True, text=True, check=True
    ).stdout
    wall = float(re.search(r"wall=([0-9.]+)s", out).group(1))
    return wall / steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seed-steps", type=int, default=20, help="1 ms steps of the seed baseline to time")
    parser.add_argument("--no-seed", action="store_true", help="skip timing the seed baseline")
    args = parser.parse_args()
    rows = []
    for label, refine, comm in (
        ("default mesh, one advance", False, None),
        ("default mesh, 1 ms communication steps", False, 1e-3),
        ("seed's mesh, one advance", True, None),
        ("seed's mesh, 1 ms communication steps", True, 1e-3),
    ):
        r = run_fem(refine, comm)
        rows.append((label, r))
        print(f"{label}: {r}", flush=True)
    seed = None if args.no_seed else seed_cost_per_step(args.seed_steps)
    print()
    print(
        "| run | ndof | wall s per simulated s | internal steps | first rebound (deg) | penetration (um) "
        "| max energy error / swing energy |"
    )
    print("|---|---|---|---|---|---|---|")
    for label, r in rows:
        print(
            f"| {label} | {r['ndof']} | {r['wall_per_sim_s']:.2f} | {r['substeps']} | {r['first_rebound_deg']:.3f} "
            f"| {r['penetration_um']:.1f} | {r['energy_error_rel']:.1e} |"
        )
    if seed is not None:
        seed_per_sim = seed * 1000.0
        print(f"\nseed baseline (dt 1 ms, {args.seed_steps} steps timed now): {seed_per_sim:.0f} s per simulated s")
        for label, r in rows:
            print(f"  {label}: {seed_per_sim / r['wall_per_sim_s']:.0f}x faster than the seed")
    else:
        print(
            "\nseed baseline not timed (../shared/baseline/seed_pendulum.py absent or --no-seed); "
            "its figure on the 2-core machine is 478 s per simulated s"
        )


if __name__ == "__main__":
    main()
