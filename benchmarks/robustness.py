"""Measurements behind docs/robustness.md.

    python benchmarks/robustness.py hard-cases [--fidelities rigid,fem] [-k EXPR]
        runs tests/test_hard_cases.py with FEM_PENDULUM_ROBUSTNESS_LOG set (the tests record their
        measured worst values before asserting them) and prints one table row per case and fidelity
    python benchmarks/robustness.py memory
        peak resident memory of building the FE model and taking one step, against the estimate
        scene.mesh_memory_estimate that refuses meshes too fine for the machine
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def hard_cases(keyword: str | None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.jsonl"
        env = dict(os.environ, FEM_PENDULUM_ROBUSTNESS_LOG=str(log))
        cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(ROOT / "tests" / "test_hard_cases.py")]
        if keyword:
            cmd += ["-k", keyword]
        run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        print(run.stdout.strip().splitlines()[-1])
        rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    print("\n| test | fidelity | energy error / scale (bound) | scale J | max penetration mm | steps per ms (bound) | "
          "max steps in a doStep | bit-identical runs | discarded |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "steps_per_ms" in r:
            print(f"| {r['test']} | {r['fidelity']} | {r['energy']:.2e} ({r['bound_energy']:g}) | {r['scale']:.3g} | "
                  f"{1e3 * r['penetration']:.4f} | {r['steps_per_ms']:.2f} ({r['bound_steps_per_ms']:g}) | "
                  f"{r['max_substeps']:.0f} | {r['runs']} {'equal' if r['identical'] else 'DIFFER'} | {r['discarded']} |")
    print()
    for r in rows:
        if "steps_per_ms" not in r:
            print(json.dumps(r))


def memory() -> None:
    script = """
import os, resource, sys, time, json
os.environ['FEM_PENDULUM_CACHE'] = 'off'
from fem_pendulum_fmu.models.fem import FemModel
from fem_pendulum_fmu.scene import stiff, estimated_unknowns, mesh_memory_estimate
h, p = float(sys.argv[1]), int(sys.argv[2])
scene = stiff(**{'model.mesh_size': h, 'model.order': p, 'theta0': 0.05})
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
m = FemModel(scene)
m.advance(2e-3, 0.0)
r1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps([h, p, m.X.ndof, estimated_unknowns(scene), (r1 - r0) / 1024, mesh_memory_estimate(scene) / 2**20,
                  time.perf_counter() - t0]))
"""
    print("| mesh size | order | unknowns | estimated unknowns | peak RSS growth MB | estimate MB | kB per unknown | s |")
    print("|---|---|---|---|---|---|---|---|")
    for h, p in ((0.03, 2), (0.01, 2), (0.005, 2), (0.005, 4), (0.0025, 3), (0.0025, 5)):
        out = subprocess.run([sys.executable, "-c", script, str(h), str(p)], capture_output=True, text=True, check=True)
        h_, p_, ndof, est, rss, est_mb, secs = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"| {h_:g} | {p_} | {ndof} | {est:.0f} | {rss:.0f} | {est_mb:.0f} | {1024 * rss / ndof:.1f} | {secs:.1f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["hard-cases", "memory"])
    parser.add_argument("-k", help="pytest -k expression (hard-cases)")
    args = parser.parse_args()
    hard_cases(args.k) if args.what == "hard-cases" else memory()


if __name__ == "__main__":
    main()
