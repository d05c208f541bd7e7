"""Measurements behind docs/notes/robustness.md.

python benchmarks/robustness.py hard-cases [-k EXPR]
    runs tests/test_hard_cases.py with FEM_PENDULUM_ROBUSTNESS_LOG set (the tests record their
    measured worst values before asserting them) and prints one table row per case and fidelity
python benchmarks/robustness.py memory
    peak resident memory of building the FE model and taking one step, against the estimate
    scene.mesh_memory_estimate that refuses meshes too fine for the machine
python benchmarks/robustness.py leak --fmu dist/FemPendulum.fmu
    resident memory over 60 instances refused at initialisation (mesh too fine, nu = 0.5)
    against 60 valid ones, each freed with fmi2FreeInstance
python benchmarks/robustness.py findings
    the measurements behind the findings of docs/notes/robustness.md: Gauss points of the discrete
    gradient (steel after violent impacts, rubber after a pulse, cost on the default run),
    penetration against the square wave's period, step-sequence sensitivity after a second impact
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RUNS = str(ROOT / "benchmarks" / "robustness_runs.py")  # each measurement in a fresh process


def hard_cases(keyword: str | None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.jsonl"
        env = dict(os.environ, FEM_PENDULUM_ROBUSTNESS_LOG=str(log))
        cmd = [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            str(ROOT / "tests" / "test_hard_cases.py"),
        ]
        if keyword:
            cmd += ["-k", keyword]
        run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        print(run.stdout.strip().splitlines()[-1])
        rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    print(
        "\n| test | fidelity | energy error / scale (bound) | scale J | max penetration mm | steps per ms (bound) | "
        "max steps in a doStep | bit-identical runs | discarded |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "steps_per_ms" in r:
            print(
                f"| {r['test']} | {r['fidelity']} | {r['energy']:.2e} ({r['bound_energy']:g}) | {r['scale']:.3g} | "
                f"{1e3 * r['penetration']:.4f} | {r['steps_per_ms']:.2f} ({r['bound_steps_per_ms']:g}) | "
                f"{r['max_substeps']:.0f} | {r['runs']} {'equal' if r['identical'] else 'DIFFER'} | {r['discarded']} |"
            )
    print()
    for r in rows:
        if "steps_per_ms" not in r:
            print(json.dumps(r))


def memory() -> None:
    print(
        "| mesh size | order | unknowns | estimated unknowns | peak RSS growth MB | estimate MB | kB per unknown | s |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for h, p in ((0.03, 2), (0.01, 2), (0.005, 2), (0.005, 4), (0.0025, 3), (0.0025, 5)):
        out = subprocess.run(
            [sys.executable, RUNS, "memory", str(h), str(p)], capture_output=True, text=True, check=True
        )
        h_, p_, ndof, est, rss, est_mb, secs = json.loads(out.stdout.strip().splitlines()[-1])
        print(
            f"| {h_:g} | {p_} | {ndof} | {est:.0f} | {rss:.0f} | {est_mb:.0f} | {1024 * rss / ndof:.1f} | {secs:.1f} |"
        )


def findings() -> None:
    jobs = (
        [("gauss-violent", n) for n in (1, 2, 3)]
        + [("gauss-rubber", n) for n in (2, 3)]
        + [("gauss-default", n) for n in (1, 2, 1, 2)]
        + [("penetration", None), ("sequence", None), ("resting-tolerance", None)]
        + [("quadrature", v) for v in ("guard", "no-guard", "no-guard-old-torque-rule", "no-guard-old-strain-rule")]
    )
    for what, n in jobs:
        args = [sys.executable, RUNS, "finding", what] + ([str(n)] if n is not None else [])
        out = subprocess.run(args, capture_output=True, text=True, check=True, cwd=ROOT)
        print(out.stdout.strip(), flush=True)


def leak(fmu: str) -> None:
    """Memory growth per instance: refused at initialisation and freed, against valid ones instantiated and freed."""
    for kind in ("mesh", "nu", "valid"):
        out = subprocess.run([sys.executable, RUNS, "leak", fmu, kind], capture_output=True, text=True, check=True)
        print(out.stdout.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["hard-cases", "memory", "findings", "leak"])
    parser.add_argument("--fmu", default=str(ROOT / "dist" / "FemPendulum.fmu"), help="the FMU (leak)")
    parser.add_argument("-k", help="pytest -k expression (hard-cases)")
    args = parser.parse_args()
    {"hard-cases": lambda: hard_cases(args.k), "memory": memory, "findings": findings, "leak": lambda: leak(args.fmu)}[
        args.what
    ]()


if __name__ == "__main__":
    main()
