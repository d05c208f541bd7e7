"""Runs of tests/test_ecos_host.py, each in a fresh interpreter that must exit normally with 0.

    python tests/ecos_runs.py fmpy OUT FMU STEPS NAME=VALUE...
    python tests/ecos_runs.py api OUT FMU STEPS NAME=VALUE...
    python tests/ecos_runs.py pair OUT FMU STEPS
    python tests/ecos_runs.py reset OUT FMU STEPS NAME=VALUE...

`fmpy` steps the FMU with fmpy's FMU2Slave through the calls ecos makes (FMI 2.0: setupExperiment at 0
without stop time or tolerance, the parameters in initialization mode, doStep(t, h) with t advanced by
t + h); `api` runs it through ecos's Python API (ecospy: ctypes on ecos's C API, libecosc.so); `pair` runs
two instances of the FMU in one ecos simulation, rigid and fem, which ecos steps in parallel; `reset` runs
the FMU twice in one ecos simulation, reset (fmi2Reset) and initialised again in between. NAME=VALUE
sets a parameter of the FMU (an Integer or a Real, as its modelDescription declares). Each writes one JSON
document to OUT: theta after every step of 1 ms (per instance for `pair`). ecos logs to standard output at
debug level, where the FMU's messages arrive as `[instance] fmi2Status message`.
"""

from __future__ import annotations

import json
import shutil
import sys
import threading
from pathlib import Path

from fmpy import read_model_description

STEP = 1e-3


def parameters(fmu: str, pairs: list[str]) -> dict[str, int | float]:
    """NAME=VALUE pairs typed as the modelDescription declares the variables."""
    types = {v.name: v.type for v in read_model_description(fmu).modelVariables}
    values: dict[str, int | float] = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        assert types[name] in ("Integer", "Real"), f"{name} is a {types[name]}"
        values[name] = int(value) if types[name] == "Integer" else float(value)
    return values


def fmpy_run(fmu: str, steps: str, *pairs: str) -> dict:
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    folder = extract(fmu)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="FemPendulum", instanceName="ref")
    slave.instantiate(visible=False, loggingOn=False)
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for name, value in parameters(fmu, list(pairs)).items():
        if isinstance(value, int):
            slave.setInteger([vr[name]], [value])
        else:
            slave.setReal([vr[name]], [value])
    slave.exitInitializationMode()
    t, theta = 0.0, []
    for _ in range(int(steps)):
        slave.doStep(t, STEP)
        t += STEP
        theta.append(slave.getReal([vr["theta"]])[0])
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(folder, ignore_errors=True)
    return {"theta": theta}


def simulate(instances: dict[str, dict[str, int | float]], fmu: str, steps: str) -> dict:
    """The instances (name: parameters) in one ecos simulation of `steps` steps of 1 ms."""
    from ecospy import EcosLib, EcosSimulation, EcosSimulationStructure

    EcosLib.set_log_level("debug")
    theta: dict[str, list[float]] = {name: [] for name in instances}
    with EcosSimulationStructure() as structure:
        for name in instances:
            structure.add_model(name, fmu)
        structure.add_parameter_set(
            "run", {f"{name}::{key}": value for name, values in instances.items() for key, value in values.items()}
        )
        with EcosSimulation(structure=structure, step_size=STEP) as sim:
            threads = record_threads()
            initialised = sim.init(parameter_set="run")
            fidelity = {name: sim.get_integer(f"{name}::model.fidelity_index") for name in instances}
            enumeration = readable(sim, f"{next(iter(instances))}::model.fidelity")
            times = []
            for _ in range(int(steps)):
                times.append(sim.step())
                for name in instances:
                    theta[name].append(sim.get_real(f"{name}::theta"))
            sim.terminate()
    return {
        "init": initialised,
        "fidelity_index": fidelity,
        "enumeration_readable": enumeration,
        "times": times,
        "theta": theta,
        "threads": {"main": threading.get_ident(), "do_step": threads},
    }


def readable(sim, identifier: str) -> bool:
    """Whether ecos knows the Integer-typed variable `identifier` (it drops Enumeration variables)."""
    try:
        sim.get_integer(identifier)
    except Exception:
        return False
    return True


def record_threads() -> list[int]:
    """The threads that will call the slave's do_step. The FMU's entry module (femp_slave_entry,
    fem_pendulum_fmu/fmi/builder.py) is imported into this interpreter when ecos instantiates the FMU;
    its class's do_step is wrapped to note the calling thread, and otherwise called as it is."""
    entry = sys.modules["femp_slave_entry"].FemPendulum
    seen: list[int] = []
    do_step = entry.do_step

    def noted(self, *args):
        seen.append(threading.get_ident())
        return do_step(self, *args)

    entry.do_step = noted
    return seen


def api_run(fmu: str, steps: str, *pairs: str) -> dict:
    return simulate({"pendulum": parameters(fmu, list(pairs))}, fmu, steps)


def pair_run(fmu: str, steps: str) -> dict:
    rigid = {"model.fidelity_index": 2}
    fem = {"model.fidelity_index": 4, "model.mesh_size": 0.06}
    return simulate({"rigid": rigid, "fem": fem}, fmu, steps)


def reset_run(fmu: str, steps: str, *pairs: str) -> dict:
    from ecospy import EcosLib, EcosSimulation, EcosSimulationStructure

    EcosLib.set_log_level("debug")
    passes: list[list[float]] = []
    with EcosSimulationStructure() as structure:
        structure.add_model("pendulum", fmu)
        structure.add_parameter_set("run", {f"pendulum::{k}": v for k, v in parameters(fmu, list(pairs)).items()})
        with EcosSimulation(structure=structure, step_size=STEP) as sim:
            for k in range(2):
                if k:
                    sim.reset()
                sim.init(parameter_set="run")
                passes.append([])
                for _ in range(int(steps)):
                    sim.step()
                    passes[-1].append(sim.get_real("pendulum::theta"))
            sim.terminate()
    return {"theta": passes}


if __name__ == "__main__":
    verbs = {"fmpy": fmpy_run, "api": api_run, "pair": pair_run, "reset": reset_run}
    Path(sys.argv[2]).write_text(json.dumps(verbs[sys.argv[1]](*sys.argv[3:])))
