"""Run a schedule of communication steps through the FMU in a fresh interpreter (fmpy FMU2Slave).

Shared by the robustness tests and benchmarks/robustness.py. One instance per
run, freed (fmi2FreeInstance, library unloaded) before the next. The child is this file:

    python tests/fmu_runner.py < JOB_JSON

runs the job run_schedule writes to its stdin and prints the outputs as one JSON line.
"""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
COLUMNS = (
    "time",
    "theta",
    "omega",
    "gap",
    "contact_force",
    "energy.kinetic",
    "energy.potential",
    "energy.strain",
    "energy.contact",
    "energy.total",
    "energy.torque_work",
    "gap_min",
    "contact_force_max",
    "contact_impulse",
    "solver.substeps",
    "status",
)
STIFF: dict = {}
COMPLIANT = {"pendulum.E": 1e6, "pendulum.nu": 0.45, "pendulum.rho": 1000.0, "contact.stiffness": 5e9, "model.order": 3}


def fmi_value(name: str, value):
    """The FMI start value of a parameter: an enumeration's item name (model.fidelity = "fem") becomes
    its number as the interface's one declaration (the template) numbers it; other values pass."""
    # imported here, in the parent: the child process must not import the package before the FMU does
    from fem_pendulum_fmu.fmi import interface

    var = interface.load().by_name(name)
    return var.item_number(value) if var.items and isinstance(value, str) else value


def run_schedule(fmu: str, params: dict, schedule: list, repeat: int = 1) -> list[np.ndarray]:
    """Outputs after every doStep (first row: after initialisation), once per repeat, in a new process.

    schedule: [(h, torque), ...]. The status column is 0 (OK) or 2 (discard: the run stops there)."""
    params = {k: fmi_value(k, v) for k, v in params.items()}
    payload = json.dumps({"fmu": str(fmu), "params": params, "schedule": schedule, "repeat": repeat})
    run = subprocess.run([sys.executable, str(HERE)], input=payload, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(run.stdout[-3000:] + run.stderr[-3000:])
    return [np.array(rows, dtype=float) for rows in json.loads(run.stdout.strip().splitlines()[-1])]


def main() -> None:
    """The child of run_schedule: the job (JSON on stdin) run, the rows printed as one JSON line."""
    from fmpy.fmi1 import FMICallException
    from test_fmu import Instance

    job = json.loads(sys.stdin.read())
    params = job["params"]
    runs = []
    for r in range(job["repeat"]):
        inst = Instance(job["fmu"], f"run{r}", **params)
        reals = [inst.var[c].valueReference for c in COLUMNS[1:-2]]
        sub = inst.var["solver.substeps"].valueReference
        row = functools.partial(_row, inst, reals, sub)
        rows = [row(0.0, 0)]
        t = 0.0
        for h, torque in job["schedule"]:
            inst.set("torque", torque)
            try:
                inst.fmu.doStep(t, h)
            except FMICallException as exc:
                if "status 2" not in str(exc):
                    raise
                rows.append(row(t, 2))
                break
            t += h
            rows.append(row(t, 0))
        runs.append(rows)
        inst.close()
    print(json.dumps(runs))


def _row(inst, reals: list[int], sub: int, t: float, status: int) -> list[float]:
    """One row of COLUMNS: t, the Real outputs, the substeps and the status."""
    return [t, *inst.fmu.getReal(reals), float(inst.fmu.getInteger([sub])[0]), status]


def col(run: np.ndarray, name: str) -> np.ndarray:
    return run[:, COLUMNS.index(name)]


if __name__ == "__main__":
    main()
