"""The FMI 3.0 FMU (fem-pendulum build --fmi-version 3): validation, the interface of the one declaration,
the FMI 2.0 FMU's results, FMU states and refusals.

Each test that instantiates the FMU does so in a fresh interpreter (tests/in_child.py runs a function of
this module there and returns what it returned); the parent asserts.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu
from fmu3_instance import Instance3, child

MODULE = Path(__file__).stem
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Enumeration": "Enumeration", "Boolean": "Boolean"}
FIDELITY = {"rigid": 2, "reduced": 3, "fem": 4}


def test_fmu_passes_fmpy_validation_with_the_interface_of_the_template(fmu3, fmus):
    assert validate_fmu(str(fmu3)) == []
    md3, md2 = read_model_description(str(fmu3)), read_model_description(str(fmus[0]))
    assert md3.fmiVersion == "3.0" and md3.guid.startswith("{")
    v3 = {v.name: v for v in md3.modelVariables}
    for v in md2.modelVariables:
        w = v3[v.name]
        assert (w.valueReference, w.causality, w.variability) == (v.valueReference, v.causality, v.variability)
        assert w.type == FMI3_TYPES.get(v.type, v.type) and (w.unit, w.displayUnit) == (v.unit, v.displayUnit)
        assert w.declaredType is None or w.declaredType.name == v.declaredType.name
        assert str(w.start) == str(v.start) or float(w.start) == float(v.start)
    assert v3["time"].causality == "independent"
    with zipfile.ZipFile(fmu3) as archive:
        cosim = ElementTree.fromstring(archive.read("modelDescription.xml")).find("CoSimulation")
    assert cosim is not None
    for flag in ("canGetAndSetFMUState", "canSerializeFMUState", "hasEventMode", "providesIntermediateUpdate"):
        assert cosim.get(flag) == "true", flag
    assert cosim.get("canReturnEarlyAfterIntermediateUpdate") == "true"


def test_terminal_of_the_hinge_flange_names_angle_speed_and_torque(fmu3):
    with zipfile.ZipFile(fmu3) as archive:
        root = ElementTree.fromstring(archive.read("terminalsAndIcons/terminalsAndIcons.xml"))
        names = {v.get("name") for v in ElementTree.fromstring(archive.read("modelDescription.xml")).iter()}
    (terminal,) = root.iter("Terminal")
    assert terminal.get("terminalKind") == "fem_pendulum_fmu.RotationalFlangeSignals"
    assert {m.get("variableKind") for m in terminal.iter("TerminalMemberVariable")} == {"signal"}
    members = {m.get("memberName"): m.get("variableName") for m in terminal.iter("TerminalMemberVariable")}
    assert members == {"phi": "theta", "w": "omega", "tau": "torque"}
    assert set(members.values()) <= names


def default_runs(fmu2: str, fmu3: str, fidelity: int, stop: float) -> dict[str, list[float]]:
    """(In a child.) The default scene through fmpy's simulate_fmu, FMI 2.0 and FMI 3.0 alike."""
    runs = {}
    for key, fmu in (("fmi2", fmu2), ("fmi3", fmu3)):
        result = simulate_fmu(fmu, stop_time=stop, output_interval=1e-3, start_values={"model.fidelity": fidelity})
        for name in ("time", "theta", "omega", "gap", "energy.total"):
            runs[f"{key} {name}"] = [float(x) for x in result[name]]
    return runs


@pytest.mark.parametrize("fidelity", ["rigid", "reduced", "fem"])
def test_default_scene_gives_the_fmi2_fmus_results(fmu3, fmus, fidelity):
    # 0.3 s: the release, the first impact at 239 ms and after; fem 0.05 s (0.6 s of CPU per simulated second)
    stop = 0.05 if fidelity == "fem" else 0.3
    runs = child(MODULE, "default_runs", str(fmus[0]), str(fmu3), FIDELITY[fidelity], stop)
    assert runs["fmi2 time"] == runs["fmi3 time"] and len(runs["fmi3 time"]) == round(stop / 1e-3) + 1
    theta2, theta3 = np.array(runs["fmi2 theta"]), np.array(runs["fmi3 theta"])
    assert np.max(np.abs(theta3 - theta2)) <= 1e-12  # round-off at most; the same code gives 0 here
    for name in ("omega", "gap", "energy.total"):
        assert runs[f"fmi3 {name}"] == runs[f"fmi2 {name}"]
    assert np.ptp(theta3) > 0.01  # it swung


def state_round_trip(fmu: str) -> dict:
    """(In a child.) Rollback through a state, through its bytes, and refused bytes."""
    inst = Instance3(fmu, **{"model.mesh_size": 0.06})
    for _ in range(5):
        inst.step(1e-3, 0.2)
    state, t = inst.fmu.getFMUState(), inst.t
    first = [inst.step(1e-3, -0.3) and inst.get("theta", "omega", "gap") for _ in range(10)]
    inst.fmu.setFMUState(state)
    inst.t = t
    again = [inst.step(1e-3, -0.3) and inst.get("theta", "omega", "gap") for _ in range(10)]
    blob = inst.fmu.serializeFMUState(state)
    restored = inst.fmu.deserializeFMUState(blob)
    inst.fmu.setFMUState(restored)
    inst.t = t
    from_bytes = [inst.step(1e-3, -0.3) and inst.get("theta", "omega", "gap") for _ in range(10)]
    before = inst.get("theta", "omega")
    refused = []
    for junk in (b"not a state", blob[:-1], blob[:80] + b"x" * (len(blob) - 80)):
        try:
            inst.fmu.deserializeFMUState(junk)
        except FMICallException as exc:
            refused.append(str(exc))
    after = inst.get("theta", "omega")
    other = Instance3(fmu, name="other", **{"model.mesh_size": 0.06, "gravity": 9.0})  # a state that does not fit
    try:
        other.fmu.deserializeFMUState(blob)
        refused.append("accepted")
    except FMICallException as exc:
        refused.append(str(exc))
    other.close()
    inst.close()
    return {
        "first": first,
        "again": again,
        "from_bytes": from_bytes,
        "refused": refused,
        "kept": before == after,
        "messages": inst.messages + other.messages,
        "magic": blob[:8].decode(),
    }


def test_state_round_trip_is_bit_identical_and_bad_bytes_are_refused(fmu3):
    got = child(MODULE, "state_round_trip", str(fmu3))
    assert got["first"] == got["again"] == got["from_bytes"]
    assert len(got["refused"]) == 4 and all("status 3" in r for r in got["refused"]) and got["kept"]
    errors = [m for s, m in got["messages"] if s == 3]
    assert any("fmi3DeserializeFMUState refused" in m and "too few" in m for m in errors), errors
    assert any("truncated" in m for m in errors) and any("not a serialised state" in m for m in errors)
    assert any("fmi3DeserializeFMUState refused" in m and "gravity" in m for m in errors), errors
    assert got["magic"] == "FEMPFMU3"


def refusals(fmu: str) -> dict:
    """(In a child, debug logging off.) A NaN torque, a call in the wrong state, a wrong token."""
    inst = Instance3(fmu, **{"model.fidelity": 2})
    inst.step(1e-3)
    theta = inst.get("theta")
    statuses = []
    inst.set("torque", float("nan"))
    for call in (
        lambda: inst.fmu.doStep(inst.t, 1e-3),
        lambda: inst.fmu.enterEventMode(),  # made without eventModeUsed
        lambda: inst.fmu.exitInitializationMode(),  # not in initializationMode
        lambda: inst.fmu.setFloat64([inst.vr("gravity")], [1.0]),  # a fixed parameter in stepMode
        lambda: inst.fmu.getFloat32([inst.vr("theta")]),  # no Float32 variable
    ):
        try:
            call()
            statuses.append("ok")
        except FMICallException as exc:
            statuses.append(str(exc))
    inst.set("torque", 0.0)
    inst.step(1e-3)
    kept = inst.get("theta") != theta and inst.t == pytest.approx(2e-3)
    inst.close()
    return {"statuses": statuses, "messages": inst.messages, "kept": kept, "token": wrong_token(fmu)}


def wrong_token(fmu: str) -> list[str]:
    """The messages of fmi3InstantiateCoSimulation with another FMU's instantiation token, and with required
    intermediate variables (NULL both times)."""
    from fmpy import extract
    from fmpy.fmi3 import FMU3Slave

    messages: list[str] = []
    folder, token = extract(fmu), read_model_description(fmu).guid
    for guid, required in (("{not-this-one}", None), (token, [1])):
        slave = FMU3Slave(guid=guid, unzipDirectory=folder, modelIdentifier="FemPendulum")
        try:
            slave.instantiate(
                logMessage=lambda env, status, category, message: messages.append(message.decode()),
                requiredIntermediateVariables=required,
            )
        except Exception as exc:  # fmpy raises when the instance is NULL
            messages.append(f"raised: {exc}")
    return messages


def test_refused_calls_are_errors_logged_without_debug_logging(fmu3):
    got = child(MODULE, "refusals", str(fmu3))
    assert all("status 3 (error)" in s for s in got["statuses"]), got["statuses"]
    errors = [m for s, m in got["messages"] if s == 3]
    assert any("torque = nan" in m for m in errors), errors
    assert any("fmi3EnterEventMode refused" in m and "eventModeUsed = false" in m for m in errors)
    assert any("fmi3ExitInitializationMode refused in state stepMode" in m for m in errors)
    assert any("gravity" in m and "cannot be set in state stepMode" in m for m in errors)
    assert any("fmi3GetFloat32 is not provided" in m for m in errors)
    assert got["kept"]
    assert any("instantiation token {not-this-one} is not this FMU's" in m for m in got["token"])
    assert got["token"].count("raised: Failed to instantiate FMU") == 2
    assert any("offers no intermediate variables" in m for m in got["token"])


def gap_profiles(fmu: str, fidelity: int) -> list[list[float]]:
    """(In a child.) [gap, *gap_profile] in free flight every 20 ms to 0.2 s, at contact onset (early return)
    and at five steps of 50 us into the contact."""
    inst = Instance3(fmu, early_return=True, **{"model.fidelity": fidelity, "model.mesh_size": 0.06})
    vr, size = inst.vr("gap_profile"), int(inst.var["gap_profile"].dimensions[0].start)

    def row() -> list[float]:
        return [*inst.get("gap"), *inst.fmu.getFloat64([vr], nValues=size)]

    rows = []
    for _ in range(10):
        inst.step(0.02)
        rows.append(row())
    assert inst.step(0.5)[1]  # returned early at contact onset
    for _ in range(6):
        rows.append(row())
        inst.step(5e-5)
    inst.close()
    return rows


# how far the profile's minimum may lie below the gap output (m): rigid, the round-off; reduced and fem, the FE
# boundary between its vertices off the exact circle the profile's points lie on, and the elastic rest interpolated
# (measured 4.2e-6 m and 5.8e-6 m on the coarse mesh, 2026-12-04)
BELOW = {"rigid": 1e-12, "reduced": 1e-5, "fem": 1e-5}
# at contact the closest point is the profile's first: the profile's minimum is the gap to within the rotation's
# effect over the penetration (rigid, measured 1.8e-9 m) and the above (reduced, fem: measured 4.0e-6, 5.6e-6 m)
AT_CONTACT = {"rigid": 1e-8, "reduced": 1e-5, "fem": 1e-5}


@pytest.mark.parametrize("fidelity", ["rigid", "reduced", "fem"])
def test_the_gap_profile_array_agrees_with_the_gap(fmu3, fidelity):
    rows = np.array(child(MODULE, "gap_profiles", str(fmu3), FIDELITY[fidelity]))
    gap, profile = rows[:, 0], rows[:, 1:]
    assert profile.shape == (16, 15)
    assert np.all(profile.min(axis=1) >= gap - BELOW[fidelity])
    free, contact = slice(0, 10), slice(10, 16)
    assert np.all(gap[free] > 1e-3) and np.all(profile[free].min(axis=1) - gap[free] > 0.0)
    assert np.all(gap[contact] <= 0.0) and np.all(profile[contact].argmin(axis=1) == 0)
    assert np.max(np.abs(profile[contact].min(axis=1) - gap[contact])) <= AT_CONTACT[fidelity]


def raising_calls(fmu: str) -> dict:
    """(In a child.) Each FMI 3.0 call whose slave entry point raises, in stepMode: its status; then the
    same calls with nothing raising."""
    import os

    inst = Instance3(fmu, **{"model.fidelity": 2})
    state = inst.fmu.getFMUState()
    theta = inst.vr("theta")
    calls = {
        "doStep": lambda: inst.fmu.doStep(inst.t, 1e-3),
        "getFloat64": lambda: inst.fmu.getFloat64([theta]),
        "setFloat64": lambda: inst.fmu.setFloat64([inst.vr("torque")], [0.5]),
        "getInt64": lambda: inst.fmu.getInt64([inst.vr("model.fidelity")]),
        "getFMUState": inst.fmu.getFMUState,
        "setFMUState": lambda: inst.fmu.setFMUState(state),
        "serializeFMUState": lambda: inst.fmu.serializeFMUState(state),
        "terminate": inst.fmu.terminate,
    }
    answers: dict[str, list[str]] = {}
    for switch in ("*", ""):
        os.environ["RAISE3"] = switch
        for name, call in calls.items():
            try:
                call()
                answers.setdefault(name, []).append("ok")
            except FMICallException as exc:
                answers.setdefault(name, []).append(str(exc))
    inst.fmu.freeInstance()
    return {"answers": answers, "messages": inst.messages}


def test_a_slave_that_raises_answers_error_never_fatal(fmu3, tmp_path):
    copy = tmp_path / "Raising3.fmu"
    with zipfile.ZipFile(fmu3) as src, zipfile.ZipFile(copy, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "resources/femp3_slave_entry.py":
                data = (Path(__file__).parent / "raising_entry3.py").read_bytes()
            dst.writestr(item, data)
    got = child(MODULE, "raising_calls", str(copy))
    for name, (raising, plain) in got["answers"].items():
        assert "status 3 (error)" in raising and plain == "ok", (name, raising, plain)
    errors = [m for s, m in got["messages"] if s == 3]
    assert sum("raised on purpose" in m for m in errors) == len(got["answers"]), errors
    assert not any(s == 4 for s, _ in got["messages"])


def output_derivatives(fmu3: str, fmu2: str) -> dict:
    """(In a child.) theta' theta'' omega' energy.total' after five driven steps, FMI 3.0 and FMI 2.0; refusals."""
    from test_fmu import Instance as Instance2

    names, orders = ["theta", "theta", "omega", "energy.total"], [1, 2, 1, 1]
    got: dict = {}
    inst3, inst2 = Instance3(fmu3, **{"model.fidelity": 2}), Instance2(Path(fmu2), **{"model.fidelity": 2})
    for _ in range(5):
        inst3.step(1e-3, 0.2)
        inst2.step(1e-3, 0.2)
    got["fmi3"] = inst3.fmu.getOutputDerivatives([inst3.vr(n) for n in names], orders)
    got["fmi2"] = list(inst2.fmu.getRealOutputDerivatives([inst2.var[n].valueReference for n in names], orders))
    got["refused"] = []
    for name in ("gap_min", "gap_profile"):
        try:
            inst3.fmu.getOutputDerivatives([inst3.vr(name)], [1])
            got["refused"].append("ok")
        except FMICallException as exc:
            got["refused"].append(str(exc))
    got["messages"] = [m for s, m in inst3.messages if s == 3]
    inst3.close()
    inst2.close()
    return got


def test_output_derivatives_are_the_fmi2_fmus(fmu3, fmus):
    got = child(MODULE, "output_derivatives", str(fmu3), str(fmus[0]))
    assert got["fmi3"] == got["fmi2"] and got["fmi3"][0] != 0.0
    assert all("status 3" in r for r in got["refused"])
    assert any("gap_min (value reference 37) is a discrete output" in m for m in got["messages"]), got["messages"]
    assert any(
        "fmi3GetOutputDerivatives refused: nValues is 1, the 1 variables have 15 elements" in m for m in got["messages"]
    )


SCALARS = ("time", "theta", "omega", "gap", "contact_force", "energy.total", "energy.torque_work", "gap_min")


def _fresh(inst: Instance3, name: str, event_mode: bool = False) -> tuple[FMU3Slave, list[tuple[int, str]]]:
    """A new instance of the FMU `inst` runs (its extraction folder), instantiated only, and its log."""
    messages: list[tuple[int, str]] = []
    fresh = FMU3Slave(guid=inst.md.guid, unzipDirectory=inst.dir, modelIdentifier="FemPendulum", instanceName=name)
    fresh.instantiate(
        eventModeUsed=event_mode,
        logMessage=lambda env, status, category, message: messages.append((int(status), message.decode())),
    )
    return fresh, messages


def _attempt(call) -> int:
    """The status of `call` (fmpy raises for anything above fmi3Warning)."""
    try:
        call()
    except FMICallException as exc:
        return int(exc.status)
    return 0


def resume(fmu: str, start: dict, steps: int, cut: int, h: float, event_mode: bool) -> dict:
    """(In a child.) A host resuming a saved run in a new instance: a run of `steps` doSteps of `h`; another
    cut after `cut`, its state serialised; a new instance (other parameter values set first) deserialises and
    sets it right after instantiation and steps on, never initialised, handling the events it reports (with
    eventModeUsed)."""
    whole = Instance3(fmu, name="whole", **start)
    vrs = [whole.vr(n) for n in SCALARS]
    uninterrupted = [whole.step(h, -0.5) and [x.hex() for x in whole.fmu.getFloat64(vrs)] for _ in range(steps)]
    first = Instance3(fmu, name="first", **start)
    for _ in range(cut):
        first.step(h, -0.5)
    blob = first.fmu.serializeFMUState(first.fmu.getFMUState())
    t = first.t
    first.fmu.terminate()
    first.fmu.freeInstance()
    fresh, messages = _fresh(whole, "resumed", event_mode)
    fresh.setFloat64([whole.vr("theta0"), whole.vr("gravity")], [0.1, 9.0])
    fresh.setFMUState(fresh.deserializeFMUState(blob))
    resumed, events = [], 0
    for _ in range(steps - cut):
        fresh.setFloat64([whole.vr("torque")], [-0.5])
        event, _terminate, _early, t = fresh.doStep(t, h)
        if event:
            fresh.enterEventMode()
            fresh.updateDiscreteStates()
            fresh.enterStepMode()
            events += 1
        resumed.append([x.hex() for x in fresh.getFloat64(vrs)])
    parameters = [whole.vr("theta0"), whole.vr("gravity"), whole.vr("model.mesh_size")]
    got = {
        "equal": resumed == uninterrupted[cut:],
        "parameters": fresh.getFloat64(parameters) == whole.fmu.getFloat64(parameters),
        "events": events,
        "initialise": [_attempt(lambda: fresh.enterInitializationMode(startTime=0.0)), _attempt(fresh.terminate)],
        "messages": messages,
    }
    fresh.freeInstance()
    whole.close()
    return got


@pytest.mark.parametrize(
    "start, steps, cut, event_mode",
    [
        ({"model.fidelity": 2}, 50, 25, False),
        ({"model.fidelity": 2}, 50, 15, True),
        ({"model.mesh_size": 0.06}, 10, 5, False),
    ],
    ids=["rigid", "rigid-event-mode", "fem"],
)
def test_a_new_instance_set_to_a_saved_state_steps_on_without_initialisation_bit_identically(
    fmu3, start, steps, cut, event_mode
):
    """Rigid 0..0.5 s (under the torque -0.5 N m the first impact is at 0.17 s), cut at 0.25 s, and with
    eventModeUsed cut at 0.15 s (the impact's events come after the cut); fem 0..0.1 s, cut at 0.05 s. Once the
    state is set the new instance is in stepMode, with the state's parameters and time."""
    got = child(MODULE, "resume", str(fmu3), start, steps, cut, 0.01, event_mode)
    assert got["equal"] and got["parameters"], got
    assert got["events"] > 0 if event_mode else got["events"] == 0, got
    assert got["initialise"] == [3, 0], got  # in stepMode: no initialisation; terminate as from any step
    assert any("fmi3EnterInitializationMode refused in state stepMode" in m for s, m in got["messages"] if s == 3)


def resume_rules(fmu: str) -> dict:
    """(In a child.) States taken before initialisation and once terminated, set into new instances."""
    run = Instance3(fmu, name="run", **{"model.fidelity": 2})
    run.step(1e-3)
    early, _ = _fresh(run, "early")
    early.setFloat64([run.vr("theta0")], [0.2])
    before = early.serializeFMUState(early.getFMUState())
    run.fmu.terminate()
    terminated = run.fmu.serializeFMUState(run.fmu.getFMUState())
    fresh, messages = _fresh(run, "fresh")
    got = {
        "terminated": [_attempt(lambda: fresh.setFMUState(fresh.deserializeFMUState(terminated)))],
        "before": [_attempt(lambda: fresh.setFMUState(fresh.deserializeFMUState(before)))],
    }
    got["terminated"].append(_attempt(lambda: fresh.getFloat64([run.vr("theta")])))  # still instantiated
    got["before"] += [
        _attempt(lambda: fresh.getFloat64([run.vr("theta")])),
        _attempt(lambda: fresh.enterInitializationMode(startTime=0.0)),
        fresh.getFloat64([run.vr("theta0")]),
    ]
    got["messages"] = [m for s, m in messages if s == 3]
    for inst in (early, fresh):
        inst.freeInstance()
    run.fmu.freeInstance()
    return got


def test_a_state_taken_before_initialisation_leaves_a_new_instance_instantiated_one_taken_terminated_is_refused(fmu3):
    got = child(MODULE, "resume_rules", str(fmu3))
    assert got["terminated"] == [3, 3], got
    assert got["before"] == [0, 3, 0, [0.2]], got  # instantiated, then initialised with the state's theta0
    assert any("fmi3SetFMUState refused" in m and "taken in state terminated" in m for m in got["messages"]), got[
        "messages"
    ]
