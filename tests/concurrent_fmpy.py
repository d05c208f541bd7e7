"""fmpy's FMU2Slave or FMU3Slave instances on Python threads at once, against the same instances one after another
(tests/test_concurrent_instances.py runs it in a child process, as tests/concurrent_host.c runs natively).

    python concurrent_fmpy.py FMU FMI_VERSION STEPS ROUNDS SPEC...

SPEC is "fidelity:theta0" (model.fidelity's item). Each instance: instantiate, set the fidelity and theta0,
initialise, STEPS steps of 1 ms reading theta, omega and gap after each, a rollback of three steps halfway
(get the FMU state, step, set it back), terminate, free. A round starts all instances at once (a barrier
before instantiation); after the first, the same instances run one after another: the reference. Prints a
line per instance and round and "rounds: R, instances differing from the sequential run: N"; exits 1 if N > 0.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass, field

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

OUTPUTS = ("theta", "omega", "gap")


@dataclass
class Run:
    fidelity: int
    theta0: float
    values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    failure: str = ""  # the call that did not answer OK, and where


class Fmu:
    """One FMU unzipped once, its instances made by fmpy's classes for its FMI version."""

    def __init__(self, path: str, version: int):
        self.description = read_model_description(path)
        self.folder = extract(path)
        self.version = version
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}

    def instance(self, name: str) -> FMU2Slave | FMU3Slave:
        kind = FMU3Slave if self.version == 3 else FMU2Slave
        token = self.description.instantiationToken if self.version == 3 else self.description.guid
        model = self.description.coSimulation.modelIdentifier
        return kind(guid=token, unzipDirectory=self.folder, modelIdentifier=model, instanceName=name)


def initialise(fmu: Fmu, slave: FMU2Slave | FMU3Slave, run: Run) -> None:
    slave.instantiate()
    vr = fmu.vr
    if fmu.version == 3:
        slave.enterInitializationMode(startTime=0.0)
        slave.setInt64([vr["model.fidelity"]], [run.fidelity])
        slave.setFloat64([vr["theta0"]], [run.theta0])
    else:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.setInteger([vr["model.fidelity"]], [run.fidelity])
        slave.setReal([vr["theta0"]], [run.theta0])
    slave.exitInitializationMode()


def stepped(fmu: Fmu, slave: FMU2Slave | FMU3Slave, steps: int) -> np.ndarray:
    """The outputs after each of `steps` steps of 1 ms, with the rollback of three steps halfway."""
    refs = [fmu.vr[name] for name in OUTPUTS]
    read = slave.getFloat64 if fmu.version == 3 else slave.getReal
    values = np.zeros((steps, len(OUTPUTS)))
    for k in range(steps):
        if k == steps // 2:
            saved = slave.getFMUState() if fmu.version == 3 else slave.getFMUstate()
            for extra in range(3):
                slave.doStep(currentCommunicationPoint=(k + extra) * 1e-3, communicationStepSize=1e-3)
            (slave.setFMUState if fmu.version == 3 else slave.setFMUstate)(saved)
            (slave.freeFMUState if fmu.version == 3 else slave.freeFMUstate)(saved)
        slave.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
        values[k] = read(refs)
    return values


def life(fmu: Fmu, run: Run, name: str, steps: int, start_line: threading.Barrier | None = None) -> None:
    if start_line is not None:
        start_line.wait()
    slave = fmu.instance(name)
    run.failure, run.values = "", np.zeros(0)
    try:
        initialise(fmu, slave, run)
        run.values = stepped(fmu, slave, steps)
        slave.terminate()
    except Exception as exc:  # fmpy raises for a status other than OK: that is the result to compare
        run.failure = f"{type(exc).__name__}: {exc}"
    finally:
        slave.freeInstance()


def concurrent_round(fmu: Fmu, runs: list[Run], steps: int) -> None:
    start_line = threading.Barrier(len(runs))
    threads = [
        threading.Thread(target=life, args=(fmu, run, f"together{i}", steps, start_line)) for i, run in enumerate(runs)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()


def compare_round(round_nr: int, runs: list[Run], alone: list[Run]) -> int:
    differing = 0
    for i, (run, ref) in enumerate(zip(runs, alone, strict=True)):
        same = not run.failure and not ref.failure and np.array_equal(run.values, ref.values)
        verdict = "same" if same else f"DIFFERENT ({run.failure or ref.failure or 'values'})"
        print(f"round {round_nr} instance {i} fidelity {run.fidelity}: {verdict}", flush=True)
        differing += not same
    return differing


def main(argv: list[str]) -> int:
    path, version, steps, rounds, *specs = argv
    fmu = Fmu(path, int(version))
    parsed = [(int(f), float(t)) for f, t in (spec.split(":") for spec in specs)]
    runs, alone = [Run(*p) for p in parsed], [Run(*p) for p in parsed]
    differing = 0
    for round_nr in range(int(rounds)):
        concurrent_round(fmu, runs, int(steps))
        if round_nr == 0:
            for i, ref in enumerate(alone):
                life(fmu, ref, f"alone{i}", int(steps))
        differing += compare_round(round_nr, runs, alone)
    print(f"rounds: {rounds}, instances differing from the sequential run: {differing}")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
