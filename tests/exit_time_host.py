"""The Python host of tests/test_exit_time_host.py: its C library (tests/exit_time_host.c, compiled by the test)
holds FMU instances and frees them at exit, after this interpreter has been finalised.

    python tests/exit_time_host.py LIBRARY MODE PENDULUM_FOLDER PENDULUM_GUID PID_FOLDER PID_GUID VR_FIDELITY FIDELITY

the library starts one instance of each FMU with its own C logger; prints "started" and what
exit_time_host_start returned (0: both instances initialised and stepped).

    python tests/exit_time_host.py --fmpy LIBRARY MODE FMI_VERSION PENDULUM_FOLDER FIDELITY

fmpy's FMU2Slave or FMU3Slave (FMI_VERSION 2 or 3) instantiates the unzipped pendulum with fmpy's own logger
(a ctypes callback into Python, printing to stdout), initialises it with model.fidelity = FIDELITY, steps it
10 times 1 ms and is refused one doStep at a wrong communication point, so that one message went through that
logger; the library holds the instance. Prints "started 0".

Either form then ends normally; the library's exit-time handler (MODE) prints its line to stderr.
"""

from __future__ import annotations

import ctypes
import sys

from fmpy import read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

KEPT: list[object] = []  # fmpy's slave stays referenced until the interpreter is finalised, as a host's would


def main(argv: list[str]) -> None:
    library, mode, pendulum, pendulum_guid, pid, pid_guid, vr_fidelity, fidelity = argv
    lib = ctypes.CDLL(library)
    lib.exit_time_host_start.argtypes = [ctypes.c_char_p] * 5 + [ctypes.c_int, ctypes.c_int]
    names = [a.encode() for a in (mode, pendulum, pendulum_guid, pid, pid_guid)]
    print("started", lib.exit_time_host_start(*names, int(vr_fidelity), int(fidelity)), flush=True)


def start_with_fmpy(fmi_version: str, folder: str, fidelity: int) -> tuple[str, object]:
    """The instance's label and fmpy's slave, instantiated with fmpy's logger, initialised and stepped."""
    description = read_model_description(folder)
    label = description.coSimulation.modelIdentifier
    vr = {v.name: v.valueReference for v in description.modelVariables}["model.fidelity"]
    kind = FMU2Slave if fmi_version == "2" else FMU3Slave
    fmu = kind(guid=description.guid, unzipDirectory=folder, modelIdentifier=label, instanceName=label)
    fmu.instantiate()  # fmpy's own logger callback
    if fmi_version == "2":
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setInteger([vr], [fidelity])
    else:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.setInt64([vr], [fidelity])  # an Enumeration, FMI 3.0's rule
    fmu.exitInitializationMode()
    for k in range(10):
        fmu.doStep(k * 1e-3, 1e-3)
    try:
        fmu.doStep(1.0, 1e-3)  # refused: the FMU's time is 0.01 s; its message goes through fmpy's logger
    except FMICallException:
        pass
    return label, fmu


def main_fmpy(argv: list[str]) -> None:
    library, mode, fmi_version, folder, fidelity = argv
    lib = ctypes.CDLL(library)
    lib.exit_time_host_begin.argtypes = [ctypes.c_char_p]
    lib.exit_time_host_hold.argtypes = [ctypes.c_char_p] + [ctypes.c_void_p] * 3
    if lib.exit_time_host_begin(mode.encode()) != 0:
        raise SystemExit(f"unknown mode {mode}")
    label, fmu = start_with_fmpy(fmi_version, folder, int(fidelity))
    functions = (getattr(fmu.dll, f"fmi{fmi_version}{name}") for name in ("Terminate", "FreeInstance"))
    terminate, free = (ctypes.cast(function, ctypes.c_void_p) for function in functions)
    KEPT.append(fmu)
    print("started", lib.exit_time_host_hold(label.encode(), fmu.component, terminate, free), flush=True)
    lib.exit_time_host_end()


if __name__ == "__main__":
    if sys.argv[1:2] == ["--fmpy"]:
        main_fmpy(sys.argv[2:])
    else:
        main(sys.argv[1:])
