"""The runs of benchmarks/robustness.py, each in a fresh process (one model or FMU, a clean peak RSS).

    python benchmarks/robustness_runs.py memory MESH_SIZE ORDER
        peak resident memory growth of building the FE model and one step (cache off): one JSON line
    python benchmarks/robustness_runs.py finding WHAT [ARG]
        one measurement behind the findings of docs/notes/robustness.md (WHAT: gauss-violent, gauss-rubber,
        gauss-default with ARG Gauss points; quadrature with ARG a variant; resting-tolerance;
        penetration; sequence): JSON lines
    python benchmarks/robustness_runs.py leak FMU KIND
        resident memory over 61 instances of KIND (mesh, nu: refused at initialisation; valid), each freed

Each run imports the package when it starts, after what it patches (the Gauss points) is in place; the leak
run imports only tests/test_fmu.py's Instance (fmpy), as a host would.
"""

from __future__ import annotations

import json
import math
import os
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def memory(h_text: str, p_text: str) -> None:
    os.environ["FEM_PENDULUM_CACHE"] = "off"
    from fem_pendulum_fmu.physics.fem.model import FemModel
    from fem_pendulum_fmu.physics.scene import estimated_unknowns, mesh_memory_estimate, steel

    h, p = float(h_text), int(p_text)
    scene = steel(**{"model.mesh_size": h, "model.order": p, "theta0": 0.05})
    r0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    m = FemModel(scene)
    m.advance(2e-3, 0.0)
    r1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    row = [h, p, m.X.ndof, estimated_unknowns(scene), (r1 - r0) / 1024, mesh_memory_estimate(scene) / 2**20]
    print(json.dumps([*row, time.perf_counter() - t0]))


def worst(model, schedule):
    """The worst |E - E0 - W| over the schedule [(t, torque), ...], the last outputs and the seconds taken."""
    e0, w, t0 = model.outputs().energy_total, 0.0, time.perf_counter()
    for t, torque in schedule:
        out = model.advance(t, torque)
        w = max(w, abs(out.energy_total - e0 - out.energy_torque_work))
    return w, out, time.perf_counter() - t0


def gauss(what: str, n: int) -> None:
    """The discrete gradient's stress with n Gauss points."""
    import fem_pendulum_fmu.physics.material as material

    original = material.averaged_pk2_stress
    material.averaged_pk2_stress = lambda C0, C1, lame_lambda, mu, points: original(C0, C1, lame_lambda, mu, n)
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import rubber, steel

    if what == "gauss-violent":  # steel, +-50 N.m square wave (0.15 s each way), 0.18 s: the back-face impact
        m = create(steel(**{"model.mesh_size": 0.06, "theta0": 0.0}))
        sched = [(k * 1e-3, 50.0 if ((k - 1) // 150) % 2 == 0 else -50.0) for k in range(1, 181)]
        w, out, secs = worst(m, sched)
        print(json.dumps({"case": what, "points": n, "worst_J": w, "work_J": out.energy_torque_work, "s": secs}))
    elif what == "gauss-rubber":  # rubber, 2 N.m for 1 ms, then 39 ms free
        m = create(rubber(**{"model.mesh_size": 0.06, "theta0": 0.0}))
        w, out, secs = worst(m, [(k * 1e-3, 2.0 if k == 1 else 0.0) for k in range(1, 41)])
        print(json.dumps({"case": what, "points": n, "worst_J": w, "work_J": out.energy_torque_work, "s": secs}))
    elif what == "gauss-default":  # the default scene released at 20 degrees, 0.5 s in 1 ms steps
        m = create(steel())
        w, out, secs = worst(m, [(k * 1e-3, 0.0) for k in range(1, 501)])
        print(json.dumps({"case": what, "points": n, "worst_J": w, "s": secs}))


def quadrature(variant: str) -> None:
    """Rubber (order 3), 2 N.m held in 0.1 ms steps: the energy guard, and the rules used before."""
    from ngsolve import BND

    import fem_pendulum_fmu.physics.fem.model as fem
    import fem_pendulum_fmu.physics.fem.outputs as fem_outputs
    from fem_pendulum_fmu.physics.fidelity import StepFailed, create
    from fem_pendulum_fmu.physics.scene import rubber

    what = "quadrature"
    integrate = fem_outputs.Integrate
    if variant != "guard":
        fem.STEP_ENERGY_TOLERANCE = math.inf

    def patched(cf, mesh, *args, **kwargs):
        if variant == "no-guard-old-torque-rule" and args and args[0] is BND and kwargs.get("order") == 8:
            kwargs.pop("order", None)  # the torque work's integral (order 2 order + 2 = 8): the default rule, 5
        if variant == "no-guard-old-strain-rule" and not args and kwargs.get("order") == 6:
            kwargs["order"] = 8  # the strain energy with 2 order + 2 instead of the forms' 2 order
        return integrate(cf, mesh, *args, **kwargs)

    fem_outputs.Integrate = patched  # the torque work's and the strain energy's integrals
    m = create(rubber(**{"model.mesh_size": 0.06, "theta0": 0.0}))
    e0 = m.outputs().energy_total
    try:
        for j in range(1, 31):
            out = m.advance(j * 1e-4, 2.0)
            if j in (20, 23, 30):
                error = out.energy_total - e0 - out.energy_torque_work
                print(
                    json.dumps(
                        {
                            "case": what,
                            "variant": variant,
                            "t_ms": j / 10,
                            "work_J": out.energy_torque_work,
                            "energy_error_J": error,
                            "min_det_F": m.min_det_F(),
                        }
                    )
                )
    except StepFailed as exc:
        print(json.dumps({"case": what, "variant": variant, "discarded_at_ms": 1e3 * m.time, "reason": str(exc)}))


def resting_tolerance() -> None:
    """-5 N.m from rest touching the wall, 30 ms in 0.1 ms steps, per solver.tolerance."""
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import steel

    for fidelity in ("rigid", "fem"):
        for tol in (1e-3, 1e-2, 1e-1):
            m = create(
                steel(**{"model.fidelity": fidelity, "model.mesh_size": 0.06, "theta0": 0.0, "solver.tolerance": tol})
            )
            e0, forces, steps, worst, t0 = m.outputs().energy_total, [], 0, 0.0, time.perf_counter()
            for k in range(1, 301):
                out = m.advance(k * 1e-4, -5.0)
                forces.append(out.contact_force)
                steps += out.solver_substeps
                worst = max(worst, abs(out.energy_total - e0 - out.energy_torque_work))
            result = {
                "case": "resting-tolerance",
                "fidelity": fidelity,
                "tolerance": tol,
                "steps_per_ms": steps / 30.0,
                "mean_force_ratio": float(np.mean(forces)) / (5.0 / 0.24),
                "max_force_ratio": max(forces) / (5.0 / 0.24),
                "energy_error_J": worst,
                "s": time.perf_counter() - t0,
            }
            print(json.dumps(result))


def penetration() -> None:
    """Rigid, +-50 N.m square waves, 1 s."""
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import steel

    for half in (0.05, 0.1, 0.15):
        m = create(steel(**{"model.fidelity": "rigid", "theta0": 0.0}))
        pen, wmax = 0.0, 0.0
        for k in range(1, 1001):
            out = m.advance(k * 1e-3, 50.0 if ((k - 1) * 1e-3 + 1e-9) // half % 2 == 0 else -50.0)
            pen, wmax = max(pen, -out.gap_min), max(wmax, abs(out.omega))
        result = {
            "case": "penetration",
            "half_period_s": half,
            "max_penetration_mm": 1e3 * pen,
            "max_omega": wmax,
            "head_speed_m_s": wmax * 0.24,
        }
        print(json.dumps(result))


def sequence() -> None:
    """fem, default scene, 1 s: 1 ms against 0.1 s communication steps, and against max_step 0.5 ms."""
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import steel

    runs = {}
    for label, h, ms in (("1ms", 1e-3, 2e-3), ("0.1s", 0.1, 2e-3), ("1ms-max_step-0.5ms", 1e-3, 5e-4)):
        m = create(steel(**{"model.mesh_size": 0.06, "solver.max_step": ms}))
        runs[label] = {round(k * h, 6): m.advance(k * h, 0.0).theta for k in range(1, int(round(1.0 / h)) + 1)}
    for label in ("0.1s", "1ms-max_step-0.5ms"):
        d = {t: abs(runs[label][t] - runs["1ms"][t]) for t in runs["0.1s"]}
        result = {
            "case": "sequence",
            "against_1ms": label,
            "max_dtheta_before_0.7s": max(v for t, v in d.items() if t <= 0.7),
            "max_dtheta_after": max(v for t, v in d.items() if t > 0.7),
        }
        print(json.dumps(result))


def finding(what: str, arg: str = "") -> None:
    """WHAT with its argument ARG (the Gauss points or the quadrature variant), as the module's docstring says."""
    if what.startswith("gauss"):
        gauss(what, int(arg))
    elif what == "quadrature":
        quadrature(arg)
    else:
        {"resting-tolerance": resting_tolerance, "penetration": penetration, "sequence": sequence}[what]()


def rss_mb() -> float:
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def leak(fmu: str, kind: str) -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    from fmpy.fmi1 import FMICallException
    from test_fmu import Instance

    class Freed(Instance):
        """Frees the instance with fmi2FreeInstance also when initialisation is refused."""

        def __init__(self, *args, **kwargs):
            try:
                super().__init__(*args, **kwargs)
            except FMICallException:
                self.fmu.fmi2FreeInstance(self.fmu.component)
                raise

    starts: dict[str, dict[str, float]] = {
        "mesh": {"model.mesh_size": 1e-5},
        "nu": {"pendulum.nu": 0.5},
        "valid": {"model.fidelity": 2},
    }
    start = starts[kind]
    samples = []
    for k in range(61):
        try:
            Freed(fmu, f"i{k}", **start).close()
        except FMICallException:
            pass
        if k in (0, 20, 40, 60):
            samples.append(round(rss_mb(), 1))
    print(kind, samples, "MB per instance after the first:", round((samples[-1] - samples[0]) / 60, 3))


if __name__ == "__main__":
    verbs: dict[str, Callable[..., None]] = {"memory": memory, "finding": finding, "leak": leak}
    verbs[sys.argv[1]](*sys.argv[2:])
