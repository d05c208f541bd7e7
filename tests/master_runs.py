"""Runs of the FMU by a master, each in a fresh interpreter, that tests compare with other hosts' runs.

    python tests/master_runs.py libcosim FMU OUT_JSON
        libcosim (libcosimpy) steps the pendulum 300 ms under a sine torque; the outputs after each step
        written to OUT_JSON (tests/test_fmu.py)
    python tests/master_runs.py simulate FMU
        fmpy's simulate_fmu, rigid, 0.3 s in 1 ms steps: one line "time theta" per step (tests/test_c_host.py)
    python tests/master_runs.py loop FMU PID_FMU START_VALUES_JSON
        the package's controller loop (PID FMU, drive, pendulum FMU) for 2 s: one JSON line of what
        tests/test_controller.py checks

Each run imports only what its master needs, when it starts: nothing of the package before the FMU loads
it, except the controller loop, which is the package's.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path


def libcosim(fmu: str, out: str) -> None:
    from fmpy import read_model_description
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    vr = {v.name: v.valueReference for v in read_model_description(fmu).modelVariables}
    ex = CosimExecution.from_step_size(step_size=1_000_000)  # 1 ms in ns
    idx = ex.add_local_slave(local_slave=CosimLocalSlave(fmu_path=fmu, instance_name="pendulum"))
    ex.real_initial_value(idx, vr["model.mesh_size"], 0.06)
    ex.integer_initial_value(idx, vr["wall.kind_index"], 1)  # libcosim ignores enumerations: the Integer alias
    observer = CosimObserver.create_last_value()
    ex.add_observer(observer)
    override = CosimManipulator.create_override()
    ex.add_manipulator(override)
    outs = [vr[n] for n in ("theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work")]
    rows = []
    for k in range(300):
        override.slave_real_values(idx, [vr["torque"]], [-2.0 * math.sin(10.0 * k * 1e-3)])
        ex.step()
        rows.append(list(observer.last_real_values(idx, outs)))
    Path(out).write_text(json.dumps(rows))


def simulate(fmu: str) -> None:
    from fmpy import simulate_fmu

    r = simulate_fmu(fmu, stop_time=0.3, step_size=1e-3, output_interval=1e-3, start_values={"model.fidelity": 2})
    for t, theta in zip(r["time"][1:], r["theta"][1:], strict=True):
        print(repr(float(t)), repr(float(theta)))


def loop(fmu: str, pid: str, start_values: str) -> None:
    import numpy as np

    from fem_pendulum_fmu.masters.control.command import DEFAULT_SETPOINT
    from fem_pendulum_fmu.masters.control.controllers import controller_fmu
    from fem_pendulum_fmu.masters.control.figure import wall_impacts
    from fem_pendulum_fmu.masters.control.loop import LoopInputs, run_loop
    from fem_pendulum_fmu.masters.control.signals import parse_signal

    setpoint = parse_signal(DEFAULT_SETPOINT, "angle", "--setpoint")
    inputs = LoopInputs(Path(fmu), setpoint, start_values=json.loads(start_values), progress=False)
    loop = run_loop(inputs, controller_fmu(Path(pid)).open())
    assert loop.stopped is None, loop.stopped
    r = loop.table
    away = r["setpoint"] > 0  # the half-periods that swing away from the wall
    result = {
        "rms_away": float(np.sqrt(np.mean((r["setpoint"][away] - r["theta"][away]) ** 2))),
        "impacts": wall_impacts(r).tolist(),
        **{k: r[k].tolist() for k in ("time", "theta", "gap", "torque", "setpoint")},
        "balance": (r["energy.total"] - r["energy.total"][0] - r["energy.torque_work"]).tolist(),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    verbs: dict[str, Callable[..., None]] = {"libcosim": libcosim, "simulate": simulate, "loop": loop}
    verbs[sys.argv[1]](*sys.argv[2:])
