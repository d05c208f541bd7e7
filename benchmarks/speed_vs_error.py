"""Work-precision benchmark: wall time per simulated second against error, for every fidelity.

    python benchmarks/speed_vs_error.py references [--scenes steel ...]   # tight FE runs -> benchmarks/references/
    python benchmarks/speed_vs_error.py sweep [--repeat 3] [--scenes ...] [--curves ...]  # -> benchmarks/results/
    python benchmarks/speed_vs_error.py report                              # tables + plots -> docs/
    python benchmarks/speed_vs_error.py quick                               # defaults vs references, asserts accuracy

Every run goes through the FMU as a user would: fmpy's FMU2Slave, 1 ms
communication steps, outputs read after every step, one fresh process per run
(so that runs do not share caches or interpreters). The scenes: steel and
rubber released at 20 degrees (2 s), the PID controller loop (2 s) and the
seed's deformable wall (0.5 s). For every available fidelity and several
accuracy settings (solver.tolerance, solver.max_step, mesh size and order)
it measures the wall time per simulated second of the stepping loop (median of
--repeat runs, with the spread) and, against the stored FE reference of the
scene, the max and RMS error in theta, the max error in gap, the error of the
first rebound peak, the energy error max |E_total - E_0 - W_torque| / swing
energy, and the largest penetration (output gap_min, the smallest gap at the
internal steps). The seed's schemes (solver.scheme newmark_fixed and
newmark_gap_rule of the FE model) run as extra rows.

The FMUs are built from this checkout into a temporary folder unless --fmu
and --pid are given.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "benchmarks" / "references"
RESULTS = ROOT / "benchmarks" / "results" / "speed_vs_error.jsonl"
RUNS = Path(os.environ.get("SPEED_VS_ERROR_RUNS", Path(tempfile.gettempdir()) / "speed_vs_error_runs"))
DOC = ROOT / "docs" / "notes" / "speed_vs_error.md"
COMM_STEP = 1e-3
SWING_DEG = 20.0  # swing energy: the 20-degree swing every scene is about
REBOUND_SPEED = 0.02  # rad/s: a rebound turns omega from faster than this towards the wall
DIVERGED = 10.0  # a run whose energy error exceeds this many swing energies is stopped as diverged
RECORDED = ("theta", "omega", "gap", "gap_min", "contact_force", "energy.total", "energy.torque_work")

# ------------------------------------------------------------------ scenes and settings


@dataclass(frozen=True)
class SceneCase:
    name: str
    description: str
    t_end: float
    preset: str
    values: dict = field(default_factory=dict)
    loop: bool = False  # the PID controller FMU in the loop (masters/control/)


SCENES = (
    SceneCase("steel", "steel preset released at 20 deg, rigid wall, no torque", 2.0, "steel"),
    SceneCase("rubber", "rubber preset (order 3) released at 20 deg, rigid wall, no torque", 2.0, "rubber"),
    SceneCase(
        "controller",
        "PID controller loop of fem-pendulum-control (steel, from rest at 0 deg, 20-deg sine set-point, 15 N.m drive)",
        2.0,
        "steel",
        {"theta0": 0.0},
        loop=True,
    ),
    SceneCase(
        "deformable_wall",
        "steel released at 20 deg against the seed's meshed steel wall (wall.kind deformable, fem only)",
        0.5,
        "steel",
        {"wall.kind": "deformable"},
    ),
)
SCENE = {s.name: s for s in SCENES}


@dataclass(frozen=True)
class Setting:
    curve: str  # fidelity or seed scheme: one curve of the work-precision plot
    label: str
    values: dict = field(default_factory=dict)  # FMI parameters on top of the scene's


SEED_FIXED = "seed Newmark, fixed dt"
SEED_GAP = "seed Newmark, gap rule"
# The convergence check of the references, as stated in docs/notes/speed_vs_error.md: max |theta_L1 - theta_L2|
# before the second impact (the measured values: steel 3.2e-4, rubber 1.05e-3, deformable wall 3.2e-5
# over its whole 0.5 s; controller 6.7e-3 because L1's order-3 head starts 6 um inside the wall it
# touches at theta0 = 0 and is kicked off it, while the default mesh agrees with L2 to 1.6e-4).
REFERENCE_AGREEMENT = {"steel": 5e-4, "rubber": 1.6e-3, "controller": 1e-2, "deformable_wall": 1e-4}
# the tight FE discretisations behind the references; the last one is the reference
REFERENCE_LEVELS = (
    ("L1", {"model.mesh_size": 0.03, "model.order": 3, "solver.tolerance": 1e-4, "solver.max_step": 5e-4}),
    ("L2", {"model.mesh_size": 0.015, "model.order": 3, "solver.tolerance": 1e-5, "solver.max_step": 2.5e-4}),
)


def scene_of(case: SceneCase, values: dict | None = None):
    """The Scene a case (plus FMI values) describes."""
    from fem_pendulum_fmu.physics.scene import PRESETS

    return PRESETS[case.preset]().with_values({**case.values, **(values or {})})


def available_fidelities() -> tuple[str, ...]:
    from fem_pendulum_fmu.physics.fidelity import AVAILABLE

    return tuple(AVAILABLE)


def supports(fidelity: str, case: SceneCase) -> bool:
    """The deformable wall is meshed: fem only."""
    return fidelity == "fem" or case.values.get("wall.kind") != "deformable"


def meant_for(fidelity: str, case: SceneCase) -> bool:
    """fem is meant for every scene; another fidelity for the scenes the auto rule gives it."""
    from fem_pendulum_fmu.physics.fidelity import resolve_fidelity

    if fidelity == "fem":
        return True
    return supports(fidelity, case) and resolve_fidelity(scene_of(case, {"model.fidelity": "auto"})) == fidelity


SEED_STEP_BUDGET = 100  # solver.max_substeps of the seed rows: its rules need at most 10 steps per 1 ms


def settings(curve: str, case: SceneCase) -> list[Setting]:
    """The accuracy settings swept for one curve on one scene (the default first).

    The FE sweep is smaller on the costly scenes (rubber, deformable wall) so that a
    full sweep fits in about an hour on two cores."""
    from fem_pendulum_fmu.physics.scene import element_order

    order = element_order(scene_of(case))
    costly = case.name in ("rubber", "deformable_wall")
    if curve == "fem":
        f = {"model.fidelity": "fem"}
        variants = [("tol 1e-2", {"solver.tolerance": 1e-2}), ("mesh 0.06", {"model.mesh_size": 0.06})]
        if case.name != "deformable_wall":
            variants.append((f"order {3 if order == 2 else 2}", {"model.order": 3 if order == 2 else 2}))
        if not costly:
            variants += [("tol 1e-4", {"solver.tolerance": 1e-4}), ("max_step 5e-4", {"solver.max_step": 5e-4})]
        return [Setting(curve, "default", f)] + [Setting(curve, label, {**f, **v}) for label, v in variants]
    if curve in ("rigid", "reduced"):
        f = {"model.fidelity": curve}
        rows = [Setting(curve, "default", f)] + [
            Setting(curve, label, {**f, **v})
            for label, v in (
                ("tol 1e-1", {"solver.tolerance": 1e-1}),
                ("tol 1e-2", {"solver.tolerance": 1e-2}),
                ("tol 1e-4", {"solver.tolerance": 1e-4}),
                ("tol 1e-5", {"solver.tolerance": 1e-5}),
                ("max_step 2.5e-4", {"solver.max_step": 2.5e-4}),
            )
        ]
        if curve == "reduced":
            rows += [Setting(curve, f"modes {m}", {**f, "model.modes": m}) for m in (2, 12)]
        return rows
    seed = {"model.fidelity": "fem", "solver.max_substeps": SEED_STEP_BUDGET}
    if curve == SEED_FIXED:
        steps = (1e-3, 2.5e-4) if costly or case.loop else (1e-3, 5e-4, 2.5e-4, 1e-4)
        return [
            Setting(curve, f"dt {dt:g}", {**seed, "solver.scheme": "newmark_fixed", "solver.max_step": dt})
            for dt in steps
        ]
    if curve == SEED_GAP:
        steps = (1e-3,) if costly or case.loop else (1e-3, 5e-4)
        return [
            Setting(curve, f"base dt {dt:g}", {**seed, "solver.scheme": "newmark_gap_rule", "solver.max_step": dt})
            for dt in steps
        ]
    raise KeyError(curve)


def curves() -> list[str]:
    return list(available_fidelities()) + [SEED_FIXED, SEED_GAP]


def fmi_values(case: SceneCase, values: dict) -> dict:
    """FMI start values (enumerations as integers) for every parameter that differs from the FMU's start."""
    from fem_pendulum_fmu.fmi import interface
    from fem_pendulum_fmu.physics.scene import Scene, get_path

    scene, default = scene_of(case, values), Scene()
    out = {}
    for var in interface.load().of_causality("parameter"):
        try:
            value, start = get_path(scene, var.name), get_path(default, var.name)
        except AttributeError:  # Integer aliases of enumerations
            continue
        if value != start:
            out[var.name] = var.items.index(value) + 1 if var.items else value
    return out


# ------------------------------------------------------------------ one run (in its own process)


def _child(spec: dict) -> None:
    """Run one scene through the FMU and save the sampled outputs and the timings to spec['out']."""
    from fmpy.fmi1 import FMICallException

    from fem_pendulum_fmu.masters.named_slave import NamedSlave

    t0 = time.perf_counter()
    pendulum = NamedSlave(spec["fmu"], "pendulum", spec["values"])
    controller = None
    if spec["loop"]:
        from fem_pendulum_fmu.masters.control.command import DEFAULT_SETPOINT
        from fem_pendulum_fmu.masters.control.loop import drive
        from fem_pendulum_fmu.masters.control.signals import parse_signal

        setpoint, drive_limit = parse_signal(DEFAULT_SETPOINT, "angle", "--setpoint"), 15.0
        controller = NamedSlave(spec["pid"], "pid", {})  # the PID FMU's own gains, as fem-pendulum control
    init = time.perf_counter() - t0
    h, n = COMM_STEP, int(round(spec["t_end"] / COMM_STEP))
    rows = [pendulum.get(*RECORDED)]
    substeps = 0
    failed = None
    t = 0.0
    w0, c0 = time.perf_counter(), time.process_time()
    for k in range(n):
        torque = 0.0
        if controller is not None:
            controller.set("setpoint", setpoint(t))
            controller.set("measurement", rows[-1][0])
            controller.fmu.doStep(t, h)
            torque = drive(controller.get("u")[0], drive_limit)
        pendulum.set("torque", torque)
        try:
            pendulum.fmu.doStep(t, h)
        except FMICallException as exc:
            failed = f"doStep at t = {t:.3f} s: {exc}"
            break
        t = (k + 1) * h
        rows.append(pendulum.get(*RECORDED))
        substeps += pendulum.fmu.getInteger([pendulum.vr["solver.substeps"]])[0]
        e = (
            rows[-1][RECORDED.index("energy.total")]
            - rows[0][RECORDED.index("energy.total")]
            - rows[-1][RECORDED.index("energy.torque_work")]
        )
        if abs(e) > spec.get("abort_energy", math.inf):
            failed = f"diverged: energy error {e:.3g} J, over {DIVERGED:g} swing energies, at t = {t:.3f} s"
            break
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    data = np.array(rows)
    np.savez(
        spec["out"],
        time=np.arange(len(rows)) * h,
        data=data,
        wall=wall,
        cpu=cpu,
        init=init,
        substeps=substeps,
        failed=json.dumps(failed),
        simulated=t,
    )


@dataclass
class Run:
    time: np.ndarray
    signals: dict
    wall: float
    cpu: float
    init: float
    substeps: int
    failed: str | None
    simulated: float


def run_once(case: SceneCase, values: dict, fmus: tuple[Path, Path], t_end: float | None = None) -> Run:
    """One run in a fresh process; the FMU's parameters are the scene's plus `values`."""
    with tempfile.TemporaryDirectory(prefix="speed_vs_error_") as tmp:
        out = Path(tmp) / "run.npz"
        spec = {
            "fmu": str(fmus[0]),
            "pid": str(fmus[1]),
            "values": fmi_values(case, values),
            "loop": case.loop,
            "abort_energy": DIVERGED * case_swing_energy(case),
            "t_end": case.t_end if t_end is None else t_end,
            "out": str(out),
        }
        proc = subprocess.run([sys.executable, __file__, "_run", json.dumps(spec)], capture_output=True, text=True)
        if proc.returncode != 0 or not out.exists():
            raise RuntimeError(f"run {case.name} {values} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}")
        with np.load(out) as z:
            data = z["data"]
            return Run(
                z["time"],
                {name: data[:, i] for i, name in enumerate(RECORDED)},
                float(z["wall"]),
                float(z["cpu"]),
                float(z["init"]),
                int(z["substeps"]),
                json.loads(str(z["failed"])),
                float(z["simulated"]),
            )


# ------------------------------------------------------------------ metrics


def case_swing_energy(case: SceneCase) -> float:
    """m g d (1 - cos 20 deg) of the case's pendulum: the energy of the swing every scene is about."""
    from fem_pendulum_fmu.physics.mass_properties import swing_energy

    return swing_energy(scene_of(case), math.radians(SWING_DEG))


def rebounds(omega: np.ndarray, gap: np.ndarray, band: float = 1e-3) -> np.ndarray:
    """physics.swing.rebounds of a pendulum moving towards the wall faster than REBOUND_SPEED
    (a pendulum resting on the wall does not count): one per rebound."""
    from fem_pendulum_fmu.physics import swing

    return swing.rebounds(omega, gap, band, speed=REBOUND_SPEED)


def early_window(ref: dict) -> int:
    """Samples before the reference's second rebound (all of them if it has none).

    After the first impact the steel plate vibrates at about 1 kHz, and the second
    impact's outcome depends on that vibration's phase, which no affordable
    discretisation resolves over half a second (docs/notes/speed_vs_error.md): errors up
    to the second impact measure the discretisation, later ones mostly that phase."""
    reb = rebounds(ref["omega"], ref["gap"])
    return int(reb[1]) - 1 if len(reb) > 1 else len(ref["theta"])


def first_rebound_peak(theta: np.ndarray, omega: np.ndarray, gap: np.ndarray, band: float = 1e-3) -> float:
    """theta at the first peak after the first rebound from the wall (nan if there is none).

    The rebound is the first sample interval in which omega turns from towards the
    wall to away from it with the gap under `band` (as masters/control/figure.py wall_impacts);
    the peak is the largest theta until omega turns back."""
    reb = rebounds(omega, gap, band)
    if len(reb) == 0:
        return math.nan
    k = reb[0] + 1
    down = np.nonzero((omega[k:-1] > 0) & (omega[k + 1 :] <= 0))[0]
    end = k + down[0] + 2 if len(down) else len(theta)
    return float(theta[k:end].max())


def energy_error(sig: dict, swing: float) -> float:
    e = sig["energy.total"] - sig["energy.total"][0] - sig["energy.torque_work"]
    return float(np.max(np.abs(e)) / swing)


def penetration(sig: dict) -> float:
    return float(max(0.0, -np.min(sig["gap_min"])))


def metrics(run: Run, ref: dict, swing: float) -> dict:
    """Errors of a run against the reference over the samples both have (a failed run: up to its failure)."""
    n = min(len(run.time), len(ref["time"]))
    s = run.signals
    dth = s["theta"][:n] - ref["theta"][:n]
    dgap = s["gap"][:n] - ref["gap"][:n]
    peak = first_rebound_peak(s["theta"], s["omega"], s["gap"])
    early = min(n, early_window(ref))
    return {
        "theta_max": float(np.max(np.abs(dth))),
        "theta_rms": float(np.sqrt(np.mean(dth * dth))),
        "theta_max_early": float(np.max(np.abs(dth[:early]))),
        "early_end": float(ref["time"][early - 1]),
        "gap_max": float(np.max(np.abs(dgap))),
        "rebound_peak": peak,
        "rebound_peak_error": peak - ref["rebound_peak"],
        "energy": energy_error(s, swing),
        "penetration": penetration(s),
    }


def load_reference(name: str) -> dict | None:
    path = REFERENCES / f"{name}.npz"
    if not path.exists():
        return None
    with np.load(path) as z:
        ref = {k: z[k] for k in z.files if k != "meta"}
        ref["meta"] = json.loads(str(z["meta"]))
    ref["rebound_peak"] = first_rebound_peak(ref["theta"], ref["omega"], ref["gap"])
    return ref


# ------------------------------------------------------------------ FMUs


def build_fmus(folder: Path) -> tuple[Path, Path]:
    run = subprocess.run(
        [sys.executable, str(ROOT / "build_fmu.py"), "--output", str(folder / "FemPendulum.fmu")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    fmu, pid = (Path(p) for p in run.stdout.split()[-2:])
    return fmu, pid


def fmus_from(args, tmp: Path) -> tuple[Path, Path]:
    if args.fmu and args.pid:
        return Path(args.fmu).resolve(), Path(args.pid).resolve()
    return build_fmus(tmp)


def code_version() -> str:
    """The checkout's commit when the row was measured (+ "dirty" with uncommitted changes); the FMU
    given with --fmu may have been built earlier (docs/notes/speed_vs_error.md says from what)."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        return head + (" dirty" if dirty else "")
    except OSError:
        return "unknown"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


# ------------------------------------------------------------------ references


def make_references(case_names: list[str], fmus: tuple[Path, Path]) -> None:
    """Run the reference levels (plus the default) of each scene; store the finest with the convergence check."""
    REFERENCES.mkdir(parents=True, exist_ok=True)
    for name in case_names:
        case = SCENE[name]
        swing = case_swing_energy(case)
        levels = [("default", {"model.fidelity": "fem"})] + [
            (lab, {"model.fidelity": "fem", **v}) for lab, v in REFERENCE_LEVELS
        ]
        runs = {}
        for label, values in levels:
            run = run_once(case, values, fmus)
            if run.failed:
                raise RuntimeError(f"reference level {label} of {name} failed: {run.failed}")
            runs[label] = run
            print(f"{name} {label}: {run.wall:.0f} s wall, {run.substeps} internal steps", flush=True)
        checks = []
        for (a, _), (b, _) in zip(levels[:-1], levels[1:], strict=False):
            ra, rb = runs[a], runs[b]
            ref_b = {
                "time": rb.time,
                **rb.signals,
                "rebound_peak": first_rebound_peak(rb.signals["theta"], rb.signals["omega"], rb.signals["gap"]),
            }
            m = metrics(ra, ref_b, swing)
            m.update(coarse=a, fine=b, fine_penetration=penetration(rb.signals))
            checks.append(m)
        final_label, final_values = levels[-1]
        final = runs[final_label]
        meta = {
            "scene": name,
            "description": case.description,
            "t_end": case.t_end,
            "level": final_label,
            "values": final_values,
            "fmi_values": fmi_values(case, final_values),
            "wall_s": final.wall,
            "substeps": final.substeps,
            "swing_energy": swing,
            "convergence": checks,
            "command": f"python benchmarks/speed_vs_error.py references --scenes {name}",
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="minutes"),
            "machine": machine(),
        }
        np.savez_compressed(REFERENCES / f"{name}.npz", time=final.time, meta=json.dumps(meta), **final.signals)
        print(json.dumps(meta, indent=1), flush=True)


def recheck_references(case_names: list[str], fmus: tuple[Path, Path]) -> None:
    """Re-run the next-to-finest level and store its comparison with the stored reference
    (the convergence check, with the metrics of the current code)."""
    label, values = REFERENCE_LEVELS[-2]
    for name in case_names:
        case, path = SCENE[name], REFERENCES / f"{name}.npz"
        ref = load_reference(name)
        run = run_once(case, {"model.fidelity": "fem", **values}, fmus)
        check = metrics(run, ref, case_swing_energy(case))
        check.update(coarse=label, fine=ref["meta"]["level"], fine_penetration=penetration(ref))
        meta = ref["meta"]
        meta["convergence"] = [c for c in meta["convergence"] if c["coarse"] != label] + [check]
        meta["recheck_date"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="minutes")
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files if k != "meta"}
        np.savez_compressed(path, meta=json.dumps(meta), **arrays)
        print(name, json.dumps(check), flush=True)


# ------------------------------------------------------------------ sweep and quick mode


def run_key(*parts: str) -> str:
    return "__".join(x.replace(" ", "_").replace(",", "") for x in parts)


def save_signals(key: str, run: Run) -> Path:
    """Keep a run's samples (outside the repository) so that the report can score it against any reference."""
    RUNS.mkdir(parents=True, exist_ok=True)
    path = RUNS / f"{key}.npz"
    np.savez_compressed(path, time=run.time, **run.signals)
    return path


def load_signals(path: str | Path) -> Run | None:
    if not Path(path).exists():
        return None
    with np.load(path) as z:
        return Run(
            z["time"],
            {k: z[k] for k in z.files if k != "time"},
            math.nan,
            math.nan,
            math.nan,
            0,
            None,
            float(z["time"][-1]),
        )


def measure(
    case: SceneCase, setting: Setting, fmus, repeat: int, t_end: float | None = None, tag: str = "sweep"
) -> dict:
    """Time `repeat` runs (errors from the first: with model.threads 1 the runs are bit-identical)."""
    runs = [run_once(case, setting.values, fmus, t_end)]
    if not runs[0].failed:
        runs += [run_once(case, setting.values, fmus, t_end) for _ in range(repeat - 1)]
    first = runs[0]
    signals = save_signals(run_key(tag, case.name, setting.curve, setting.label), first)
    ref = load_reference(case.name)
    row = {
        "scene": case.name,
        "curve": setting.curve,
        "label": setting.label,
        "values": setting.values,
        "t_end": case.t_end if t_end is None else t_end,
        "simulated": first.simulated,
        "wall_per_sim": [r.wall / max(r.simulated, COMM_STEP) for r in runs],
        "cpu_per_sim": [r.cpu / max(r.simulated, COMM_STEP) for r in runs],
        "init_s": [r.init for r in runs],
        "substeps": first.substeps,
        "failed": first.failed,
        "signals": str(signals),
        "code": code_version(),
        "metrics": metrics(first, ref, case_swing_energy(case)) if ref is not None else None,
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="minutes"),
    }
    return row


def resample(fmus, curves: list[str]) -> None:
    """Re-run once the rows whose saved samples are missing or do not cover the scene (scoring only:
    the row's timings stay those of its own runs); the samples go where the row points."""
    for line in RESULTS.read_text().splitlines():
        r = json.loads(line)
        run = load_signals(r.get("signals", ""))
        if r["curve"] not in curves or run is not None and (r["failed"] or run.time[-1] >= r["t_end"] - COMM_STEP / 2):
            continue
        fresh = run_once(SCENE[r["scene"]], r["values"], fmus)
        path = Path(r["signals"])
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(path, time=fresh.time, **fresh.signals)
        print("resampled", r["scene"], r["curve"], r["label"], flush=True)


def sweep(args, fmus) -> None:
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if RESULTS.exists() and not args.overwrite:
        for line in RESULTS.read_text().splitlines():
            r = json.loads(line)
            done.add((r["scene"], r["curve"], r["label"]))
    jobs = []
    for name in args.scenes:
        case = SCENE[name]
        for curve in args.curves:
            fidelity = "fem" if curve.startswith("seed") else curve
            if not supports(fidelity, case):
                continue
            for rank, s in enumerate(settings(curve, case)):
                if (name, curve, s.label) not in done:
                    jobs.append((case, s, min(rank, 1)))
    order = {"deformable_wall": 0, "steel": 1, "controller": 2, "rubber": 3}
    jobs = [(c, s) for c, s, rank in sorted(jobs, key=lambda j: (j[2], order[j[0].name]))]
    print(f"{len(jobs)} rows to run", flush=True)
    for case, s in jobs:
        row = measure(case, s, fmus, args.repeat)
        with RESULTS.open("a") as f:
            f.write(json.dumps(row) + "\n")
        m = row["metrics"] or {}
        print(
            f"{case.name:16s} {s.curve:24s} {s.label:16s} wall/sim {np.median(row['wall_per_sim']):8.3f} s "
            f"theta {m.get('theta_max', math.nan):.2e} energy {m.get('energy', math.nan):.1e} "
            f"{'FAILED ' + row['failed'] if row['failed'] else ''}",
            flush=True,
        )


# Accuracy a fidelity's default settings must reach on the scenes it is meant for (quick mode, tests),
# in max |theta - theta_ref| before the reference's second impact (early_window: later, the phase of
# the steel plate's 1 kHz vibration decides, which not even the references agree on): the
# target where it is met, else the bound docs/notes/speed_vs_error.md states (measured value + 50 %).
THETA_TARGET = 1e-3  # rad
ENERGY_TARGET = 1e-3  # of the swing energy
THETA_BOUNDS = {("fem", "rubber"): 1.7e-3}  # measured 1.1e-3 to 1.5e-3 (round-off moves it; L1 -> L2 differ by 1.05e-3)
QUICK_MARGIN = 0.02  # s simulated past the end of the early window


def quick_rows(fmus, scenes: list[str] | None = None) -> list[dict]:
    """Each available fidelity's default settings, once, on the scenes it is meant for, up to
    QUICK_MARGIN past the reference's second impact (that is all the quick check scores)."""
    rows = []
    for case in SCENES:
        if scenes and case.name not in scenes:
            continue
        ref = load_reference(case.name)
        t_end = min(case.t_end, round(float(ref["time"][early_window(ref) - 1]) + QUICK_MARGIN, 3))
        for fidelity in available_fidelities():
            if meant_for(fidelity, case):
                row = measure(case, settings(fidelity, case)[0], fmus, repeat=1, t_end=t_end, tag="quick")
                row["theta_bound"] = THETA_BOUNDS.get((fidelity, case.name), THETA_TARGET)
                rows.append(row)
    return rows


def check_quick(rows: list[dict]) -> list[str]:
    """Accuracy failures of quick-mode rows (an empty list when all pass)."""
    problems = []
    for r in rows:
        m = r["metrics"]
        where = f"{r['curve']} default on {r['scene']}"
        if r["failed"]:
            problems.append(f"{where}: {r['failed']}")
        elif m is None:
            problems.append(f"{where}: no stored reference")
        else:
            if not m["theta_max_early"] <= r["theta_bound"]:
                problems.append(
                    f"{where}: max theta error before the second impact {m['theta_max_early']:.3g} rad "
                    f"> {r['theta_bound']:.3g}"
                )
            if not m["energy"] <= ENERGY_TARGET:
                problems.append(f"{where}: energy error {m['energy']:.3g} > {ENERGY_TARGET:g}")
    return problems


# ------------------------------------------------------------------ report


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "_run":
        _child(json.loads(argv[1]))
        return
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("command", choices=("references", "recheck", "sweep", "resample", "report", "quick"))
    p.add_argument("--scenes", nargs="+", default=[s.name for s in SCENES], choices=[s.name for s in SCENES])
    p.add_argument("--curves", nargs="+", default=None, help="fidelities and seed schemes (default: all)")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--overwrite", action="store_true", help="sweep: start a new results file")
    p.add_argument("--fmu", help="FemPendulum.fmu to use (default: build from this checkout)")
    p.add_argument("--pid", help="PidController.fmu to use")
    args = p.parse_args(argv)
    args.curves = args.curves or curves()
    if args.command == "report":
        from speed_vs_error_report import write_report  # here: the report imports this module (benchmarks/ on sys.path)

        write_report()
        return
    with tempfile.TemporaryDirectory(prefix="speed_vs_error_fmu_") as tmp:
        fmus = fmus_from(args, Path(tmp))
        if args.command == "references":
            make_references(args.scenes, fmus)
        elif args.command == "resample":
            resample(fmus, args.curves)
        elif args.command == "recheck":
            recheck_references(args.scenes, fmus)
        elif args.command == "sweep":
            if args.overwrite and RESULTS.exists():
                RESULTS.unlink()
            sweep(args, fmus)
        else:
            t0 = time.perf_counter()
            rows = quick_rows(fmus, args.scenes)
            for r in rows:
                m = r["metrics"] or {}
                print(
                    f"{r['scene']:16s} {r['curve']:8s} max theta error to {m.get('early_end', math.nan):.3f} s "
                    f"{m.get('theta_max_early', math.nan):.2e} rad "
                    f"(bound {r['theta_bound']:.2g}), energy error {m.get('energy', math.nan):.1e}, "
                    f"wall/sim {r['wall_per_sim'][0]:.2f} s"
                )
            problems = check_quick(rows)
            print(
                f"quick mode: {len(rows)} runs in {time.perf_counter() - t0:.0f} s; "
                + ("all within bounds" if not problems else "FAILED:\n  " + "\n  ".join(problems))
            )
            if problems:
                raise SystemExit(1)


if __name__ == "__main__":
    main()
