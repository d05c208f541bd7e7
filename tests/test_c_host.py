"""A C host (examples/c_host/fmi2_host.c) runs the FMU with the environment fem-pendulum-host-env prints."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import fmpy
import numpy as np
from fmpy import extract, read_model_description

from fem_pendulum_fmu.host_env import host_environment

ROOT = Path(__file__).resolve().parents[1]

FMPY_RUN = """
import sys
from fmpy import simulate_fmu
r = simulate_fmu(sys.argv[1], stop_time=0.3, step_size=1e-3, output_interval=1e-3, start_values={"model.fidelity": 2})
for t, theta in zip(r["time"][1:], r["theta"][1:]):
    print(repr(float(t)), repr(float(theta)))
import os; sys.stdout.flush(); os._exit(0)
"""


def test_c_host_with_the_printed_environment_matches_fmpy(fmus, tmp_path):
    fmu, _ = fmus
    host = tmp_path / "fmi2_host"
    headers = Path(fmpy.__file__).parent / "c-code"
    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the FMU's status shim and this host"
    subprocess.run([compiler, "-O1", f"-I{headers}", str(ROOT / "examples" / "c_host" / "fmi2_host.c"), "-ldl",
                    "-o", str(host)], check=True)
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    folder = extract(str(fmu), unzipdir=str(tmp_path / "fmu"))
    args = [str(host), folder, md.guid, "300", str(vr["model.fidelity"]), str(vr["theta"])]

    clean = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "LD_PRELOAD"))}
    clean["PATH"] = os.defpath
    bare = subprocess.run(args, env=clean, capture_output=True, text=True, timeout=120)
    assert bare.returncode == 3 and "host environment" in bare.stderr  # without it: refused, no crash

    env = {**clean, **{k: v.replace("$PATH", clean["PATH"]) for k, v in host_environment().items()}}
    run = subprocess.run(args, env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    lines = run.stdout.split("\n")
    assert "nan-torque-status 3" in lines  # fmi2Error, as through fmpy
    assert "initialised RigidModel" in run.stderr  # the FMI logger callback got the package's log
    c_rows = np.array([[float(x) for x in line.split()] for line in lines if line and not line.startswith("nan")])

    ref = subprocess.run([sys.executable, "-c", FMPY_RUN, str(fmu)], capture_output=True, text=True, check=True)
    fmpy_rows = np.array([[float(x) for x in line.split()] for line in ref.stdout.split("\n") if line])
    assert c_rows.shape == fmpy_rows.shape == (300, 2)
    assert np.min(c_rows[:, 1]) < 0.01  # it swung down to the wall in 0.3 s
    assert np.max(np.abs(c_rows - fmpy_rows)) <= 1e-12
