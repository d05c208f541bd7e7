"""The races in netgen and NGSolve that fem_pendulum_fmu/physics/shared_state.py's lock takes in turn, reproduced.

Each run is a fresh process (benchmarks/library_races_driver.py) in which THREADS threads make the same object at
once, released together from a barrier, and compare it with one made alone afterwards; with the lock taken away
("unlocked") and held as the package holds it ("locked"). A run is "same", "different" (a result that differs from
the one made alone, or an exception), or "crashed" (the process died: heap corruption, SIGSEGV).

    python benchmarks/library_races.py --runs 20 --threads 4

prints, per case and lock, the count of each. The cases:

    mesh       netgen.occ shapes named and combined into the pendulum, meshed, loaded and curved (the shapes'
               names and sizes are kept in netgen's process-wide tables; the mesher and reader use process-wide
               variables)
    set        GridFunction.Set of the initial rotation, each thread on a space of its own (NGSolve's Python
               bindings take its scratch memory from one heap for the whole process)
    build      a fem model built (FemModel itself, or fidelity.create, which holds the lock), then 20 steps
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections import Counter
from pathlib import Path

DRIVER = str(Path(__file__).resolve().parent / "library_races_driver.py")
CASES = ("mesh", "set", "build")


def one_run(case: str, lock: str, threads: int) -> str:
    run = subprocess.run(
        [sys.executable, DRIVER, case, lock, str(threads)], capture_output=True, text=True, timeout=600
    )
    if run.returncode != 0:
        return "crashed"
    return "same" if run.stdout.strip() == "same" else "different"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20, help="processes per case and lock")
    parser.add_argument("--threads", type=int, default=4)
    args = parser.parse_args()
    print(f"{args.runs} runs of {args.threads} threads for each case and lock")
    print(f"{'case':10} {'lock':9} {'same':>5} {'different':>10} {'crashed':>8}")
    for case in CASES:
        for lock in ("unlocked", "locked"):
            counts = Counter(one_run(case, lock, args.threads) for _ in range(args.runs))
            print(f"{case:10} {lock:9} {counts['same']:5} {counts['different']:10} {counts['crashed']:8}", flush=True)


if __name__ == "__main__":
    main()
