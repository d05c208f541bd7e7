"""The rigid fidelity through the FMU against the floor of any Python FMU.

    python benchmarks/rigid_floor.py [--fmu dist/FemPendulum.fmu] [--repeat 5] [--stop-time 2]

The floor is a trivial pythonfmu slave with the same inputs, parameters and
Real outputs as FemPendulum (read from modelDescription.template.xml through
fem_pendulum_fmu/fmi/interface.py), whose doStep only adds torque x step to
one output. It is built into a temporary folder with the same binary
(fmi/shim/) as FemPendulum, so both go through the same native calls. Both
FMUs are then driven alike by fmpy's FMU2Slave, each run in a fresh process:
the steel scene released at theta0 (20 degrees), 1 ms communication steps,
every step set the torque (0), doStep, getReal of all Real outputs, for
--stop-time seconds. Printed: CPU time (time.process_time, all the process's
threads), the stepping thread's CPU time (time.thread_time: the process may
run other threads beside it, which process_time counts) and wall time per
simulated second of the stepping loop (instantiation excluded), median of
--repeat runs each (alternating, so that load from other jobs hits both
alike), their ratios, and the load average before and after.

    python benchmarks/rigid_floor.py --instructions [--fmu ...] [--stop-time 2]

counts instead what the load cannot change: each FMU runs the same calls once
under valgrind's callgrind, collected in the stepping loop only (run inside
functools.reduce, callgrind's --toggle-collect); printed per doStep are the
instructions of the whole loop (fmpy's side included) and of those inside the
FMU's fmi2DoStep, fmi2SetReal and fmi2GetReal (inclusive) where callgrind names
them: it did under pythonfmu's binary, it does not under ours (entered from
ctypes' libffi, their cost is filed under an unnamed frame), so with ours only the
whole loop counts, with the whole loop's ratio.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from fem_pendulum_fmu.fmi import interface as fmi_interface

FLOOR_ID = "RigidFloor"  # the class of benchmarks/rigid_floor_slave.py

HERE = Path(__file__).resolve().parent
SLAVE = HERE / "rigid_floor_slave.py"  # the trivial slave; its variables in a file beside it in the FMU
DRIVER = HERE / "rigid_floor_driver.py"  # one timed run, in a fresh process


def variables() -> list[tuple]:
    """FemPendulum's inputs, parameters and Real outputs as (name, type, causality, variability, start)."""
    chosen = []
    for v in fmi_interface.load().variables:
        if v.causality in ("input", "parameter") or (v.causality == "output" and v.type == "Real"):
            chosen.append((v.name, v.type, v.causality, v.variability, v.start))
    return chosen


def build_floor(folder: Path) -> Path:
    """Build the trivial FMU in `folder`, with the same binary as FemPendulum."""
    import rigid_floor_slave  # benchmarks/ is on sys.path: this script's folder
    from pythonfmu.builder import FmuBuilder

    from fem_pendulum_fmu.fmi.builder import finish_fmu, shim_resources

    listed = folder / rigid_floor_slave.VARIABLES_FILE
    listed.write_text(json.dumps(variables()))
    fmu = Path(FmuBuilder.build_FMU(SLAVE, dest=folder, project_files=[listed]))
    with zipfile.ZipFile(fmu) as z:
        xml = z.read("modelDescription.xml").decode()
    finish_fmu(fmu, FLOOR_ID, xml, shim_resources(("numpy",)))
    return fmu


def run(fmu: Path, identifier: str, stop: float, step: float, integers: dict[str, int]) -> dict:
    """One run in a fresh process: the driver's JSON line."""
    out = subprocess.run(
        [sys.executable, str(DRIVER), str(fmu), identifier, repr(stop), repr(step), json.dumps(integers)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


CALLS = ("fmi2DoStep", "fmi2SetReal", "fmi2GetReal")
ANNOTATED = re.compile(r"\s*([\d,]+) .*:(fmi2\w+) \[.*/binaries/linux64/[^/\]]*\.so\]")


def count_instructions(fmu: Path, identifier: str, stop: float, step: float, integers: dict[str, int]) -> dict:
    """One run under callgrind, collecting in the stepping loop only (the driver's "count" mode): its
    instructions ("loop") and those inside each of CALLS (inclusive)."""
    with tempfile.TemporaryDirectory(prefix="rigid_floor_cg_") as tmp:
        out = Path(tmp) / "callgrind.out"
        args = [str(fmu), identifier, repr(stop), repr(step), json.dumps(integers), "count"]
        valgrind = ["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=functools_reduce"]
        subprocess.run(
            [*valgrind, f"--callgrind-out-file={out}", sys.executable, str(DRIVER), *args],
            capture_output=True,
            check=True,
        )
        text = subprocess.run(
            ["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    counts = dict.fromkeys(CALLS, 0)
    for line in text.splitlines():
        m = ANNOTATED.match(line)
        if m and m[2] in counts:
            counts[m[2]] += int(m[1].replace(",", ""))
        elif "PROGRAM TOTALS" in line:
            counts["loop"] = int(line.split()[0].replace(",", ""))
    return counts


def report_instructions(floor: Path, fmu: Path, args: argparse.Namespace, integers: dict[str, int]) -> None:
    """Print the instructions per doStep of both FMUs (see the module's docstring)."""
    n = round(args.stop_time / args.step)
    per_step = {}
    fmus = (("floor", floor, FLOOR_ID, {}), (args.fidelity, fmu, "FemPendulum", integers))
    for name, path, identifier, values in fmus:
        counts = count_instructions(path, identifier, args.stop_time, args.step, values)
        per_step[name] = {k: v / n for k, v in counts.items()}
    print(f"instructions per doStep (callgrind, {n} doSteps; inside the FMU's calls inclusive)")
    print("| FMU | " + " | ".join(CALLS) + " | in the calls | whole loop |")
    print("|---|" + "---|" * (len(CALLS) + 2))
    for k, c in per_step.items():
        calls = " | ".join(f"{c[call]:,.0f}" for call in CALLS)
        print(f"| {k} | {calls} | {sum(c[call] for call in CALLS):,.0f} | {c['loop']:,.0f} |")
    loop = {k: c["loop"] for k, c in per_step.items()}
    print(
        f"ratio {args.fidelity} / floor, whole loop: {loop[args.fidelity] / loop['floor']:.3f} "
        f"({loop[args.fidelity] - loop['floor']:,.0f} more per doStep)"
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fmu", type=Path, default=Path("dist") / "FemPendulum.fmu")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--stop-time", type=float, default=2.0)
    p.add_argument("--step", type=float, default=1e-3)
    p.add_argument("--fidelity", default="rigid")
    p.add_argument("--instructions", action="store_true", help="count instructions under callgrind instead")
    args = p.parse_args()
    fidelity = fmi_interface.load().by_name("model.fidelity").item_number(args.fidelity)
    if args.instructions:
        with tempfile.TemporaryDirectory(prefix="rigid_floor_") as tmp:
            report_instructions(build_floor(Path(tmp)), args.fmu.resolve(), args, {"model.fidelity": fidelity})
        return
    load_before = os.getloadavg()
    runs: dict[str, list[dict]] = {"floor": [], args.fidelity: []}
    with tempfile.TemporaryDirectory(prefix="rigid_floor_") as tmp:
        floor = build_floor(Path(tmp))
        for _ in range(args.repeat):
            runs["floor"].append(run(floor, FLOOR_ID, args.stop_time, args.step, {}))
            runs[args.fidelity].append(
                run(args.fmu.resolve(), "FemPendulum", args.stop_time, args.step, {"model.fidelity": fidelity})
            )
    load_after = os.getloadavg()
    median = {
        k: {m: statistics.median(r[m] for r in v) / args.stop_time for m in ("cpu", "thread", "wall")}
        for k, v in runs.items()
    }
    print(
        f"{args.repeat} runs each, {args.stop_time:g} s in {args.step * 1e3:g} ms steps, "
        f"{runs['floor'][0]['outputs']} Real outputs read per step"
    )
    print("| FMU | CPU ms per simulated s | of it the stepping thread | wall ms per simulated s | CPU, every run |")
    print("|---|---|---|---|---|")
    for k, v in runs.items():
        every = ", ".join(f"{r['cpu'] / args.stop_time * 1e3:.1f}" for r in v)
        print(
            f"| {k} | {median[k]['cpu'] * 1e3:.1f} | {median[k]['thread'] * 1e3:.1f} | {median[k]['wall'] * 1e3:.1f} "
            f"| {every} |"
        )
    ratio_cpu = median[args.fidelity]["cpu"] / median["floor"]["cpu"]
    ratio_wall = median[args.fidelity]["wall"] / median["floor"]["wall"]
    ratio_thread = median[args.fidelity]["thread"] / median["floor"]["thread"]
    print(
        f"ratio {args.fidelity} / floor: CPU {ratio_cpu:.2f}, stepping thread {ratio_thread:.2f}, wall {ratio_wall:.2f}"
    )
    print(
        "load average (1, 5, 15 min) before: {:.2f} {:.2f} {:.2f}, after: {:.2f} {:.2f} {:.2f}".format(
            *load_before, *load_after
        )
    )


if __name__ == "__main__":
    main()
