"""One timed run of benchmarks/fidelity_speed.py, in a fresh process that imports nothing of the package.

    python benchmarks/fidelity_speed_driver.py FMU PRESET FIDELITY T_END OUT_NPY

fmpy's FMU2Slave: model.fidelity = FIDELITY (its number), the rubber preset's parameters when PRESET is
"rubber", then 1 ms steps to T_END (torque 0). Saves theta, gap, energy.total, energy.torque_work and
solver.substeps after initialisation and every step to OUT_NPY; prints the loop's wall and CPU time as JSON.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


def main(argv: list[str]) -> None:
    fmu, preset, fidelity, t_end, out = argv[0], argv[1], int(argv[2]), float(argv[3]), argv[4]
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    names = ["theta", "gap", "energy.total", "energy.torque_work", "solver.substeps"]
    s = FMU2Slave(
        guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier, instanceName="b"
    )
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.setInteger([vr["model.fidelity"]], [fidelity])
    if preset == "rubber":
        s.setReal(
            [vr["pendulum.E"], vr["pendulum.nu"], vr["pendulum.rho"], vr["contact.stiffness"]], [1e6, 0.45, 1000.0, 5e9]
        )
        s.setInteger([vr["model.order"]], [3])
    s.exitInitializationMode()
    reals = [vr[n] for n in names[:4]]
    n = int(round(t_end / 1e-3))
    rows = np.empty((n + 1, 5))
    rows[0, :4] = s.getReal(reals)
    rows[0, 4] = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for k in range(n):
        s.setReal([vr["torque"]], [0.0])
        s.doStep(k * 1e-3, 1e-3)
        rows[k + 1, :4] = s.getReal(reals)
        rows[k + 1, 4] = s.getInteger([vr["solver.substeps"]])[0]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    s.terminate()
    s.freeInstance()
    np.save(out, rows)
    print(json.dumps({"wall": wall, "cpu": cpu}))


if __name__ == "__main__":
    main(sys.argv[1:])
