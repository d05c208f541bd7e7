"""Accuracy and cost of FE discretisations: how the default mesh size and order were chosen.

    python benchmarks/mesh_study.py [--t-end 0.6] [--preset steel|rubber]

For each (mesh size, order) it runs the scene (released at 20 degrees, rigid
wall) and prints the first contact time, the first rebound peak, the largest
penetration, the energy error and the wall time, plus the largest theta and
gap differences against the finest discretisation of the list.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import PRESETS

CASES = ((0.06, 2), (0.03, 2), (0.03, 3), (0.015, 2), (0.015, 3))


def run(preset: str, size: float, order: int, t_end: float) -> dict:
    model = FemModel(PRESETS[preset](**{"model.mesh_size": size, "model.order": order}))
    e0 = model.outputs().energy_total
    swing = swing_energy(model.scene)
    rows = []
    t0 = time.perf_counter()
    for i in range(1, int(round(t_end * 1000)) + 1):
        o = model.advance(i * 1e-3, 0.0)
        rows.append((o.time, o.theta, o.gap, model.last_min_gap, abs(o.energy_total - o.energy_torque_work - e0)))
    wall = time.perf_counter() - t0
    r = np.array(rows)
    k = int(np.argmax(r[:, 3] < 0))
    return {
        "ndof": model.X.ndof,
        "wall_per_sim_s": wall / t_end,
        "contact_ms": r[k, 0] * 1e3,
        "peak_deg": float(np.degrees(r[k:, 1].max())),
        "pen_um": -r[:, 3].min() * 1e6,
        "energy_rel": r[:, 4].max() / swing,
        "theta": r[:, 1],
        "gap": r[:, 2],
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--t-end", type=float, default=0.6)
    p.add_argument("--preset", default="steel", choices=PRESETS)
    args = p.parse_args()
    results = {}
    for case in CASES:
        results[case] = run(args.preset, *case, args.t_end)
        print(case, {k: v for k, v in results[case].items() if k not in ("theta", "gap")}, flush=True)
    ref = results[CASES[-1]]
    print(f"preset {args.preset}, {args.t_end} s, reference {CASES[-1]}")
    print(
        "| mesh size | order | ndof | wall s / sim s | contact in interval ending (ms) | first rebound (deg) "
        "| penetration (um) | energy error / swing | max theta diff (deg) | max gap diff (mm) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (size, order), r in results.items():
        dth = np.degrees(np.max(np.abs(r["theta"] - ref["theta"])))
        dgap = np.max(np.abs(r["gap"] - ref["gap"])) * 1e3
        print(
            f"| {size} | {order} | {r['ndof']} | {r['wall_per_sim_s']:.2f} | {r['contact_ms']:.0f} "
            f"| {r['peak_deg']:.3f} "
            f"| {r['pen_um']:.1f} | {r['energy_rel']:.1e} | {dth:.4f} | {dgap:.4f} |"
        )


if __name__ == "__main__":
    main()
