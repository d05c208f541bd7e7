"""Hard cases through the FMU, each for every fidelity that applies, with stated bounds.

Every case checks: all outputs finite; the energy error |E - E0 - W| within
the case's bound (relative to the energy the run moves: the largest kinetic +
strain + contact energy plus the largest |torque work|); penetration (gap_min,
the smallest gap at any internal step) below 2 mm; no step stall (internal
steps per simulated millisecond below the case's bound, and solver.max_substeps
set so that a stalling doStep would be discarded); two runs bit-identical.
The bounds and why they are what they are: docs/notes/robustness.md.

Fidelities: those of physics/fidelity.py's AVAILABLE that model the wall of the case
(the rigid fidelity has no deformable wall and no elements; "reduced" joins
the rigid-wall cases when it is registered).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from fmu_runner import COMPLIANT, STIFF, col, run_schedule

from fem_pendulum_fmu.physics.fidelity import AVAILABLE, create
from fem_pendulum_fmu.physics.scene import compliant, stiff

RIGID_WALL = [f for f in ("rigid", "reduced", "fem") if f in AVAILABLE]
COARSE = {"model.mesh_size": 0.06}  # robustness, not accuracy: the coarsest mesh (docs/notes/fem.md mesh study)
STALL_GUARD = {"solver.max_substeps": 5000}  # a doStep needing more is discarded, and the run fails
PENETRATION = 2e-3  # m, the robustness bound (docs/notes/robustness.md)
# energy error / energy moved, per fidelity: the rigid model's discrete gradient is exact to round-off;
# the FE model's to its Newton tolerance and the discrete gradient's Gauss rule (docs/notes/robustness.md)
ENERGY = {
    "high_speed": {"rigid": 1e-9, "reduced": 1e-6, "fem": 1e-7},
    "large_steps": {"rigid": 1e-9, "reduced": 1e-6, "fem": 1e-7},
    "violent": {"rigid": 1e-9, "reduced": 1e-5, "fem": 2e-6},
    "resting": {"rigid": 1e-9, "reduced": 1e-5, "fem": 2e-6},
    "grazing": {"rigid": 1e-9, "reduced": 1e-4, "fem": 1e-4},  # of 7e-5 J: the Newton floor, 1e-9 J
    "at_rest": {"rigid": 1e-12, "reduced": 5e-9, "fem": 1e-9},  # of |E0|: nothing moves
    "rubber_pulse": {"fem": 1e-2},  # strain increments ~0.1 per step; the energy guard holds each step to 1e-3
    "deformable_wall": {"fem": 5e-3},  # contact pairs fixed at the step start: entry and exit approximate
}
# internal steps per simulated ms: free flight 0.5 (2 ms steps) plus 16 to 29 steps per contact duration;
# a held contact takes free-flight steps after three contact durations (stepping.py): the resting case
# measured 1.32 (rigid) to 1.52 (reduced) per ms over 0.3 s in 1 ms doSteps (docs/notes/robustness.md)
STEPS_PER_MS = {
    "high_speed": 40,
    "large_steps": 2,
    "violent": 5,
    "resting": 3,
    "grazing": 2,
    "at_rest": 2,
    "rubber_pulse": 40,
    "deformable_wall": 40,
}


def record(**values) -> None:
    """Append measured worst values (before they are asserted) to $FEM_PENDULUM_ROBUSTNESS_LOG, if set:
    benchmarks/robustness.py runs these tests that way to write the table of docs/notes/robustness.md."""
    path = os.environ.get("FEM_PENDULUM_ROBUSTNESS_LOG")
    if path:
        test = os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0].split("::")[-1]
        with open(path, "a") as f:
            f.write(json.dumps({"test": test, **values}) + "\n")


def energy_error(run):
    e = col(run, "energy.total")
    return np.abs(e - e[0] - col(run, "energy.torque_work"))


def energy_moved(run):
    moving = col(run, "energy.kinetic") + col(run, "energy.strain") + col(run, "energy.contact")
    return float(np.max(moving) + np.max(np.abs(col(run, "energy.torque_work"))))


def check_common(
    case: str, fidelity: str, runs: list[np.ndarray], allow_discard: bool = False, scale: float | None = None
) -> dict:
    """The checks every hard case shares; returns the measured worst values (for the report).

    scale: the energy the error is measured against, by default the energy the run moves."""
    first = runs[0]
    ok = first[col(first, "status") == 0]
    moved = energy_moved(ok) if scale is None else scale
    rel = float(np.max(energy_error(ok))) / moved
    penetration = -float(np.min(col(ok, "gap_min")))
    t = col(ok, "time")
    rate = float(np.sum(col(ok, "solver.substeps"))) / (t[-1] * 1e3)
    identical = all(np.array_equal(first, other, equal_nan=True) for other in runs[1:])
    measured = {
        "energy": rel,
        "energy_abs": float(np.max(energy_error(ok))),
        "scale": moved,
        "penetration": penetration,
        "steps_per_ms": rate,
        "max_substeps": float(np.max(col(ok, "solver.substeps"))),
        "identical": identical,
        "runs": len(runs),
        "finite": bool(np.all(np.isfinite(ok))),
        "discarded": int(np.sum(col(first, "status") == 2)),
    }
    record(
        case=case,
        fidelity=fidelity,
        **measured,
        bound_energy=ENERGY[case][fidelity],
        bound_steps_per_ms=STEPS_PER_MS[case],
    )
    assert identical, "two runs of the same case differ"
    if not allow_discard:
        assert np.all(col(first, "status") == 0), "a doStep was discarded"
    assert measured["finite"], "an output is not finite"
    assert rel <= ENERGY[case][fidelity], (rel, moved)
    assert penetration < PENETRATION, penetration
    assert rate <= STEPS_PER_MS[case], rate
    return measured


def preset(name: str) -> dict:
    return {"stiff": STIFF, "compliant": COMPLIANT}[name]


# ----------------------------------------------------------------------------- 1. high-speed impact
def high_speed(fidelity, name):
    params = {**preset(name), **COARSE, **STALL_GUARD, "model.fidelity": fidelity, "theta0": 0.08, "omega0": -15.0}
    return params, [(1e-3, 0.0)] * 40


@pytest.mark.parametrize("name", ["stiff", "compliant"])
@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_high_speed_impact(fmus, fidelity, name):
    """omega0 = -15 rad/s (3.6 m/s at the head) from 19 mm before the wall: it hits and rebounds."""
    params, schedule = high_speed(fidelity, name)
    runs = run_schedule(fmus[0], params, schedule, repeat=2)
    check_common("high_speed", fidelity, runs)
    omega = col(runs[0], "omega")
    assert omega[0] < -14.0 and omega[-1] > 0.0  # it rebounded
    assert col(runs[0], "gap_min").min() < 0.0  # through contact


# ------------------------------------------------------------------------ 2. large communication steps
def phase_bound(t_end: float, max_step: float, theta_amp: float) -> tuple[float, float]:
    """(theta, omega) bounds for two step sequences of the same free flight: twice the midpoint
    rule's phase error over t_end, omega_n t_end (omega_n max_step)^2 / 12 radians of phase, for the
    small-angle pendulum frequency omega_n of the rigid body (the FE proxy follows the same swing)."""
    rigid = create(stiff(**{"model.fidelity": "rigid"}))
    omega_n = math.sqrt(rigid.total_mass * 9.81 * rigid.com_depth / rigid.inertia)
    phase = omega_n * t_end * (omega_n * max_step) ** 2 / 12.0
    return 2.0 * theta_amp * phase, 2.0 * theta_amp * omega_n * phase


@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_large_communication_steps_across_an_impact(fmus, fidelity):
    """0.1 s and 0.5 s doSteps across the impact at 0.24 s reach the 1 ms run's state within the
    step control's free-flight accuracy (the impact itself is located and resolved the same way)."""
    params = {**COARSE, **STALL_GUARD, "model.fidelity": fidelity}
    fine = run_schedule(fmus[0], params, [(1e-3, 0.0)] * 500)[0]
    dtheta, domega = phase_bound(0.5, 2e-3, math.radians(20.0))
    for h in (0.1, 0.5):
        runs = run_schedule(fmus[0], params, [(h, 0.0)] * int(round(0.5 / h)), repeat=2 if h == 0.5 else 1)
        check_common("large_steps", fidelity, runs)
        coarse = runs[0]
        rows = [int(round(t / 1e-3)) for t in col(coarse, "time")]
        record(
            case="large_steps",
            fidelity=fidelity,
            h=h,
            dtheta=float(np.max(np.abs(col(coarse, "theta") - col(fine, "theta")[rows]))),
            domega=float(np.max(np.abs(col(coarse, "omega") - col(fine, "omega")[rows]))),
            bound_dtheta=dtheta,
            bound_domega=domega,
        )
        assert np.max(np.abs(col(coarse, "theta") - col(fine, "theta")[rows])) <= dtheta
        assert np.max(np.abs(col(coarse, "omega") - col(fine, "omega")[rows])) <= domega
        # the impact happened inside a doStep: gap_min saw it, the samples did not
        assert col(coarse, "gap_min").min() < 0.0 < col(coarse, "gap").min()
    check_common("large_steps", fidelity, [fine])


# ------------------------------------------------------------------------------- 3. violent torque
def violent(fidelity):
    schedule = [(1e-3, 50.0 if (k // 150) % 2 == 0 else -50.0) for k in range(300)]
    return {**COARSE, **STALL_GUARD, "model.fidelity": fidelity, "theta0": 0.0}, schedule


@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_violent_square_wave_torque_over_the_top(fmus, fidelity):
    """+-50 N.m, 0.15 s each way, steel: over the top at ~100 rad/s, the head strikes the block's
    back face (x_min) at about 0.1 s and its front face after the reversal. (The head cannot reach
    the top face or its corners: they lie 0.129-0.143 m from the pivot, the head no closer than
    0.18 m; docs/notes/robustness.md.)"""
    params, schedule = violent(fidelity)
    runs = run_schedule(fmus[0], params, schedule, repeat=2)
    check_common("violent", fidelity, runs)
    run = runs[0]
    theta, omega, gap_min = col(run, "theta"), col(run, "omega"), col(run, "gap_min")
    assert np.max(np.abs(omega)) > 50.0
    assert np.any(np.abs(theta) > 3.0)  # over the top
    hits = np.flatnonzero(gap_min < 0.0)
    assert np.any(theta[hits] < -0.5), "no impact on the back face"
    assert np.any(np.abs(theta[hits]) < 0.2), "no impact on the front face"


# ------------------------------------------------------------------------------ 4. resting contact
RESTING_FORCE = 5e-3  # mean contact force (impulse over time) / (|T| / D): measured within 1.9e-3 over 0.3 s


def resting(fidelity):
    return {**COARSE, **STALL_GUARD, "model.fidelity": fidelity, "theta0": 0.0}, [(1e-3, -5.0)] * 300


@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_resting_contact_under_constant_torque(fmus, fidelity):
    """-5 N.m from rest touching the wall (steel, no damping), 0.3 s in 1 ms doSteps: the held contact
    takes free-flight steps (at most 3 per ms, check_common), and still the mean contact force, the
    contact impulse over the run's time, is the torque's reaction |T| / D within 0.5 %; the undamped
    normal vibration stays bounded and the head does not leave the wall by more than the rod's
    bending deflection under the torque."""
    params, schedule = resting(fidelity)
    runs = run_schedule(fmus[0], params, schedule, repeat=2)
    check_common("resting", fidelity, runs)
    run = runs[0][1:]
    scene = stiff()
    reaction = 5.0 / scene.geometry.head_centre_depth  # the head touches level with its centre
    mean_force = float(np.sum(col(run, "contact_impulse")) / col(run, "time")[-1])
    force = col(run, "contact_force")  # samples of the vibration, which held steps do not resolve
    half = len(force) // 2
    w, E, h = scene.geometry.rod_half_width, scene.pendulum.E, scene.pendulum.thickness
    length = scene.geometry.head_centre_depth - scene.geometry.head_radius
    lift_off = 2.0 * 5.0 * length**2 / (2.0 * E * h * (2.0 * w) ** 3 / 12.0)  # twice the static tip deflection
    record(
        case="resting",
        fidelity=fidelity,
        mean_force_ratio=mean_force / reaction,
        sampled_force_ratio=float(force.mean() / reaction),
        max_force_ratio=float(force.max() / reaction),
        growth=float(force[half:].max() / force[:half].max()),
        max_gap=float(col(run, "gap").max()),
        bound_gap=lift_off,
    )
    assert abs(mean_force / reaction - 1.0) < RESTING_FORCE, mean_force / reaction
    assert force.max() < 10.0 * reaction and force[half:].max() < 1.5 * force[:half].max()
    assert col(run, "gap").max() <= (1e-12 if fidelity == "rigid" else lift_off)


# ------------------------------------------------------------------------------- 5. grazing contact
@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_grazing_release_at_half_a_degree(fmus, fidelity):
    params = {**COARSE, **STALL_GUARD, "model.fidelity": fidelity, "theta0": math.radians(0.5)}
    runs = run_schedule(fmus[0], params, [(1e-3, 0.0)] * 600, repeat=2)
    check_common("grazing", fidelity, runs)
    run = runs[0]
    assert col(run, "gap_min").min() < 0.0  # it touched
    assert col(run, "theta")[300:].max() > math.radians(0.45)  # and swung back out


@pytest.mark.parametrize("name", ["stiff", "compliant"])
@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_at_rest_touching_the_wall_stays_at_rest(fmus, fidelity, name):
    """theta0 = 0: the head's circle touches the wall face. No energy is created, and the pendulum
    moves no more than its initial contact energy can swing it (the curved order-3 rubber mesh
    bulges 6 um past the circle, so it starts pressed in and is pushed off; the FE body also sags
    under gravity, which moves theta by about 1e-6 rad)."""
    params = {**preset(name), **COARSE, **STALL_GUARD, "model.fidelity": fidelity, "theta0": 0.0}
    runs = run_schedule(fmus[0], params, [(1e-3, 0.0)] * (200 if name == "stiff" else 60), repeat=2)
    e = col(runs[0], "energy.total")
    check_common("at_rest", fidelity, runs, scale=abs(e[0]))
    run = runs[0]
    assert np.max(e - e[0]) <= ENERGY["at_rest"][fidelity] * abs(e[0])  # no energy created
    rigid = create(stiff(**{"model.fidelity": "rigid", **preset(name)}))
    mgd = rigid.total_mass * 9.81 * rigid.com_depth
    swing = math.sqrt(2.0 * col(run, "energy.contact")[0] / mgd)  # 1/2 mgd theta^2 = initial contact energy
    record(
        case="at_rest",
        fidelity=fidelity,
        preset=name,
        energy_gain=float(np.max(e - e[0])),
        max_theta=float(np.max(np.abs(col(run, "theta")))),
        bound_theta=1.1 * swing + 1e-5,
    )
    assert np.max(np.abs(col(run, "theta"))) <= 1.1 * swing + 1e-5


# ----------------------------------------------------------------------- 6. compliant large deformation
@pytest.mark.slow
def test_rubber_torque_pulse_discards_cleanly_when_the_hinge_collapses(fmus):
    """2 N.m held on the rubber pendulum crushes the hinge edge (the torque is a traction there,
    1.3 E at its corners): an element would invert at t = 2.3 ms, no step down to 1e-9 s avoids it,
    and the doStep is discarded with the state as before it."""
    params = {**COMPLIANT, **COARSE, **STALL_GUARD, "model.fidelity": "fem", "theta0": 0.0}
    runs = run_schedule(fmus[0], params, [(1e-3, 2.0)] * 5, repeat=2)
    check_common("rubber_pulse", "fem", runs, allow_discard=True)
    run = runs[0]
    status = col(run, "status")
    assert list(status) == [0, 0, 0, 2]  # t = 0, 1 ms, 2 ms, then the doStep to 3 ms is discarded
    assert np.array_equal(run[-1][1:-2], run[-2][1:-2])  # outputs as before the step


@pytest.mark.slow
def test_rubber_short_pulse_keeps_every_element_upright():
    """A 1 ms pulse of 2 N.m (4.2 J into the 0.14 kg rubber pendulum): det F > 0 at every
    integration point after every step, outputs finite, energy within the rubber bound."""
    model = create(compliant(**{**COARSE, "theta0": 0.0}))
    e0 = model.outputs().total
    worst_det, worst_err, work = math.inf, 0.0, 0.0
    for k in range(1, 21):
        out = model.advance(k * 1e-3, 2.0 if k == 1 else 0.0)
        assert all(math.isfinite(v) for v in out.as_dict().values())
        worst_det = min(worst_det, model.min_det_F())
        worst_err = max(worst_err, abs(out.total - e0 - out.torque_work))
        work = max(work, abs(out.torque_work))
    record(
        case="rubber_short_pulse",
        fidelity="fem",
        min_det_F=worst_det,
        energy=worst_err / work,
        energy_abs=worst_err,
        scale=work,
        bound_energy=ENERGY["rubber_pulse"]["fem"],
    )
    assert worst_det > 0.2, worst_det
    assert worst_err <= ENERGY["rubber_pulse"]["fem"] * work, (worst_err, work)


# ------------------------------------------------------------------- 7. deformable wall, compliant
@pytest.mark.slow
def test_deformable_wall_with_the_compliant_pendulum(fmus):
    """The meshed steel block and the rubber pendulum (order 2 for speed): 0.24 m/s at the head
    (omega0 = -1 rad/s) from 1.2 mm before the wall, through the first 7 ms of a long, soft contact."""
    params = {
        **COMPLIANT,
        **COARSE,
        **STALL_GUARD,
        "model.order": 2,
        "model.fidelity": "fem",
        "wall.kind": "deformable",
        "theta0": 0.005,
        "omega0": -1.0,
    }
    runs = run_schedule(fmus[0], params, [(1e-3, 0.0)] * 12, repeat=2)
    check_common("deformable_wall", "fem", runs)
    assert col(runs[0], "contact_force").max() > 0.5
