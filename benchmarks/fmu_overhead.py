"""Cost of the FMI layer: one doStep through fmpy against the model called directly, and start-up time.

    python benchmarks/fmu_overhead.py [--fmu dist/FemPendulum.fmu] [--steps 300]

Both paths run the same scene (steel, default mesh, released at 20 degrees)
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
import time
from pathlib import Path

HERE = str(Path(__file__).resolve())  # each run: this file in a fresh process (--direct, --fmu-steps)


def fmu_steps(fmu: str, n: int, fidelity: int) -> None:
    """(A child, --fmu-steps.) Print the time of instantiate + initialise and the time per doStep of n steps
    through fmpy's FMU2Slave."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    t0 = time.perf_counter()
    md = read_model_description(fmu)
    d = extract(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    s = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier="FemPendulum", instanceName="b")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setInteger([vr["model.fidelity"]], [fidelity])
    s.exitInitializationMode()
    t_init = time.perf_counter() - t0
    t = 0.0
    t0 = time.perf_counter()
    for k in range(n):
        s.setReal([vr["torque"]], [0.0])
        s.doStep(t, 1e-3)
        t = (k + 1) * 1e-3
        s.getReal(outs)
    print(t_init, (time.perf_counter() - t0) / n)


def direct_steps(n: int, fidelity: str) -> None:
    """(A child, --direct.) Print the time per step of n steps of the model called directly."""
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import steel

    m = create(steel(**{"model.fidelity": fidelity}))
    t0 = time.perf_counter()
    for k in range(n):
        m.advance((k + 1) * 1e-3, 0.0)
    print((time.perf_counter() - t0) / n)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--repeat", type=int, default=3, help="runs each way; the first FMU run has the cold cache")
    p.add_argument("--fmu-steps", nargs=3, metavar=("FMU", "STEPS", "FIDELITY"), help=argparse.SUPPRESS)
    p.add_argument("--direct", nargs=2, metavar=("STEPS", "FIDELITY"), help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.fmu_steps:
        fmu_steps(args.fmu_steps[0], int(args.fmu_steps[1]), int(args.fmu_steps[2]))
        return
    if args.direct:
        direct_steps(int(args.direct[0]), args.direct[1])
        return
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
                            [sys.executable, HERE, "--direct", str(args.steps), name],
                            capture_output=True,
                            text=True,
                            check=True,
                        ).stdout.split()[-1]
                    )
                )
                out = subprocess.run(
                    [sys.executable, HERE, "--fmu-steps", str(args.fmu), str(args.steps), str(code)],
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
