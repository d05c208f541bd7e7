"""What the field output (output.vtk_folder) costs on a fem run through the FMU.

    python benchmarks/vtk_output_cost.py [--fmu dist/FemPendulum.fmu] [--stop-time 0.5] [--repeat 3]

The default steel scene (fem, 1 ms communication steps, torque 0) runs through fmpy.simulate_fmu
with the field output off and on (output.vtk_interval at its default 0.01 s), alternately, each run
a fresh process (`python benchmarks/vtk_output_cost.py --child ...`). Reported: the CPU time of each
run (less sensitive to other jobs than wall time), the medians, the extra share the field output
costs and the frames and bytes it wrote.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def child(fmu: str, stop_time: float, folder: str) -> None:
    """One run; prints its CPU and wall time as JSON."""
    from fmpy import simulate_fmu

    start = {"output.vtk_folder": folder} if folder else {}
    cpu, wall = time.process_time(), time.perf_counter()
    simulate_fmu(fmu, stop_time=stop_time, step_size=1e-3, output_interval=1e-3, start_values=start)
    print(json.dumps({"cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall}))


def run(fmu: str, stop_time: float, folder: str) -> dict:
    args = [sys.executable, __file__, "--child", "--fmu", fmu, "--stop-time", str(stop_time), "--folder", folder]
    done = subprocess.run(args, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fmu", default="dist/FemPendulum.fmu")
    parser.add_argument("--stop-time", type=float, default=0.5)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--folder", default="", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.fmu, args.stop_time, args.folder)
        return
    off, on = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeat):
            off.append(run(args.fmu, args.stop_time, ""))
            folder = Path(tmp) / f"fields{r}"
            on.append(run(args.fmu, args.stop_time, str(folder)))
            files = list(folder.iterdir())
        written = sum(f.stat().st_size for f in files)
    median = {name: sorted(x["cpu"] for x in runs)[len(runs) // 2] for name, runs in (("off", off), ("on", on))}
    print("cpu s, output off:", " ".join(f"{x['cpu']:.2f}" for x in off))
    print("cpu s, output on: ", " ".join(f"{x['cpu']:.2f}" for x in on))
    print(
        f"median {median['off']:.2f} s off, {median['on']:.2f} s on: the field output costs "
        f"{100 * (median['on'] / median['off'] - 1):.1f} % ({len(files) - 1} frames, {written / 1e6:.2f} MB)"
    )


if __name__ == "__main__":
    main()
