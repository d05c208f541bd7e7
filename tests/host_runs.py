"""Python host runs of tests/test_hosts.py, each in a fresh interpreter that must exit normally with 0.

    python tests/host_runs.py sequence FMU PID
    python tests/host_runs.py original FMU STATE_FILE FIDELITY
    python tests/host_runs.py restored FMU STATE_FILE FIDELITY
    python tests/host_runs.py misuse FMU
    python tests/host_runs.py foreign FMU FOLDER same|changed

Each prints one JSON line: what the test compares.
"""

from __future__ import annotations

import atexit
import ctypes
import json
import shutil
import sys
from pathlib import Path
from typing import Any

from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

OUTPUTS = ("theta", "omega", "gap", "energy.total")


def sequence(fmu: str, pid: str) -> dict[str, float]:
    """simulate_fmu with rigid, reduced, fem and rigid again (fmpy deletes each extraction folder),
    then the pendulum and the PID FMU side by side for 10 steps."""
    from fem_pendulum_fmu.masters.named_slave import NamedSlave  # here: `foreign` must import its own copy

    ends = {}
    for k, fidelity in enumerate((2, 3, 4, 2)):
        result = simulate_fmu(fmu, stop_time=0.01, step_size=1e-3, start_values={"model.fidelity": fidelity})
        ends[f"{k}:{fidelity}"] = float(result["theta"][-1])
    pendulum = NamedSlave(Path(fmu), "pendulum", {"model.fidelity": 2})
    controller = NamedSlave(Path(pid), "pid", {})
    for k in range(10):
        controller.set("setpoint", 0.1)
        controller.set("measurement", pendulum.get("theta")[0])
        controller.fmu.doStep(k * 1e-3, 1e-3)
        pendulum.set("torque", controller.get("u")[0])
        pendulum.fmu.doStep(k * 1e-3, 1e-3)
    ends["loop"] = pendulum.get("theta")[0]
    pendulum.close()
    controller.close()
    return ends


def instance(fmu: str, name: str) -> tuple[FMU2Slave, dict[str, int], str]:
    """An instantiated FMU2Slave, the value references by name and the extraction folder."""
    md = read_model_description(fmu)
    folder = extract(fmu)
    atexit.register(shutil.rmtree, folder, True)  # this child process's extraction folder, when it ends
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="FemPendulum", instanceName=name)
    slave.instantiate()
    return slave, {v.name: v.valueReference for v in md.modelVariables}, folder


def ten_steps_from_5_ms(slave: FMU2Slave, vr: dict[str, int]) -> list[list[float]]:
    rows = []
    for k in range(10):
        slave.setReal([vr["torque"]], [-0.3])
        slave.doStep(0.005 + k * 1e-3, 1e-3)
        rows.append(slave.getReal([vr[name] for name in OUTPUTS]))
    slave.terminate()
    slave.freeInstance()
    return rows


def original(fmu: str, state_file: str, fidelity: str) -> list[list[float]]:
    """Five steps, the state serialised to `state_file`, then ten steps more."""
    slave, vr, _ = instance(fmu, "original")
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["model.fidelity"]], [int(fidelity)])
    slave.setReal([vr["model.mesh_size"]], [0.06])
    slave.exitInitializationMode()
    for k in range(5):
        slave.doStep(k * 1e-3, 1e-3)
    Path(state_file).write_bytes(bytes(slave.serializeFMUstate(slave.getFMUstate())))
    return ten_steps_from_5_ms(slave, vr)


def restored(fmu: str, state_file: str, fidelity: str) -> list[list[float]]:
    """A fresh instance set to the saved state right after fmi2Instantiate, which puts it in stepComplete
    (docs/reference/fmi2.md, "Setting an FMU state"), then the same ten steps, never initialised."""
    slave, vr, _ = instance(fmu, "restored")
    slave.setInteger([vr["model.fidelity"]], [1 if int(fidelity) != 1 else 2])  # replaced by the state's
    slave.setFMUstate(slave.deSerializeFMUstate(Path(state_file).read_bytes()))
    return ten_steps_from_5_ms(slave, vr)


def misuse(fmu: str) -> dict[str, Any]:
    """FMU states a host gets wrong, through the binary's functions without fmpy's argument types."""
    slave, vr, folder = instance(fmu, "misuse")
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["model.fidelity"]], [2])
    slave.exitInitializationMode()
    raw = ctypes.CDLL(f"{folder}/binaries/linux64/FemPendulum.so")  # fresh function objects: no argtypes
    component = ctypes.c_void_p(slave.component)
    state = slave.getFMUstate()
    codes: dict[str, Any] = {
        "set_bogus": raw.fmi2SetFMUstate(component, ctypes.c_void_p(0x1234)),
        "free_state_itself": raw.fmi2FreeFMUstate(component, ctypes.c_void_p(state.value)),  # the address is due
        "set_freed": raw.fmi2SetFMUstate(component, ctypes.c_void_p(state.value)),
        "free_null": raw.fmi2FreeFMUstate(component, None),
    }
    kept = slave.getFMUstate()
    slave.getFMUstate()  # never freed: fmi2FreeInstance frees it
    slave.doStep(0.0, 1e-3)
    slave.setFMUstate(kept)
    pointer = ctypes.c_void_p(kept.value)
    codes["free_kept"] = raw.fmi2FreeFMUstate(component, ctypes.byref(pointer))
    codes["freed_pointer_is_null"] = pointer.value is None
    slave.terminate()
    slave.freeInstance()
    return codes


def foreign(fmu: str, folder: str, kind: str) -> dict[str, Any]:
    """The FMU instantiated after this process imported another copy of fem_pendulum_fmu: the FMU's own
    files copied to `folder` ("same"), or with one line added to physics/scene.py ("changed")."""
    shipped = Path(extract(fmu)) / "resources" / "fem_pendulum_fmu"
    copy = Path(folder) / "fem_pendulum_fmu"
    shutil.copytree(shipped, copy)
    shutil.rmtree(shipped.parent.parent, True)
    if kind == "changed":
        scene = copy / "physics" / "scene.py"
        scene.write_text(scene.read_text() + "\nCHANGED_HERE = True\n")
    sys.path.insert(0, folder)
    import fem_pendulum_fmu.physics.scene  # noqa: F401  (the host's own copy, imported first)

    try:
        slave, vr, _ = instance(fmu, "foreign")
    except Exception as exc:  # fmpy's: fmi2Instantiate returned NULL
        return {"instantiated": False, "error": str(exc)}
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.setInteger([vr["model.fidelity"]], [2])
    slave.exitInitializationMode()
    slave.doStep(0.0, 1e-3)
    theta = slave.getReal([vr["theta"]])[0]
    slave.terminate()
    slave.freeInstance()
    return {"instantiated": True, "theta": theta}


if __name__ == "__main__":
    verbs = {"sequence": sequence, "original": original, "restored": restored, "misuse": misuse, "foreign": foreign}
    print(json.dumps(verbs[sys.argv[1]](*sys.argv[2:])))
