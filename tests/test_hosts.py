"""The FMU in Python hosts as users run it: fmpy's command line, several runs and FMUs in one process,
an environment that lacks the FMU's packages, and a run that starts from a saved state.

Every process here must exit normally with 0: pythonfmu's binary alone made
hosts crash at exit and broke a second run in the same process (docs/fmu.md).
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import re
import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest

FMPY = str(Path(sys.executable).parent / "fmpy")
TESTS = str(Path(__file__).resolve().parent)


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", [None, "2"], ids=["fem-default", "rigid"])
def test_fmpy_command_line_exits_cleanly_every_time(fmus, tmp_path, fidelity):
    fmu, _ = fmus
    start = ["--start-values", "model.fidelity", fidelity] if fidelity else []
    codes, ends = [], []
    for k in range(20):
        out = tmp_path / f"run{k}.csv"
        run = subprocess.run(
            [FMPY, "simulate", str(fmu), "--stop-time", "0.02", "--output-file", str(out), *start],
            capture_output=True,
            text=True,
        )
        codes.append(run.returncode)
        assert run.returncode == 0, run.stderr[-3000:]
        ends.append(np.genfromtxt(out, delimiter=",", names=True)["theta"][-1])
    assert codes == [0] * 20
    assert len(set(ends)) == 1  # and every run computed the same


SEQUENCE = """
import json, sys
from pathlib import Path
from fmpy import simulate_fmu
from fem_pendulum_fmu.masters.named_slave import NamedSlave
fmu, pid = sys.argv[1], sys.argv[2]
ends = {}
for k, fidelity in enumerate((2, 3, 4, 2)):
    r = simulate_fmu(fmu, stop_time=0.01, step_size=1e-3, start_values={"model.fidelity": fidelity})
    ends[f"{k}:{fidelity}"] = float(r["theta"][-1])
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
print(json.dumps(ends))
"""


def test_every_fidelity_in_turn_then_both_fmus_in_one_process(fmus):
    """fmpy deletes each run's extraction folder; the next run, of another fidelity, still imports."""
    run = subprocess.run([sys.executable, "-c", SEQUENCE, str(fmus[0]), str(fmus[1])], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    ends = json.loads(run.stdout.strip().splitlines()[-1])
    assert list(ends) == ["0:2", "1:3", "2:4", "3:2", "loop"]
    assert ends["0:2"] == ends["3:2"]  # the same run gives the same result after the others
    assert 0.30 < ends["2:4"] < 0.35 and abs(ends["1:3"] - ends["2:4"]) < 1e-4  # released at 0.349 rad
    assert ends["loop"] != ends["0:2"]  # the controller's torque moved the pendulum


def fmpy_only_environment(folder: Path) -> Path:
    """A virtual environment holding fmpy and what it requires (linked from this one), nothing else."""
    venv.create(folder, with_pip=False)
    site = Path(
        subprocess.run(
            [str(folder / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    seen, todo = set(), [("fmpy", "")]
    while todo:
        name, marker = todo.pop()
        try:
            dist = importlib.metadata.distribution(name.replace("-", "_"))
        except importlib.metadata.PackageNotFoundError:
            assert marker, f"{name}, which fmpy needs, is not installed here"
            continue  # a requirement for another platform (e.g. pywin32)
        if dist.metadata["Name"].lower() in seen:
            continue
        seen.add(dist.metadata["Name"].lower())
        for requirement in dist.requires or []:
            if "extra ==" not in requirement:
                name = re.match(r"[A-Za-z0-9_.\-]+", requirement).group(0)
                todo.append((name, requirement.partition(";")[2]))
        for file in dist.files or []:
            top = file.parts[0]
            source, target = Path(dist.locate_file(top)), site / top
            if top != ".." and source.exists() and not target.exists():
                target.symlink_to(source)
    assert "ngsolve" not in seen and "scipy" not in seen
    return folder / "bin" / "python"


def test_missing_packages_are_named_with_the_install_command(fmus, tmp_path):
    fmu, _ = fmus
    python = fmpy_only_environment(tmp_path / "venv")
    run = subprocess.run(
        [str(python), "-m", "fmpy", "simulate", str(fmu), "--stop-time", "0.01"],
        capture_output=True,
        text=True,
        env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"},
    )
    assert run.returncode != 0
    error = [line for line in run.stdout.splitlines() if line.startswith("[ERROR]")]
    assert error, run.stdout + run.stderr[-2000:]
    assert "ngsolve is not installed" in error[0] and "scipy is not installed" in error[0]
    assert f"{python} -m pip install" in error[0] and '"ngsolve>=' in error[0]


RESTORE = """
import json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu, blob, fidelity = sys.argv[1], sys.argv[2], int(sys.argv[3])
md = read_model_description(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}
s = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier="FemPendulum", instanceName="restored")
s.instantiate()
s.setFMUstate(s.deSerializeFMUstate(open(blob, "rb").read()))  # right after fmi2Instantiate
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.setInteger([vr["model.fidelity"]], [fidelity])  # the value the state was taken with: accepted
s.exitInitializationMode()
rows = []
for k in range(10):
    s.setReal([vr["torque"]], [-0.3])
    s.doStep(0.005 + k * 1e-3, 1e-3)
    rows.append(s.getReal([vr["theta"], vr["omega"], vr["gap"], vr["energy.total"]]))
s.terminate()
s.freeInstance()
print(json.dumps(rows))
"""

ORIGINAL = """
import json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu, blob, fidelity = sys.argv[1], sys.argv[2], int(sys.argv[3])
md = read_model_description(fmu)
vr = {v.name: v.valueReference for v in md.modelVariables}
s = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier="FemPendulum", instanceName="original")
s.instantiate()
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.setInteger([vr["model.fidelity"]], [fidelity])
s.setReal([vr["model.mesh_size"]], [0.06])
s.exitInitializationMode()
for k in range(5):
    s.doStep(k * 1e-3, 1e-3)
open(blob, "wb").write(bytes(s.serializeFMUstate(s.getFMUstate())))
rows = []
for k in range(10):
    s.setReal([vr["torque"]], [-0.3])
    s.doStep(0.005 + k * 1e-3, 1e-3)
    rows.append(s.getReal([vr["theta"], vr["omega"], vr["gap"], vr["energy.total"]]))
s.terminate()
s.freeInstance()
print(json.dumps(rows))
"""


@pytest.mark.parametrize("fidelity", [4, 2], ids=["fem", "rigid"])
def test_a_fresh_instance_started_from_a_saved_state_continues_bit_identically(fmus, tmp_path, fidelity):
    fmu, _ = fmus
    blob = tmp_path / "state.bin"
    runs = [
        subprocess.run(
            [sys.executable, "-c", script, str(fmu), str(blob), str(fidelity)], capture_output=True, text=True
        )
        for script in (ORIGINAL, RESTORE)
    ]
    for run in runs:
        assert run.returncode == 0, run.stderr[-3000:]
    original, restored = (json.loads(run.stdout.strip().splitlines()[-1]) for run in runs)
    assert restored == original
    assert original[0] != original[-1]  # it moved


MISUSE = """
import ctypes, json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu = sys.argv[1]
md = read_model_description(fmu)
folder = extract(fmu)
s = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="FemPendulum", instanceName="misuse")
s.instantiate()
s.setupExperiment(startTime=0.0)
s.enterInitializationMode()
s.setInteger([md.modelVariables[[v.name for v in md.modelVariables].index("model.fidelity")].valueReference], [2])
s.exitInitializationMode()
raw = ctypes.CDLL(f"{folder}/binaries/linux64/FemPendulum.so")  # fresh function objects: no argtypes
c = ctypes.c_void_p(s.component)
state = s.getFMUstate()
codes = {
    "set_bogus": raw.fmi2SetFMUstate(c, ctypes.c_void_p(0x1234)),
    "free_state_itself": raw.fmi2FreeFMUstate(c, ctypes.c_void_p(state.value)),  # the address is due
    "set_freed": raw.fmi2SetFMUstate(c, ctypes.c_void_p(state.value)),
    "free_null": raw.fmi2FreeFMUstate(c, None),
}
kept = s.getFMUstate()
left = s.getFMUstate()  # never freed: fmi2FreeInstance frees it
s.doStep(0.0, 1e-3)
s.setFMUstate(kept)
codes["restore_kept"] = 0
pointer = ctypes.c_void_p(kept.value)
codes["free_kept"] = raw.fmi2FreeFMUstate(c, ctypes.byref(pointer))
codes["freed_pointer_is_null"] = pointer.value is None
s.terminate()
s.freeInstance()
print(json.dumps(codes))
"""


def test_fmu_states_a_host_gets_wrong_are_refused_not_dereferenced(fmus):
    """fmi2OK 0, fmi2Error 3: a state the FMU never handed out is refused; the state passed where its
    address is due (a host bug that crashed pythonfmu's binary) is freed; a freed pointer reads NULL."""
    run = subprocess.run([sys.executable, "-c", MISUSE, str(fmus[0])], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    codes = json.loads(run.stdout.strip().splitlines()[-1])
    assert codes == {
        "set_bogus": 3,
        "free_state_itself": 0,
        "set_freed": 3,
        "free_null": 0,
        "restore_kept": 0,
        "free_kept": 0,
        "freed_pointer_is_null": True,
    }
