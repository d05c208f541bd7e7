"""Resident memory an FMU instance leaves behind once freed, in a native C host and through fmpy.

    python benchmarks/instance_memory.py [--dist dist] [--cycles 50] [--steps 100] [--repeat 3]

Each host runs CYCLES instances one after another (instantiate, initialise, STEPS doSteps of 1 ms,
terminate, free) and prints its resident size after each: tests/fmi2_cycle_host.c (compiled here)
and tests/fmpy_cycles.py (no gc.collect()). Printed per FMU and host: the growth per cycle from
cycle 10 to the last, from the end points and as a least-squares slope, for each of --repeat runs
in fresh processes, and the load average. FemPendulum runs its default scene (fem: NGSolve mesh,
spaces, matrices), PidController its defaults. tests/test_fmu_memory.py asserts the same bound.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import fmpy
import numpy as np
from fmpy import extract, read_model_description

ROOT = Path(__file__).resolve().parents[1]
FIRST = 10


def compile_cycle_host(folder: Path) -> str:
    binary = folder / "fmi2_cycle_host"
    include = Path(fmpy.__file__).parent / "c-code"
    source = ROOT / "tests" / "fmi2_cycle_host.c"
    compiler = shutil.which("cc") or "gcc"
    subprocess.run([compiler, "-O1", f"-I{include}", str(source), "-ldl", "-o", str(binary)], check=True)
    return str(binary)


def growth(stdout: str) -> tuple[float, float]:
    """kB per cycle from cycle FIRST on: end points, fitted slope."""
    rss = np.array([float(line.split()[2]) for line in stdout.splitlines() if line.startswith("cycle ")])
    ends = (rss[-1] - rss[FIRST]) / (len(rss) - 1 - FIRST)
    return ends, float(np.polyfit(np.arange(FIRST, len(rss)), rss[FIRST:], 1)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--dist", type=Path, default=Path("dist"), help="folder with FemPendulum.fmu, PidController.fmu"
    )
    parser.add_argument("--cycles", type=int, default=50)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"load average before {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="instance_memory_") as tmp:
        work = Path(tmp)
        host = compile_cycle_host(work)
        for identifier in ("FemPendulum", "PidController"):
            fmu = args.dist / f"{identifier}.fmu"
            folder = extract(str(fmu), unzipdir=str(work / identifier))
            guid = read_model_description(str(fmu)).guid
            commands = {
                "native": [host, folder, identifier, guid, str(args.cycles), str(args.steps)],
                "fmpy": [
                    sys.executable,
                    str(ROOT / "tests" / "fmpy_cycles.py"),
                    folder,
                    identifier,
                    str(args.cycles),
                    str(args.steps),
                ],
            }
            for name, command in commands.items():
                figures = []
                for _ in range(args.repeat):
                    run = subprocess.run(command, capture_output=True, text=True, check=True)
                    figures.append("{:.1f} ({:.1f})".format(*growth(run.stdout)))
                print(
                    f"{identifier:13s} {name:6s} kB per cycle, cycles {FIRST}-{args.cycles - 1}: {', '.join(figures)}"
                )
    print(f"load average after {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
