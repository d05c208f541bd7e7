"""Speed and accuracy of every fidelity through the FMU, as a user runs it.

    python benchmarks/fidelity_speed.py [--fmu dist/FemPendulum.fmu] [--t-end 2] [--repeat 3]

Each run is a fresh process that drives the FMU with fmpy's FMU2Slave in 1 ms
communication steps (torque 0, released at 20 degrees) and times the doStep
loop (set torque, doStep, get every output) after initialisation. Scenes: the
steel and rubber presets. For each scene the fem run is the
reference the other fidelities are compared with (max |theta - theta_fem|,
max |gap - gap_fem|); the energy error is max |E_total - E_0 - W_torque| over
the swing energy m g d (1 - cos 20 deg) (physics.mass_properties). Times: CPU
time of the process (less sensitive to other jobs on the machine) and wall
time, median of --repeat runs (fem: one run when --repeat-fem is 1), with the
CPU spread. The comparison with fem stops
before the second impact (--compare-until): after it, both models' results
depend on the phase of a vibration 1-2 ms steps do not resolve.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from fem_pendulum_fmu.physics.mass_properties import swing_energy
from fem_pendulum_fmu.physics.scene import PRESETS

ROOT = Path(__file__).resolve().parents[1]
DRIVER = Path(__file__).resolve().with_name("fidelity_speed_driver.py")  # one timed run, in a fresh process
sys.path.insert(0, str(ROOT / "tests"))  # fmu_runner: the interface's enumeration numbers

from fmu_runner import fmi_value  # noqa: E402


def run(fmu: Path, preset: str, fidelity: str, t_end: float, tmp: Path) -> tuple[dict, np.ndarray]:
    out = tmp / f"{preset}_{fidelity}.npy"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run(
        [
            sys.executable,
            str(DRIVER),
            str(fmu),
            preset,
            str(fmi_value("model.fidelity", fidelity)),
            str(t_end),
            str(out),
        ],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1]), np.load(out)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    p.add_argument("--t-end", type=float, default=2.0)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--repeat-fem", type=int, default=1)
    p.add_argument("--scenes", default="steel,rubber")
    p.add_argument(
        "--compare-until",
        type=float,
        default=0.6,
        help="compare with fem up to this time (s): before the second impact, after which both "
        "models' results depend on the phase of an unresolved vibration (docs/notes/reduced.md)",
    )
    args = p.parse_args(argv)
    if not args.fmu.exists():
        subprocess.run([sys.executable, "build_fmu.py"], check=True)
    print(
        f"| scene | fidelity | CPU s per simulated s (median, spread) | wall s per simulated s (median) | "
        f"internal steps per s | max dtheta vs fem to {args.compare_until:g} s (deg) | max dgap (mm) | "
        f"energy error / swing energy (whole run) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for named in args.scenes.split(","):
            preset = next(k for k, f in PRESETS.items() if f is PRESETS[named])  # an old name: its new one
            results = {}
            for fidelity in ("fem", "reduced", "rigid"):
                repeat = args.repeat_fem if fidelity == "fem" else args.repeat
                times = []
                for _ in range(repeat):
                    timing, rows = run(args.fmu, preset, fidelity, args.t_end, Path(tmp))
                    times.append((timing["cpu"] / args.t_end, timing["wall"] / args.t_end))
                results[fidelity] = (sorted(times), rows)
            ref = results["fem"][1]
            window = slice(0, int(round(args.compare_until / 1e-3)) + 1)
            for fidelity, (times, rows) in results.items():
                swing = swing_energy(PRESETS[preset]())
                energy = np.max(np.abs(rows[:, 2] - rows[0, 2] - rows[:, 3])) / swing
                dth = np.degrees(np.max(np.abs(rows[window, 0] - ref[window, 0])))
                dgap = 1e3 * np.max(np.abs(rows[window, 1] - ref[window, 1]))
                cpu, wall = times[len(times) // 2]
                spread = f"{times[0][0]:.3g}-{times[-1][0]:.3g}" if len(times) > 1 else "1 run"
                steps = rows[1:, 4].sum() / args.t_end
                print(
                    f"| {preset} | {fidelity} | {cpu:.3g} ({spread}) | {wall:.3g} | {steps:.0f} | "
                    f"{'reference' if fidelity == 'fem' else f'{dth:.3g}'} | "
                    f"{'reference' if fidelity == 'fem' else f'{dgap:.3g}'} | {energy:.2g} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
