"""One timed run of benchmarks/rigid_floor.py, in a fresh process that imports nothing of the package.

    python benchmarks/rigid_floor_driver.py FMU MODEL_IDENTIFIER STOP STEP INTEGERS_JSON [count]

fmpy's FMU2Slave: instantiate, the Integer start values INTEGERS_JSON, initialise, then every STEP until
STOP: set the torque (0), doStep, getReal of all Real outputs. Prints one JSON line: CPU, wall and the
stepping thread's CPU time of the loop, the number of Real outputs and the last theta. With "count" the
same calls run inside functools.reduce, which callgrind collects alone (--toggle-collect).
"""

from __future__ import annotations

import functools
import json
import sys
import time

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


def main(argv: list[str]) -> None:
    fmu, identifier, stop, step = argv[0], argv[1], float(argv[2]), float(argv[3])
    integers = json.loads(argv[4])
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier=identifier, instanceName="floor")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    for name, value in integers.items():
        s.setInteger([vr[name]], [value])
    s.exitInitializationMode()
    n = round(stop / step)
    torque = [vr["torque"]]
    t = 0.0
    c0, w0, h0 = time.process_time(), time.perf_counter(), time.thread_time()
    if argv[5:] == ["count"]:  # the same calls inside functools.reduce, which callgrind collects alone

        def one(_, k):
            s.setReal(torque, [0.0])
            s.doStep(k * step, step)
            return s.getReal(outs)

        values = functools.reduce(one, range(n), None)
    else:
        for k in range(n):
            s.setReal(torque, [0.0])
            s.doStep(t, step)
            t = (k + 1) * step
            values = s.getReal(outs)
    cpu, wall, thread = time.process_time() - c0, time.perf_counter() - w0, time.thread_time() - h0
    s.terminate()
    s.freeInstance()
    theta = values[outs.index(vr["theta"])]
    print(json.dumps({"cpu": cpu, "wall": wall, "thread": thread, "outputs": len(outs), "theta": theta}))


if __name__ == "__main__":
    main(sys.argv[1:])
