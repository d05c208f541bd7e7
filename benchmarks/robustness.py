"""Measurements behind docs/robustness.md.

python benchmarks/robustness.py hard-cases [-k EXPR]
    runs tests/test_hard_cases.py with FEM_PENDULUM_ROBUSTNESS_LOG set (the tests record their
    measured worst values before asserting them) and prints one table row per case and fidelity
python benchmarks/robustness.py memory
    peak resident memory of building the FE model and taking one step, against the estimate
    scene.mesh_memory_estimate that refuses meshes too fine for the machine
python benchmarks/robustness.py leak --fmu dist/FemPendulum.fmu
    resident memory over 60 instances refused at initialisation (mesh too fine, nu = 0.5)
    against 60 valid ones, each freed with fmi2FreeInstance
python benchmarks/robustness.py findings
    the measurements behind the findings of docs/robustness.md: Gauss points of the discrete
    gradient (steel after violent impacts, rubber after a pulse, cost on the default run),
    penetration against the square wave's period, step-sequence sensitivity after a second impact
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def hard_cases(keyword: str | None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.jsonl"
        env = dict(os.environ, FEM_PENDULUM_ROBUSTNESS_LOG=str(log))
        cmd = [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            str(ROOT / "tests" / "test_hard_cases.py"),
        ]
        if keyword:
            cmd += ["-k", keyword]
        run = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        print(run.stdout.strip().splitlines()[-1])
        rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    print(
        "\n| test | fidelity | energy error / scale (bound) | scale J | max penetration mm | steps per ms (bound) | "
        "max steps in a doStep | bit-identical runs | discarded |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "steps_per_ms" in r:
            print(
                f"| {r['test']} | {r['fidelity']} | {r['energy']:.2e} ({r['bound_energy']:g}) | {r['scale']:.3g} | "
                f"{1e3 * r['penetration']:.4f} | {r['steps_per_ms']:.2f} ({r['bound_steps_per_ms']:g}) | "
                f"{r['max_substeps']:.0f} | {r['runs']} {'equal' if r['identical'] else 'DIFFER'} | {r['discarded']} |"
            )
    print()
    for r in rows:
        if "steps_per_ms" not in r:
            print(json.dumps(r))


def memory() -> None:
    script = """
import os, resource, sys, time, json
os.environ['FEM_PENDULUM_CACHE'] = 'off'
from fem_pendulum_fmu.physics.fem.model import FemModel
from fem_pendulum_fmu.physics.scene import stiff, estimated_unknowns, mesh_memory_estimate
h, p = float(sys.argv[1]), int(sys.argv[2])
scene = stiff(**{'model.mesh_size': h, 'model.order': p, 'theta0': 0.05})
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
m = FemModel(scene)
m.advance(2e-3, 0.0)
r1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps([h, p, m.X.ndof, estimated_unknowns(scene), (r1 - r0) / 1024, mesh_memory_estimate(scene) / 2**20,
                  time.perf_counter() - t0]))
"""
    print(
        "| mesh size | order | unknowns | estimated unknowns | peak RSS growth MB | estimate MB | kB per unknown | s |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for h, p in ((0.03, 2), (0.01, 2), (0.005, 2), (0.005, 4), (0.0025, 3), (0.0025, 5)):
        out = subprocess.run([sys.executable, "-c", script, str(h), str(p)], capture_output=True, text=True, check=True)
        h_, p_, ndof, est, rss, est_mb, secs = json.loads(out.stdout.strip().splitlines()[-1])
        print(
            f"| {h_:g} | {p_} | {ndof} | {est:.0f} | {rss:.0f} | {est_mb:.0f} | {1024 * rss / ndof:.1f} | {secs:.1f} |"
        )


FINDINGS = r"""
import json, math, sys, time
import numpy as np
what = sys.argv[1]
if what.startswith("gauss"):
    import fem_pendulum_fmu.physics.material as material
    original = material.averaged_pk2_stress
    n = int(sys.argv[2])
    material.averaged_pk2_stress = lambda C0, C1, lam, mu, points: original(C0, C1, lam, mu, n)
from fem_pendulum_fmu.physics.fidelity import create
from fem_pendulum_fmu.physics.scene import compliant, stiff

def worst(model, schedule):
    e0, w, t0 = model.outputs().total, 0.0, time.perf_counter()
    for t, torque in schedule:
        out = model.advance(t, torque)
        w = max(w, abs(out.total - e0 - out.torque_work))
    return w, out, time.perf_counter() - t0

if what == "gauss-violent":   # steel, +-50 N.m square wave (0.15 s each way), 0.18 s: the back-face impact
    m = create(stiff(**{"model.mesh_size": 0.06, "theta0": 0.0}))
    sched = [(k * 1e-3, 50.0 if ((k - 1) // 150) % 2 == 0 else -50.0) for k in range(1, 181)]
    w, out, secs = worst(m, sched)
    print(json.dumps({"case": what, "points": n, "worst_J": w, "work_J": out.torque_work, "s": secs}))
elif what == "gauss-rubber":  # rubber, 2 N.m for 1 ms, then 39 ms free
    m = create(compliant(**{"model.mesh_size": 0.06, "theta0": 0.0}))
    w, out, secs = worst(m, [(k * 1e-3, 2.0 if k == 1 else 0.0) for k in range(1, 41)])
    print(json.dumps({"case": what, "points": n, "worst_J": w, "work_J": out.torque_work, "s": secs}))
elif what == "gauss-default":  # the default scene released at 20 degrees, 0.5 s in 1 ms steps
    m = create(stiff())
    w, out, secs = worst(m, [(k * 1e-3, 0.0) for k in range(1, 501)])
    print(json.dumps({"case": what, "points": n, "worst_J": w, "s": secs}))
elif what == "quadrature":  # rubber (order 3), 2 N.m held in 0.1 ms steps: the energy guard, and the rules used before
    import fem_pendulum_fmu.physics.fem.model as fem
    import fem_pendulum_fmu.physics.fem.outputs as fem_outputs
    from fem_pendulum_fmu.physics.fidelity import StepFailed
    from ngsolve import BND
    integrate, variant = fem_outputs.Integrate, sys.argv[2]
    if variant != "guard":
        fem.STEP_ENERGY_TOLERANCE = math.inf

    def patched(cf, mesh, *args, **kwargs):
        if variant == "no-guard-old-torque-rule" and args and args[0] is BND and kwargs.get("order") == 8:
            kwargs.pop("order", None)  # the torque work's integral (order 2 order + 2 = 8): the default rule, 5
        if variant == "no-guard-old-strain-rule" and not args and kwargs.get("order") == 6:
            kwargs["order"] = 8  # the strain energy with 2 order + 2 instead of the forms' 2 order
        return integrate(cf, mesh, *args, **kwargs)
    fem_outputs.Integrate = patched  # the torque work's and the strain energy's integrals
    m = create(compliant(**{"model.mesh_size": 0.06, "theta0": 0.0}))
    e0 = m.outputs().total
    try:
        for j in range(1, 31):
            out = m.advance(j * 1e-4, 2.0)
            if j in (20, 23, 30):
                print(json.dumps({"case": what, "variant": variant, "t_ms": j / 10, "work_J": out.torque_work,
                                  "energy_error_J": out.total - e0 - out.torque_work, "min_det_F": m.min_det_F()}))
    except StepFailed as exc:
        print(json.dumps({"case": what, "variant": variant, "discarded_at_ms": 1e3 * m.time, "reason": str(exc)}))
elif what == "resting-tolerance":  # -5 N.m from rest touching the wall, 30 ms in 0.1 ms steps, per solver.tolerance
    for fidelity in ("rigid", "fem"):
        for tol in (1e-3, 1e-2, 1e-1):
            m = create(stiff(**{"model.fidelity": fidelity, "model.mesh_size": 0.06, "theta0": 0.0,
                                "solver.tolerance": tol}))
            e0, forces, steps, worst, t0 = m.outputs().total, [], 0, 0.0, time.perf_counter()
            for k in range(1, 301):
                out = m.advance(k * 1e-4, -5.0)
                forces.append(out.contact_force)
                steps += out.substeps
                worst = max(worst, abs(out.total - e0 - out.torque_work))
            print(json.dumps({"case": what, "fidelity": fidelity, "tolerance": tol, "steps_per_ms": steps / 30.0,
                              "mean_force_ratio": float(np.mean(forces)) / (5.0 / 0.24),
                              "max_force_ratio": max(forces) / (5.0 / 0.24), "energy_error_J": worst,
                              "s": time.perf_counter() - t0}))
elif what == "penetration":  # rigid, +-50 N.m square waves, 1 s
    for half in (0.05, 0.1, 0.15):
        m = create(stiff(**{"model.fidelity": "rigid", "theta0": 0.0}))
        pen, wmax = 0.0, 0.0
        for k in range(1, 1001):
            out = m.advance(k * 1e-3, 50.0 if ((k - 1) * 1e-3 + 1e-9) // half % 2 == 0 else -50.0)
            pen, wmax = max(pen, -out.min_gap), max(wmax, abs(out.omega))
        print(json.dumps({"case": what, "half_period_s": half, "max_penetration_mm": 1e3 * pen, "max_omega": wmax,
                          "head_speed_m_s": wmax * 0.24}))
elif what == "sequence":  # fem, default scene, 1 s: 1 ms against 0.1 s communication steps, and against max_step 0.5 ms
    runs = {}
    for label, h, ms in (("1ms", 1e-3, 2e-3), ("0.1s", 0.1, 2e-3), ("1ms-max_step-0.5ms", 1e-3, 5e-4)):
        m = create(stiff(**{"model.mesh_size": 0.06, "solver.max_step": ms}))
        runs[label] = {round(k * h, 6): m.advance(k * h, 0.0).theta for k in range(1, int(round(1.0 / h)) + 1)}
    for label in ("0.1s", "1ms-max_step-0.5ms"):
        d = {t: abs(runs[label][t] - runs["1ms"][t]) for t in runs["0.1s"]}
        print(json.dumps({"case": what, "against_1ms": label,
                          "max_dtheta_before_0.7s": max(v for t, v in d.items() if t <= 0.7),
                          "max_dtheta_after": max(v for t, v in d.items() if t > 0.7)}))
"""


def findings() -> None:
    jobs = (
        [("gauss-violent", n) for n in (1, 2, 3)]
        + [("gauss-rubber", n) for n in (2, 3)]
        + [("gauss-default", n) for n in (1, 2, 1, 2)]
        + [("penetration", None), ("sequence", None), ("resting-tolerance", None)]
        + [("quadrature", v) for v in ("guard", "no-guard", "no-guard-old-torque-rule", "no-guard-old-strain-rule")]
    )
    for what, n in jobs:
        args = [sys.executable, "-c", FINDINGS, what] + ([str(n)] if n is not None else [])
        out = subprocess.run(args, capture_output=True, text=True, check=True, cwd=ROOT)
        print(out.stdout.strip(), flush=True)


LEAK = r"""
import os, sys
sys.path.insert(0, sys.argv[3])
from fmpy.fmi1 import FMICallException
from test_fmu import Instance

def rss_mb():
    return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

class Freed(Instance):
    # frees the instance with fmi2FreeInstance also when initialisation is refused

    def __init__(self, *args, **kwargs):
        try:
            super().__init__(*args, **kwargs)
        except FMICallException:
            self.fmu.fmi2FreeInstance(self.fmu.component)
            raise


start = {"mesh": {"model.mesh_size": 1e-5}, "nu": {"pendulum.nu": 0.5}, "valid": {"model.fidelity": 2}}[sys.argv[2]]
samples = []
for k in range(61):
    try:
        Freed(sys.argv[1], f"i{k}", **start).close()
    except FMICallException:
        pass
    if k in (0, 20, 40, 60):
        samples.append(round(rss_mb(), 1))
print(sys.argv[2], samples, "MB per instance after the first:", round((samples[-1] - samples[0]) / 60, 3))
"""


def leak(fmu: str) -> None:
    """Memory growth per instance: refused at initialisation and freed, against valid ones instantiated and freed."""
    for kind in ("mesh", "nu", "valid"):
        out = subprocess.run(
            [sys.executable, "-c", LEAK, fmu, kind, str(ROOT / "tests")], capture_output=True, text=True, check=True
        )
        print(out.stdout.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["hard-cases", "memory", "findings", "leak"])
    parser.add_argument("--fmu", default=str(ROOT / "dist" / "FemPendulum.fmu"), help="the FMU (leak)")
    parser.add_argument("-k", help="pytest -k expression (hard-cases)")
    args = parser.parse_args()
    {"hard-cases": lambda: hard_cases(args.k), "memory": memory, "findings": findings, "leak": lambda: leak(args.fmu)}[
        args.what
    ]()


if __name__ == "__main__":
    main()
