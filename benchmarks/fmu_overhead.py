"""Cost of the FMI layer: one doStep through fmpy against the model called directly, and start-up time.

    python benchmarks/fmu_overhead.py [--fmu dist/FemPendulum.fmu] [--steps 300]

Both paths run the same scene (stiff, default mesh, released at 20 degrees)
for the same 1 ms communication steps in free flight; the difference per step
(best of --repeat runs each way) is the overhead of fmpy + pythonfmu + the
slave (set torque, doStep, get all outputs). Start-up is instantiate +
initialise of a new process's first instance, once with an empty mesh cache
(cold) and then with the cache the first run filled (warm, best of the rest);
each run is a fresh process.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

FMU_STEPS = """
import sys, time
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu, n, fidelity = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
t0 = time.perf_counter()
md = read_model_description(fmu); d = extract(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}
outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="FemPendulum", instanceName="b")
s.instantiate(); s.setupExperiment(startTime=0.0); s.enterInitializationMode()
s.setInteger([vr["model.fidelity"]], [fidelity])
s.exitInitializationMode()
t_init = time.perf_counter() - t0
t = 0.0
t0 = time.perf_counter()
for k in range(n):
    s.setReal([vr["torque"]], [0.0]); s.doStep(t, 1e-3); t = (k + 1) * 1e-3; s.getReal(outs)
print(t_init, (time.perf_counter() - t0) / n)
"""

DIRECT = """
import sys, time
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.scene import stiff
n, fidelity = int(sys.argv[1]), sys.argv[2]
m = create(stiff(**{"model.fidelity": fidelity}))
t0 = time.perf_counter()
for k in range(n):
    m.advance((k + 1) * 1e-3, 0.0)
print((time.perf_counter() - t0) / n)
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--repeat", type=int, default=3, help="runs each way; the first FMU run has the cold cache")
    args = p.parse_args()
    print(
        "| fidelity | direct s/step | through fmpy s/step | overhead per doStep "
        "| instantiate+initialise, cold cache | warm cache |"
    )
    print("|---|---|---|---|---|---|")
    for name, code in (("fem", 4), ("rigid", 2)):
        # best of --repeat runs each way, alternating, so that load from other jobs hits both alike
        direct, runs = [], []
        with tempfile.TemporaryDirectory() as cache_dir:
            env = {**os.environ, "FEM_PENDULUM_CACHE": cache_dir}
            for _ in range(args.repeat):
                direct.append(
                    float(
                        subprocess.run(
                            [sys.executable, "-c", DIRECT, str(args.steps), name],
                            capture_output=True,
                            text=True,
                            check=True,
                        ).stdout.split()[-1]
                    )
                )
                out = subprocess.run(
                    [sys.executable, "-c", FMU_STEPS, str(args.fmu), str(args.steps), str(code)],
                    capture_output=True,
                    text=True,
                    check=True,
                    env=env,
                ).stdout.split()
                runs.append((float(out[-2]), float(out[-1])))
        best_direct, via = min(direct), min(r[1] for r in runs)
        print(
            f"| {name} | {best_direct * 1e3:.3f} ms | {via * 1e3:.3f} ms | {(via - best_direct) * 1e6:.0f} us "
            f"| {runs[0][0]:.2f} s | {min(r[0] for r in runs[1:]):.2f} s |"
        )


if __name__ == "__main__":
    main()
