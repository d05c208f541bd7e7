"""Faults a master can meet, through fmpy's FMU2Slave and through the model's Python API.

Already covered elsewhere (not repeated here): NaN/inf torque, step <= 0, a jumping communication
point, a parameter after initialisation, pendulum.nu = 0.5, corrupt state bytes
(tests/test_fmu.py, tests/test_slave.py), bad values of every range in the Python API
(tests/test_fem.py::test_bad_parameters_are_named_with_value_and_range).
"""

from __future__ import annotations

import math
import resource

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmu_runner import fmi_value
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from isolated import isolated
from test_fmu import Instance

from fem_pendulum_fmu.physics.fidelity import AVAILABLE, StepFailed, create
from fem_pendulum_fmu.physics.scene import stiff

RIGID_WALL = [f for f in ("rigid", "reduced", "fem") if f in AVAILABLE]
COARSE = {"model.mesh_size": 0.06}
OUTPUTS = ("theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work", "gap_min")


# ------------------------------------------------------------------ a step the model cannot complete
@pytest.mark.parametrize("fidelity", RIGID_WALL)
def test_a_step_over_budget_fails_with_the_state_kept_and_a_retry_is_exact(fidelity):
    """solver.max_substeps: an advance needing more internal steps raises StepFailed, the state
    (and the FE model's held Jacobian) stays as before, and the retry in smaller steps gives
    bit-identically what a model that never failed gives."""
    scene = stiff(**{**COARSE, "model.fidelity": fidelity, "theta0": 0.05, "omega0": -1.0, "solver.max_substeps": 30})
    ref, model = create(scene), create(scene)
    times = [k * 1e-3 for k in range(1, 81)]
    expected = [ref.advance(t, -0.5).as_dict() for t in times]
    for t in times[:20]:
        model.advance(t, -0.5)
    before = model.get_state()
    with pytest.raises(StepFailed, match="solver.max_substeps = 30"):
        model.advance(times[-1], -0.5)  # 60 ms: 30 free-flight steps and an impact
    after = model.get_state()
    assert after.time == before.time and after.scalars == before.scalars
    assert all(np.array_equal(after.arrays[k], before.arrays[k]) for k in before.arrays)
    got = [model.advance(t, -0.5).as_dict() for t in times[20:]]
    assert got == expected[20:]
    assert min(o["gap"] for o in expected) < 0.002 and max(o["contact_force"] for o in expected) > 0


def _retrying_master(inst, t_end, h0, torque):
    """Step to t_end in steps of h0; on fmi2Discard restore the state saved before the step
    and retry with a quarter of the step; after a success the step doubles again, up to h0.
    Returns (the steps that succeeded, discards)."""
    done, discards = [], 0
    h = h0
    while inst.t < t_end - 1e-12:
        h = min(h, t_end - inst.t)
        saved = inst.fmu.getFMUstate()
        before = inst.get(*OUTPUTS)
        inst.set("torque", torque)
        try:
            inst.fmu.doStep(inst.t, h)
        except FMICallException as exc:
            assert "status 2" in str(exc)  # fmi2Discard
            assert inst.get(*OUTPUTS) == before  # state as before the step
            inst.fmu.setFMUstate(saved)
            inst.fmu.freeFMUstate(saved)
            discards += 1
            h /= 4.0
            continue
        inst.fmu.freeFMUstate(saved)
        inst.t += h
        done.append(h)
        h = min(h0, 2.0 * h)
    return done, discards


@pytest.mark.slow
@isolated
def test_a_master_restores_and_retries_with_smaller_steps(fmus, tmp_path):
    fmu, _ = fmus
    for fidelity in RIGID_WALL:
        start = {**COARSE, "model.fidelity": fmi_value("model.fidelity", fidelity), "theta0": 0.05, "omega0": -1.0}
        inst = Instance(fmu, f"budget-{fidelity}", **start, **{"solver.max_substeps": 25})
        done, discards = _retrying_master(inst, 0.1, 0.1, -0.5)
        assert discards >= 2 and abs(sum(done) - 0.1) < 1e-12
        result = inst.get(*OUTPUTS)
        assert any("solver.max_substeps = 25" in m for m in inst.messages)
        inst.close()
        free = Instance(fmu, f"free-{fidelity}", **start)  # no budget, the same communication steps
        for h in done:
            free.step(h, -0.5)
        assert free.get(*OUTPUTS) == result, fidelity
        free.close()


# ------------------------------------------------------------------- parameters at initialisation
BAD_PARAMETERS = [
    ("pendulum.E", 0.0, "(0, inf)"),
    ("pendulum.thickness", -0.01, "(0, inf)"),
    ("model.order", 1, "[2, 5]"),
    ("model.order", 10, "[2, 5]"),
    ("wall.kind", 7, "choose one of 1 (rigid)"),
    ("model.fidelity", 9, "choose one of 1 (auto)"),
    ("solver.max_substeps", -1, "[0, 1000000000]"),
    ("model.mesh_size", 1e-5, "more than this machine's"),
]


@pytest.mark.slow
@isolated
def test_invalid_parameters_are_refused_at_initialisation_naming_the_range(fmus, tmp_path):
    fmu, _ = fmus
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for name, value, allowed in BAD_PARAMETERS:
        messages: list[str] = []
        with pytest.raises(FMICallException, match=r"fmi2ExitInitializationMode failed with status 3 \(error\)"):
            Instance(fmu, messages=messages, **{**COARSE, name: value})
        assert any(name in m and repr(value) in m and allowed in m for m in messages), (name, messages)
    # the 1e-5 m mesh (about 15 TiB by the estimate) was refused before anything was meshed
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 300_000  # kB
    probe = Instance(fmu, "probe", **COARSE)
    probe.step(1e-3)
    probe.close()


# ----------------------------------------------------------- bad calls: an error, never a crash
@isolated
def test_unknown_value_references_and_calls_after_terminate_are_errors(fmus, tmp_path):
    fmu, _ = fmus
    inst = Instance(fmu, **COARSE)
    inst.step(1e-3)
    before = inst.get(*OUTPUTS)
    for call in (
        lambda: inst.fmu.getReal([999]),
        lambda: inst.fmu.setReal([999], [1.0]),
        lambda: inst.fmu.setReal([inst.var["theta"].valueReference], [0.3]),
        lambda: inst.fmu.getInteger([inst.var["theta"].valueReference]),
    ):
        with pytest.raises(FMICallException, match=r"status 3 \(error\)"):
            call()
    assert inst.get(*OUTPUTS) == before
    assert any("value reference 999 is no variable" in m for m in inst.messages)
    assert any("theta (value reference 1) is an output" in m for m in inst.messages)
    inst.step(1e-3)  # goes on
    inst.fmu.terminate()
    with pytest.raises(FMICallException, match=r"status 3 \(error\)"):
        inst.fmu.doStep(inst.t, 1e-3)
    assert any("terminated" in m for m in inst.messages)
    inst.fmu.fmi2FreeInstance(inst.fmu.component)


# ------------------------------------------------------------------------ property-based: no crash
TORQUE = st.floats(min_value=-50.0, max_value=50.0, allow_nan=False)
STEP = st.sampled_from([1e-4, 5e-4, 1e-3, 4e-3, 1e-2, 3e-2])


def _energy_check(model, schedule, rel_bound, floor):
    """|E - E0 - W| <= rel_bound * (energy moved) + floor * |E0| after every step; outputs finite."""
    e0 = model.outputs().total
    t, moved, worst = 0.0, 0.0, 0.0
    for h, torque in schedule:
        t += h
        out = model.advance(t, torque)
        values = out.as_dict()
        assert all(math.isfinite(v) for k, v in values.items() if k != "min_gap"), values
        moved = max(moved, out.kinetic + out.strain + out.contact + abs(out.torque_work))
        worst = max(worst, abs(out.total - e0 - out.torque_work))
    assert worst <= rel_bound * moved + floor * abs(e0), (worst, moved, e0)


@pytest.mark.slow  # hypothesis draws long schedules: 2 to 27 s in four runs
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    schedule=st.lists(st.tuples(STEP, TORQUE), min_size=1, max_size=40),
    theta0=st.floats(min_value=-0.6, max_value=0.6),
    omega0=st.floats(min_value=-15.0, max_value=15.0),
)
def test_random_torques_and_steps_never_crash_the_rigid_model(schedule, theta0, omega0):
    model = create(stiff(**{"model.fidelity": "rigid", "theta0": theta0, "omega0": omega0}))
    _energy_check(model, schedule, 1e-9, 1e-13)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    schedule=st.lists(st.tuples(STEP, st.floats(min_value=-5.0, max_value=5.0)), min_size=1, max_size=6),
    theta0=st.floats(min_value=0.0, max_value=0.3),
)
def test_random_torques_and_steps_never_crash_the_fe_model(schedule, theta0):
    """Released outside the wall: theta0 < 0 starts the head inside the block, and releasing that
    penalty energy (18 kJ at 7.5 mm) is an explosion, not an operating point (docs/notes/robustness.md)."""
    model = create(stiff(**{**COARSE, "theta0": theta0}))
    _energy_check(model, schedule, 1e-5, 1e-9)  # floor: the Newton tolerance
