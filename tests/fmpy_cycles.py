"""Instance after instance of one FMU through fmpy's FMU2Slave, printing the resident size after each.

    python tests/fmpy_cycles.py FMU_FOLDER MODEL_IDENTIFIER CYCLES STEPS

FMU2Slave as a Python master uses it, one per instance, and no gc.collect() anywhere: each cycle
instantiates, initialises, takes STEPS doSteps of 1 ms, terminates and frees the instance, then prints
`cycle <k> <resident kB> 0` (as tests/fmi2_cycle_host.c does). Used by tests/test_fmu_memory.py and
benchmarks/instance_memory.py.
"""

import sys

from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave


def main(folder: str, identifier: str, cycles: int, steps: int) -> None:
    md = read_model_description(folder + "/modelDescription.xml")
    for k in range(cycles):
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=identifier, instanceName="cycle")
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for s in range(steps):
            fmu.doStep(currentCommunicationPoint=s * 1e-3, communicationStepSize=1e-3)
        fmu.terminate()
        fmu.freeInstance()
        with open("/proc/self/statm") as f:
            print("cycle", k, int(f.read().split()[1]) * 4, 0, flush=True)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
