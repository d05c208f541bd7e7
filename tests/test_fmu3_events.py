"""The FMI 3.0 FMU's early return at contact onset, intermediate update and event mode (fmpy's FMU3Slave).

Rigid fidelity, the default scene (stiff, released at 20 degrees): the first impact begins at 239.47 ms
and lasts 0.3376 ms (the closed forms of tests/pendulum_closed_form.py). Each run is in a fresh
interpreter (tests/in_child.py).
"""

from __future__ import annotations

from pathlib import Path

import pendulum_closed_form as closed
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmu3_instance import Instance3, child

RIGID = {"model.fidelity": 2}
MODULE = Path(__file__).stem


def first_contact() -> float:
    """The first contact's time (s), 239.47 ms. Only in pytest's process: a child imports no fem_pendulum_fmu
    of its own before the FMU's."""
    from fem_pendulum_fmu.physics.scene import Scene

    return closed.first_impact(Scene()).time


def early_return(fmu: str, fmu2: str) -> dict:
    """(In a child.) A 0.5 s doStep from the release with and without early return; the FMI 2.0 FMU's."""
    inst = Instance3(fmu, early_return=True, **RIGID)
    _, early, t = inst.step(0.5)
    gap, gap_min, time = inst.get("gap", "gap_min", "time")
    _, early_next, t_next = inst.step(0.5 - t)  # from the contact on: the next onset is after 0.5 s
    inst.close()
    plain = Instance3(fmu, **RIGID)
    _, early_off, t_off = plain.step(0.5)
    theta_off = plain.get("theta", "omega")
    plain.close()
    fmi2 = simulate_fmu(fmu2, stop_time=0.5, output_interval=0.5, start_values=RIGID)  # one doStep of 0.5 s
    return {
        "early": early,
        "t": t,
        "gap": gap,
        "gap_min": gap_min,
        "time": time,
        "early_next": early_next,
        "t_next": t_next,
        "early_off": early_off,
        "t_off": t_off,
        "theta_off": theta_off,
        "theta_fmi2": [float(fmi2["theta"][-1]), float(fmi2["omega"][-1])],
    }


def test_a_step_across_contact_onset_returns_early_there_and_only_when_allowed(fmu3, fmus):
    got = child(MODULE, "early_return", str(fmu3), str(fmus[0]))
    assert got["early"] and got["time"] == got["t"]
    assert abs(got["t"] - first_contact()) < 2e-4  # the step ends at the internal step where the gap closes
    assert got["gap"] <= 0.0 and got["gap_min"] <= 0.0
    assert not got["early_next"] and got["t_next"] == pytest.approx(0.5, abs=1e-12)
    assert not got["early_off"] and got["t_off"] == 0.5
    assert got["theta_off"] == got["theta_fmi2"]  # without early return, steps are exactly the FMI 2.0 FMU's


def intermediate_updates(fmu: str, allowed: bool) -> dict:
    """(In a child.) A 0.2 s doStep of free flight whose host asks, at the third intermediate update, to
    return early."""
    calls: list[list] = []
    inside: list[str] = []  # what a call on the instance from inside the callback answered
    holder: list[Instance3] = []

    def update(env, time, set_requested, get_allowed, finished, can_return, requested, early_time):
        calls.append([time, bool(set_requested), bool(get_allowed), bool(finished), bool(can_return)])
        if len(calls) == 1:
            try:
                holder[0].fmu.getFloat64([holder[0].vr("theta")])
                inside.append("ok")
            except FMICallException as exc:
                inside.append(str(exc))
        if len(calls) == 3:
            requested[0] = True

    inst = Instance3(fmu, early_return=allowed, intermediate=update, **RIGID)
    holder.append(inst)
    _, early, t = inst.step(0.2)
    inst.close()
    return {"calls": calls, "early": early, "t": t, "inside": inside, "messages": inst.messages}


@pytest.mark.slow
def test_intermediate_update_is_called_at_internal_steps_and_an_early_return_asked_there_is_granted(fmu3):
    got = child(MODULE, "intermediate_updates", str(fmu3), True)
    calls = got["calls"]
    assert len(calls) == 3 and all(c[1:] == [False, False, True, True] for c in calls)
    assert 0.0 < calls[0][0] < calls[1][0] < calls[2][0] < 0.2
    assert got["early"] and got["t"] == calls[2][0]
    assert len(got["inside"]) == 1 and "status 3" in got["inside"][0]  # no variable access inside the callback
    assert any("fmi3GetFloat64 refused: called during fmi3DoStep" in m for _, m in got["messages"])
    not_allowed = child(MODULE, "intermediate_updates", str(fmu3), False)
    assert not not_allowed["early"] and not_allowed["t"] == pytest.approx(0.2, abs=1e-12)
    assert len(not_allowed["calls"]) > 3 and all(c[4] is False for c in not_allowed["calls"])


def event_run(fmu: str, event_mode: bool) -> dict:
    """(In a child.) 0.3 s at 0.1 ms steps: the times of the steps that asked for event handling."""
    inst = Instance3(fmu, event_mode=event_mode, **RIGID)
    flagged, thetas = [], []
    for _ in range(3000):
        event, _, t = inst.step(1e-4)
        if event:
            flagged.append(t)
        thetas.append(inst.get("theta")[0])
    events = inst.events
    inst.close()
    return {"flagged": flagged, "thetas": thetas, "events": events}


@pytest.mark.slow
def test_contact_onset_and_release_are_events_in_event_mode_and_change_nothing(fmu3):
    on, off = child(MODULE, "event_run", str(fmu3), True), child(MODULE, "event_run", str(fmu3), False)
    onset, release = on["flagged"]  # the first impact: 0.3376 ms long, three or four steps of 0.1 ms
    assert onset == pytest.approx(first_contact(), abs=2e-4) and 2e-4 < release - onset < 6e-4
    assert on["events"] == 2 and off["flagged"] == [] and off["events"] == 0
    assert on["thetas"] == off["thetas"]


def event_mode_calls(fmu: str) -> list[str]:
    """(In a child.) Calls out of turn in event mode: each answer, in order."""
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(fmu)
    slave = FMU3Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier="FemPendulum")
    messages: list[str] = []
    slave.instantiate(eventModeUsed=True, logMessage=lambda e, s, c, m: messages.append(m.decode()))
    slave.enterInitializationMode()
    slave.setInt64([md.modelVariables[25].valueReference], [2])
    answers = []
    for call in (
        slave.exitInitializationMode,  # -> eventMode
        lambda: slave.doStep(0.0, 1e-3),  # refused: not in stepMode
        slave.updateDiscreteStates,
        slave.enterStepMode,
        slave.enterStepMode,  # refused: already in stepMode
        lambda: slave.doStep(0.0, 1e-3),
    ):
        try:
            call()
            answers.append("ok")
        except FMICallException as exc:
            answers.append(str(exc))
    slave.terminate()
    slave.freeInstance()
    return answers + messages


def test_event_mode_state_machine(fmu3):
    got = child(MODULE, "event_mode_calls", str(fmu3))
    answers, messages = got[:6], got[6:]
    assert answers[0] == answers[2] == answers[3] == answers[5] == "ok"
    assert "status 3" in answers[1] and "status 3" in answers[4]
    assert any("fmi3DoStep refused in state eventMode (allowed in: stepMode)" in m for m in messages), messages
    assert any("fmi3EnterStepMode refused in state stepMode (allowed in: eventMode)" in m for m in messages)
