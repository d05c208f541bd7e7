"""The FMI 2.0 co-simulation contract of both FMUs (FemPendulum.fmu, PidController.fmu), through fmpy.

The contract: which call is allowed in which state (anything else answers fmi2Error, logs a message naming
the call and the state and changes nothing), the GUID check, the FMU state functions, no fmi2Fatal
whatever the slave's Python code raises, fmi2Discard with the state kept, the status functions and
fmi2Reset. docs/reference/fmi2.md describes it; tests/fmi2_raw.py calls the FMU's functions raw, so that every
status is seen. The pendulum runs its rigid fidelity (model.fidelity = 2) unless a case needs the FE
model (model.mesh_size 0.06, the coarsest mesh).

Every test's FMU work runs in a child interpreter (`child`), which must exit 0: an FMU that crashes
takes only the child down. The state-machine table runs all its cases in one child per FMU and starts
a new child after a crash, so that one crashing case does not hide the others.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import subprocess
import traceback
import zipfile
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from ctypes import addressof, c_void_p, create_string_buffer
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import fmi2_raw
import in_child
import pytest
from pythonfmu import Fmi2Slave
from raising_switch import RAISE_SWITCH, RAISING

MODULE = Path(__file__).stem  # this module, as tests/in_child.py imports it
RIGID = {"model.fidelity": 2}
FEM = {"model.mesh_size": 0.06}
H = 1e-3  # communication step of the scripted runs
CHILD_TIMEOUT = 240  # s: a child that hangs fails its test instead of the whole session


def child(function: str, *args: Any) -> Any:
    """`function(*args)` of this module run in a new interpreter (tests/in_child.py), which must exit 0; what it
    returned."""
    run = subprocess.run(
        in_child.command(MODULE, function, *args), capture_output=True, text=True, timeout=CHILD_TIMEOUT
    )
    assert run.returncode == 0, f"child exited {run.returncode}\n" + run.stdout[-3000:] + run.stderr[-3000:]
    return in_child.result(run.stdout)


# ------------------------------------------------------------------------------------------------------
# Scripted runs: instantiate -> terminated, cut at each of the four states
# ------------------------------------------------------------------------------------------------------

STATES = fmi2_raw.STATES


class Clock:
    """The host's communication time of one instance."""

    def __init__(self) -> None:
        self.t = 0.0


@dataclass(frozen=True)
class Script:
    """A run of one FMU as the ops done in each state (each op records its statuses and values read):
    `prelude` right after fmi2Instantiate, then the ops of `phases[state]` in the order of STATES; the
    last op of a state's phase moves the instance to the next state."""

    prelude: dict[str, Any]  # start values set in instantiated
    phases: dict[str, list[Callable]]

    def drive(self, inst, clock: Clock, state: str) -> list:
        """Take a new instance to `state`: the prelude and the phases before it (what they recorded)."""
        record = [inst.set_named(**self.prelude)]
        for s in STATES[: STATES.index(state)]:
            record += [op(inst, clock) for op in self.phases[s]]
        return record

    def finish(self, inst, clock: Clock, state: str) -> list:
        """From `state` to the end of the run (what the ops recorded)."""
        return [op(inst, clock) for s in STATES[STATES.index(state) :] for op in self.phases[s]]


def _snapshot(inst, clock: Clock) -> list:
    return list(inst.snapshot())


def _step(input_name: str, value: float) -> Callable:
    """An op: set the input, one doStep of H, the snapshot."""

    def step(inst, clock: Clock) -> list:
        record = [inst.set_named(**{input_name: value}), inst.do_step(clock.t, H)]
        if record[-1] == 0:
            clock.t += H
        return [*record, *inst.snapshot()]

    return step


def _statuses(inst, clock: Clock) -> list:
    """fmi2Terminated and fmi2LastSuccessfulTime: both statuses, then the values."""
    (s1, terminated) = inst.status("Boolean", fmi2_raw.TERMINATED)
    (s2, time) = inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)
    return [s1, s2, bool(terminated), float(time).hex()]


def _script(kind: str) -> Script:
    """The scripted run of the pendulum (rigid) or the PID."""
    if kind == "pendulum":
        prelude = dict(RIGID)
        start = [lambda i, c: i.set_named(theta0=0.3, **{"pendulum.rho": 7000.0}), lambda i, c: i.exit()]
        step = _step("torque", -0.5)
    else:
        prelude = {"Kp": 12.0}
        start = [lambda i, c: i.set_named(Ki=5.0, setpoint=0.2), lambda i, c: i.exit()]
        step = _step("measurement", 0.05)
    return Script(
        prelude=prelude,
        phases={
            "instantiated": [lambda i, c: i.setup(0.0), lambda i, c: i.enter()],
            "initializationMode": [_snapshot, *start, step],
            "stepComplete": [_snapshot, step, step, lambda i, c: i.terminate()],
            "terminated": [_snapshot, _statuses],
        },
    )


# ------------------------------------------------------------------------------------------------------
# The state machine: every cell of the contract's table
# ------------------------------------------------------------------------------------------------------

NOT_PROVIDED = ("fmi2GetDirectionalDerivative", "fmi2CancelStep")
# input derivatives where fmi2SetReal of an input is allowed, output derivatives after a step and once terminated
# (FMI 2.0's table; the FMUs enter none of its other states); an FMU that declares neither refuses both always
DERIVATIVES = ("fmi2SetRealInputDerivatives", "fmi2GetRealOutputDerivatives")
PROVIDES_DERIVATIVES = ("pendulum", "pid")


@dataclass(frozen=True)
class Call:
    """One FMI call with its arguments, for the table: `forbidden` are the states where it must answer
    fmi2Error (the others: `answer`, fmi2OK unless said); `kinds` the FMUs it applies to; `skip` the states
    where it is allowed but moves the instance on or changes the run (the scripted run makes those calls)."""

    name: str
    variant: str
    forbidden: tuple[str, ...]
    kinds: tuple[str, ...] = ("pendulum", "pid")
    skip: tuple[str, ...] = ()
    answer: int = 0


def _parameter(kind: str) -> tuple[str, Any]:
    """A Real parameter and the value it has in the scripted run."""
    return ("pendulum.E", 2.1e11) if kind == "pendulum" else ("Kp", 12.0)


# a pendulum parameter of each other type, at its start value (the scripted run leaves them there)
OTHER_TYPES = {
    "Integer": ("model.order", 0),
    "Boolean": ("model.compute_stress", False),
    "String": ("output.vtk_folder", ""),
}
# fmi2Get<kind>Status -> the status kind asked (there is no Integer one: fmi2DoStepStatus)
STATUS_KINDS = {
    "": fmi2_raw.DO_STEP_STATUS,
    "Real": fmi2_raw.LAST_SUCCESSFUL_TIME,
    "Integer": fmi2_raw.DO_STEP_STATUS,
    "Boolean": fmi2_raw.TERMINATED,
    "String": fmi2_raw.PENDING_STATUS,
}


def _invoke(call: Call, kind: str, inst, clock: Clock) -> list[int]:
    """Make `call` on `inst`: its status(es)."""
    fmu = inst.fmu
    output, input_ = ("theta", "torque") if kind == "pendulum" else ("u", "setpoint")
    name = call.name
    typed = name[7:]  # fmi2Get<type> / fmi2Set<type>
    if name == "fmi2SetupExperiment":
        return [inst.setup(5.0)]
    if name == "fmi2EnterInitializationMode":
        return [inst.enter()]
    if name == "fmi2ExitInitializationMode":
        return [inst.exit()]
    if name == "fmi2Terminate":
        return [inst.terminate()]
    if name == "fmi2DoStep":
        return [inst.do_step(clock.t, H)]
    if name == "fmi2SetDebugLogging":
        return [inst.debug_logging(True)]
    if name.startswith("fmi2Get") and name.endswith("Status"):
        return [inst.status(typed[:-6], STATUS_KINDS[typed[:-6]])[0]]
    if name.startswith("fmi2Get") and typed in ("Real", *OTHER_TYPES):
        return [inst.get_named(output if typed == "Real" else OTHER_TYPES[typed][0])[0]]
    if name == "fmi2SetReal" and call.variant == "input":
        return [inst.set_named(**{input_: 5.0})]
    if name == "fmi2SetReal":
        parameter, value = _parameter(kind)
        return [inst.set_named(**{parameter: value if call.variant == "parameter" else 3.0 * value})]
    if name.startswith("fmi2Set") and typed in OTHER_TYPES:
        return [inst.set_named(**dict([OTHER_TYPES[typed]]))]
    if name == "fmi2GetDirectionalDerivative":
        return [inst.directional_derivative(fmu.vr(output), fmu.vr(input_))]
    if name == "fmi2SetRealInputDerivatives":
        return [inst.set_input_derivatives(fmu.vr(input_))]
    if name == "fmi2GetRealOutputDerivatives":
        return [inst.get_output_derivatives(fmu.vr(output))[0]]
    if name == "fmi2CancelStep":
        return [inst.cancel_step()]
    if name == "fmi2GetFMUstate":  # the whole round trip: get, size, serialise, deserialise, set both, free both
        status, state = inst.get_state()
        size_status, n = inst.state_size(state)
        serial_status, data = inst.serialize(state, n)
        de_status, copy = inst.deserialize(data)
        statuses = [status, size_status, serial_status, de_status, inst.set_state(copy), inst.set_state(state)]
        return [*statuses, inst.free_state(copy), inst.free_state(state)]
    raise AssertionError(f"no way to call {name}")


INST, INIT, STEP, TERM = STATES
CALLS = (
    Call("fmi2SetDebugLogging", "", ()),
    Call("fmi2SetupExperiment", "", (INIT, STEP, TERM)),
    Call("fmi2EnterInitializationMode", "", (INIT, STEP, TERM), skip=(INST,)),
    Call("fmi2ExitInitializationMode", "", (INST, STEP, TERM), skip=(INIT,)),
    Call("fmi2Terminate", "", (INST, INIT, TERM), skip=(STEP,)),
    Call("fmi2Reset", "", ()),
    Call("fmi2FreeInstance", "", ()),
    Call("fmi2GetReal", "", (INST,)),
    *(Call(f"fmi2Get{k}", "", (INST,), ("pendulum",)) for k in OTHER_TYPES),
    Call("fmi2SetReal", "input", (TERM,), skip=(INST, INIT, STEP)),
    Call("fmi2SetReal", "parameter", (STEP, TERM)),
    Call("fmi2SetReal", "parameter, another value", (STEP, TERM), skip=(INST, INIT)),
    *(Call(f"fmi2Set{k}", "parameter", (STEP, TERM), ("pendulum",)) for k in OTHER_TYPES),
    Call("fmi2GetFMUstate", "round trip", ()),
    Call("fmi2DoStep", "", (INST, INIT, TERM), skip=(STEP,)),
    # fmi2DoStepStatus, fmi2PendingStatus and an Integer status: fmi2Discard, as a slave that cannot say
    *(Call(f"fmi2Get{k}Status", "", (INST, INIT), answer=2) for k in ("", "Integer", "String")),
    *(Call(f"fmi2Get{k}Status", "", (INST, INIT)) for k in ("Real", "Boolean")),
    *(Call(name, "", STATES) for name in NOT_PROVIDED),
    Call("fmi2SetRealInputDerivatives", "", (TERM,), PROVIDES_DERIVATIVES),  # of value 0: the run is unchanged
    Call("fmi2GetRealOutputDerivatives", "", (INST, INIT), PROVIDES_DERIVATIVES),
    *(
        Call(name, "not provided", STATES, tuple(k for k in ("pendulum", "pid") if k not in PROVIDES_DERIVATIVES))
        for name in DERIVATIVES
        if len(PROVIDES_DERIVATIVES) < 2
    ),
)


@dataclass(frozen=True)
class Case:
    kind: str
    call: Call
    state: str

    @property
    def id(self) -> str:
        variant = f"({self.call.variant})" if self.call.variant else ""
        return f"{self.kind}-{self.call.name}{variant}-{self.state}"

    @property
    def forbidden(self) -> bool:
        return self.state in self.call.forbidden


def _cases(kind: str) -> list[Case]:
    return [Case(kind, call, s) for call in CALLS if kind in call.kinds for s in STATES if s not in call.skip]


CASES = _cases("pendulum") + _cases("pid")


def table_child(path: str, kind: str, ids: list[str]) -> None:
    """Run the table's cases `ids` for one FMU, printing START <id> before each and CASE <json> after it.

    A case: a new instance driven to its state, the call, then the rest of the scripted run; its reference
    is the scripted run of another new instance without the call. For fmi2Reset the rest is the whole run
    from instantiated (prelude included); for fmi2FreeInstance a new instance's."""
    fmu = fmi2_raw.Fmu(path)
    script = _script(kind)
    by_id = {case.id: case for case in _cases(kind)}
    references: dict[str, list] = {}

    def reference(state: str) -> list:
        if state not in references:
            inst, clock = fmi2_raw.Instance(fmu, "reference"), Clock()
            references[state] = [script.drive(inst, clock, state), script.finish(inst, clock, state)]
            inst.free()
        return references[state]

    for case_id in ids:
        print("START", case_id, flush=True)
        case = by_id[case_id]
        try:
            result = _table_case(fmu, script, case, reference)
        except Exception:
            result = {"exception": traceback.format_exc()}
        print("CASE", json.dumps({"id": case_id, **result}), flush=True)
    fmu.close()


def _table_case(fmu, script: Script, case: Case, reference: Callable) -> dict:
    expected = reference("instantiated" if case.call.name in ("fmi2Reset", "fmi2FreeInstance") else case.state)
    inst, clock = fmi2_raw.Instance(fmu, "inst"), Clock()
    drive = script.drive(inst, clock, case.state)
    mark = inst.mark()
    if case.call.name == "fmi2FreeInstance":  # no status: what counts is that the next instance runs as usual
        inst.free()
        statuses, messages = [0], []
        inst, clock = fmi2_raw.Instance(fmu, "next"), Clock()
        after = [script.drive(inst, clock, "instantiated"), script.finish(inst, clock, "instantiated")]
    elif case.call.name == "fmi2Reset":
        statuses = [inst.reset()]
        messages = inst.since(mark)
        clock = Clock()
        after = [script.drive(inst, clock, "instantiated"), script.finish(inst, clock, "instantiated")]
    else:
        statuses = _invoke(case.call, case.kind, inst, clock)
        messages = inst.since(mark)
        after = [drive, script.finish(inst, clock, case.state)]
    if inst.c is not None:
        inst.free()
    return {"statuses": statuses, "messages": messages, "after": after, "expected": expected}


def run_table(fmu: Path, kind: str) -> tuple[dict[str, dict], list[dict]]:
    """The table's results for one FMU (case id -> result) and its child runs (exit codes): a child that
    crashes is followed by a new one for the cases after the one it crashed in."""
    remaining = [case.id for case in _cases(kind)]
    results: dict[str, dict] = {}
    runs: list[dict] = []
    while remaining:
        try:
            run = subprocess.run(
                in_child.command(MODULE, "table_child", str(fmu), kind, remaining),
                capture_output=True,
                text=True,
                timeout=CHILD_TIMEOUT,
            )
            code, out, err = run.returncode, run.stdout, run.stderr
        except subprocess.TimeoutExpired as exc:
            code, out, err = "timeout", exc.stdout or "", exc.stderr or ""
            out, err = (s.decode() if isinstance(s, bytes) else s for s in (out, err))
        started = None
        for line in out.splitlines():
            if line.startswith("START "):
                started = line[6:]
            elif line.startswith("CASE "):
                result = json.loads(line[5:])
                results[result.pop("id")] = result
                started = None
        runs.append({"exit": code, "cases": len(remaining), "stderr": err[-2000:]})
        if started is not None:
            results[started] = {"crashed": f"the child died in this case (exit {code}): {err[-2000:]}"}
        done = [case_id for case_id in remaining if case_id in results]
        if not done:
            for case_id in remaining:
                results[case_id] = {"crashed": f"the child ran no case (exit {code}): {err[-2000:]}"}
        remaining = [case_id for case_id in remaining if case_id not in results]
    return results, runs


@pytest.fixture(scope="module")
def table(fmus) -> dict[str, tuple[dict[str, dict], list[dict]]]:
    """Both FMUs' tables, run side by side (one child each at a time)."""
    with ThreadPoolExecutor(2) as pool:
        futures = {
            kind: pool.submit(run_table, path, kind) for kind, path in zip(("pendulum", "pid"), fmus, strict=True)
        }
        return {kind: future.result() for kind, future in futures.items()}


@pytest.mark.parametrize("case", CASES, ids=[case.id for case in CASES])
def test_each_call_in_each_state_answers_as_the_table_says_and_a_refusal_changes_nothing(table, case):
    """A forbidden call answers fmi2Error and logs a message naming the call and the state; an allowed one
    answers fmi2OK (fmi2Discard for a status a slave cannot give); either way the rest of the run is
    bit-identical to a run without the call."""
    result = table[case.kind][0][case.id]
    assert "crashed" not in result and "exception" not in result, result
    if case.forbidden:
        assert result["statuses"] == [3], result
        if case.call.name in NOT_PROVIDED or case.call.variant == "not provided":
            assert any(case.call.name in m for m in result["messages"]), result["messages"]
        else:
            assert any(case.call.name in m and case.state in m for m in result["messages"]), result["messages"]
    else:
        assert set(result["statuses"]) == {case.call.answer}, result
    reference_drive, reference_finish = result["expected"]
    assert set(_statuses_in(reference_drive + reference_finish)) == {0}  # the reference ran through
    assert result["after"] == result["expected"]


def _statuses_in(record: list) -> list[int]:
    """The statuses in a record: its ints (the values read are strings, bools or floats' hex)."""
    flat = [x for entry in record for x in (entry if isinstance(entry, list) else [entry])]
    return [x for x in flat if type(x) is int]


def test_the_table_children_exit_cleanly(table):
    """Every child process of the table ran to its end and exited 0 (no crash, no crash at exit)."""
    for kind, (_, runs) in table.items():
        assert [run["exit"] for run in runs] == [0], (kind, runs)


# ------------------------------------------------------------------------------------------------------
# Arguments: fmi2Instantiate's, value references, invalid parameters, the start time
# ------------------------------------------------------------------------------------------------------


def instantiate_child(path: str) -> dict:
    fmu = fmi2_raw.Fmu(path)
    wrong = "{01234567-89ab-cdef-0123-456789abcdef}"
    out: dict[str, Any] = {"own": fmu.guid, "wrong": wrong, "version": list(fmi2_raw.version(fmu))}
    for label, kwargs in (
        ("wrong_guid", {"guid": wrong}),
        ("model_exchange", {"fmu_type": 0}),
        ("no_name", {"name": None}),
    ):
        inst = fmi2_raw.Instance(fmu, **kwargs)
        out[label] = {"null": inst.c is None, "messages": [m.text for m in inst.messages]}
        if inst.c is not None:
            inst.free()
    # NULL callback functions: nothing to log through; the FMU must refuse, not crash
    f = fmu.f["fmi2Instantiate"]
    out["no_callbacks"] = f(b"x", 1, fmu.guid.encode(), fmu.uri.encode(), None, 0, 1) is None
    inst = fmi2_raw.Instance(fmu, "after")  # the refusals left the FMU usable
    statuses = [inst.setup(), inst.enter(), inst.exit(), inst.do_step(0.0, H), inst.terminate()]
    out["after"] = inst.c is not None and statuses == [0] * 5
    inst.free()
    fmu.close()
    return out


@pytest.mark.parametrize("which", [0, 1], ids=["pendulum", "pid"])
def test_instantiate_refuses_a_wrong_guid_naming_both_and_other_bad_arguments(fmus, which):
    got = child("instantiate_child", str(fmus[which]))
    assert got["version"] == ["default", "2.0"]
    assert got["wrong_guid"]["null"], got
    assert any(got["own"] in m and got["wrong"] in m for m in got["wrong_guid"]["messages"]), got["wrong_guid"]
    for label in ("model_exchange", "no_name"):
        assert got[label]["null"] and got[label]["messages"], (label, got[label])
    assert got["no_callbacks"]
    assert got["after"]


def arguments_child(path: str, kind: str) -> dict:
    """Bad value references and setting an output (fmi2Error, nothing changed); for the pendulum an invalid
    parameter at fmi2ExitInitializationMode (fmi2Error, still in initializationMode, correctable); a start
    time of 0.5 s; the run compared with one that had none of these."""
    fmu = fmi2_raw.Fmu(path)
    output, real_parameter = ("theta", "pendulum.E") if kind == "pendulum" else ("u", "Kp")
    start = dict(RIGID) if kind == "pendulum" else {"Kp": 12.0}
    torque = "torque" if kind == "pendulum" else "measurement"
    out: dict[str, Any] = {}

    def run(inst) -> list:
        record, t = [], 0.5
        for k in range(3):
            record.append([inst.set_named(**{torque: 0.1 * k}), inst.do_step(t, H), inst.snapshot()])
            t += H
        return record

    reference = fmi2_raw.Instance(fmu, "reference")
    assert [reference.setup(0.5), reference.enter(), reference.set_named(**start), reference.exit()] == [0] * 4
    expected = run(reference)
    reference.free()

    inst = fmi2_raw.Instance(fmu, "inst")
    assert [inst.setup(0.5), inst.enter(), inst.set_named(**start)] == [0, 0, 0]
    if kind == "pendulum":
        mark = inst.mark()
        out["invalid"] = [inst.set_named(**{"pendulum.nu": 0.5}), inst.exit()]
        out["invalid_named"] = any("pendulum.nu" in m for m in inst.since(mark))
        # still in initializationMode: Get allowed, doStep not; the parameter can be corrected
        out["still_init"] = [inst.get_named("pendulum.nu"), inst.do_step(0.5, H)]
        out["corrected"] = [inst.set_named(**{"pendulum.nu": 0.3}), inst.exit()]
    else:
        out["corrected"] = [inst.exit()]
    before = inst.snapshot()
    real = fmu.vr(output)[0]
    integer_vr = fmu.vr("model.order")[0] if kind == "pendulum" else None
    refused = {
        "get_unknown_reference": inst.get("Real", [len(fmu.md.modelVariables) + 100])[0],
        "get_real_of_another_type": inst.get("Integer", [real])[0],
        "set_output": inst.set("Real", [real], [1.0]),
        "set_unknown_reference": inst.set("Real", [len(fmu.md.modelVariables) + 100], [1.0]),
        "set_parameter": inst.set("Real", fmu.vr(real_parameter), [1.0]),
    }
    if integer_vr is not None:
        refused["set_real_of_an_integer"] = inst.set("Real", [integer_vr], [3.0])
    out["refused"] = refused
    out["unchanged"] = inst.snapshot() == before
    out["start_time"] = list(inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME))
    out["same_run"] = run(inst) == expected and all(r[:2] == [0, 0] for r in expected)
    inst.free()
    fmu.close()
    return out


@pytest.mark.parametrize("which", [0, 1], ids=["pendulum", "pid"])
def test_bad_arguments_are_refused_and_change_nothing(fmus, which):
    kind = ("pendulum", "pid")[which]
    got = child("arguments_child", str(fmus[which]), kind)
    for label, status in got["refused"].items():
        assert status == 3, (label, got)
    assert got["unchanged"] and got["same_run"], got
    assert got["start_time"] == [0, 0.5], got  # fmi2LastSuccessfulTime before any step: the start time
    if kind == "pendulum":
        assert got["invalid"] == [0, 3] and got["invalid_named"], got
        assert got["still_init"] == [[0, [0.5]], 3], got
        assert got["corrected"] == [0, 0], got
    else:
        assert got["corrected"] == [0], got


# ------------------------------------------------------------------------------------------------------
# FMU states
# ------------------------------------------------------------------------------------------------------


def _started(fmu, name: str, start: dict, steps: int = 3, torque: float = -0.5):
    """A new instance initialised with `start`, `steps` steps of H done: (instance, clock)."""
    inst, clock = fmi2_raw.Instance(fmu, name), Clock()
    assert inst.c is not None, inst.messages
    assert [inst.setup(), inst.enter(), inst.set_named(**start), inst.exit()] == [0] * 4, inst.messages[-3:]
    for _ in range(steps):
        assert _run(inst, clock, 1, torque)[0][0] == [0, 0], inst.messages[-3:]
    return inst, clock


def _run(inst, clock: Clock, steps: int, torque: float = -0.5, h: float = H) -> list:
    """`steps` steps of `h`: per step, the statuses and the snapshot."""
    out = []
    for _ in range(steps):
        status = [inst.set_named(torque=torque), inst.do_step(clock.t, h)]
        clock.t += h if status[-1] == 0 else 0.0
        out.append([status, inst.snapshot()])
    return out


def buffers_child(path: str) -> dict:
    fmu = fmi2_raw.Fmu(path)
    inst, _ = _started(fmu, "buffers", RIGID)
    status, state = inst.get_state()
    size_status, n = inst.state_size(state)
    exact_status, exact = inst.serialize(state, n)
    large_status, large = inst.serialize(state, n + 100)
    small_status, small = inst.serialize(state, n - 1, capacity=n)
    zero_status, _ = inst.serialize(state, 0, capacity=n)
    out = {
        "statuses": [status, size_status, exact_status, large_status],
        "n": n,
        "exact_is_filled": exact != bytes([fmi2_raw.FILL]) * n,
        "large_head_is_exact": large[:n] == exact,
        "large_tail_untouched": large[n:] == bytes([fmi2_raw.FILL]) * 100,
        "small": [small_status, small == bytes([fmi2_raw.FILL]) * n],
        "zero": zero_status,
        "free": inst.free_state(state),
    }
    inst.free()
    fmu.close()
    return out


def test_serialise_writes_exactly_n_bytes_into_a_larger_buffer_and_refuses_a_smaller_one(fmus):
    got = child("buffers_child", str(fmus[0]))
    assert got["statuses"] == [0, 0, 0, 0] and got["n"] > 0, got
    assert got["exact_is_filled"], got
    assert got["large_head_is_exact"] and got["large_tail_untouched"], got
    assert got["small"] == [3, True], got  # fmi2Error, the host's buffer untouched
    assert got["zero"] == 3 and got["free"] == 0, got


def deserialise_child(path: str) -> dict:
    """Into a fem instance (mesh 0.06) and a rigid one: every kind of bytes that is not a state of theirs."""
    fmu = fmi2_raw.Fmu(path)
    rigid, rigid_clock = _started(fmu, "rigid", RIGID)
    fem, fem_clock = _started(fmu, "fem", FEM)
    fine, _ = _started(fmu, "fine", {"model.mesh_size": 0.04}, steps=1)
    mine = {}
    for name, inst in (("rigid", rigid), ("fem", fem), ("fine", fine)):
        status, state = inst.get_state()
        assert status == 0, inst.messages[-3:]
        mine[name] = (state, inst.serialized(state))
    out: dict[str, Any] = {"refused": {}}
    for target, inst, clock in (("fem", fem, fem_clock), ("rigid", rigid, rigid_clock)):
        own_state, own = mine[target]
        before = inst.snapshot()
        candidates = {
            "junk": b"not an FMU state at all, just bytes " * 20,
            "empty": b"",
            "truncated_half": own[: len(own) // 2],
            "truncated_by_one": own[:-1],
            "other_fidelity": mine["rigid" if target == "fem" else "fem"][1],
        }
        if target == "fem":
            candidates["other_mesh_size"] = mine["fine"][1]
        for label, data in candidates.items():
            into_null = inst.deserialize(data)
            live = c_void_p(own_state.value)
            into_live = inst.deserialize(data, into=live)
            out["refused"][f"{target}:{label}"] = [
                into_null[0],
                into_null[1].value is None,
                into_live[0],
                live.value == own_state.value,
            ]
        out[f"{target}:own_state_intact"] = inst.serialized(own_state) == own
        out[f"{target}:unchanged"] = inst.snapshot() == before
        # the instance goes on as if nothing had been tried: a run from here equals the run from its own state
        t = clock.t
        ahead = _run(inst, clock, 3)
        clock.t = t
        out[f"{target}:runs_on"] = [inst.set_state(own_state), ahead == _run(inst, clock, 3), ahead[-1][0]]
    for inst in (rigid, fem, fine):
        inst.free()
    fmu.close()
    return out


def test_deserialise_refuses_what_is_not_a_state_of_this_instance(fmus):
    """Junk, empty, truncated bytes, a state of another fidelity or mesh size: fmi2Error at deserialise,
    the handle unchanged (NULL, or the live state it held, which still works), the instance unchanged."""
    got = child("deserialise_child", str(fmus[0]))
    assert len(got["refused"]) == 11
    for label, value in got["refused"].items():
        assert value == [3, True, 3, True], (label, value)
    for target in ("fem", "rigid"):
        assert got[f"{target}:own_state_intact"] and got[f"{target}:unchanged"], got
        assert got[f"{target}:runs_on"] == [0, True, [0, 0]], got


def deserialised_child(path: str, start: dict) -> dict:
    fmu = fmi2_raw.Fmu(path)
    inst, clock = _started(fmu, "inst", start)
    status, state = inst.get_state()
    data = inst.serialized(state)
    t_state = clock.t
    first = _run(inst, clock, 3, 0.7)
    de_status, copy = inst.deserialize(data)
    out: dict[str, Any] = {"get": status, "deserialize": de_status, "distinct": copy.value not in (None, state.value)}
    size_status, n = inst.state_size(copy)
    serial_status, again = inst.serialize(copy, n)
    out["size"] = [size_status, n == len(data)]
    out["serialise_again"] = [serial_status, again == data]
    out["set"] = inst.set_state(copy)
    clock.t = t_state
    out["time"] = inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)[1] == t_state
    out["replays"] = _run(inst, clock, 3, 0.7) == first
    # fmi2GetFMUstate into a live handle (the deserialised one): replaced in place, same pointer, new content
    held = copy.value
    refill = inst.get_state(into=copy)[0]
    out["get_in_place"] = [refill, copy.value == held, inst.serialized(copy) != data]
    # a state of the current instant, serialised, deserialised and set after the run went on, replays too
    now = inst.serialized(copy)
    t_now = clock.t
    later = _run(inst, clock, 2, -0.2)
    status2, copy2 = inst.deserialize(now)
    clock.t = t_now
    out["replays_again"] = [status2, inst.set_state(copy2), _run(inst, clock, 2, -0.2) == later]
    freed = [inst.free_state(copy), inst.free_state(copy2), inst.free_state(state)]
    out["free"] = [freed, copy.value is None and copy2.value is None and state.value is None]
    inst.free()
    fmu.close()
    return out


@pytest.mark.parametrize("start", [RIGID, FEM], ids=["rigid", "fem"])
def test_every_state_function_works_on_a_deserialised_state(fmus, start):
    got = child("deserialised_child", str(fmus[0]), start)
    assert got["get"] == 0 and got["deserialize"] == 0 and got["distinct"], got
    assert got["size"] == [0, True] and got["serialise_again"] == [0, True], got
    assert got["set"] == 0 and got["time"] and got["replays"], got
    assert got["get_in_place"] == [0, True, True], got
    assert got["replays_again"] == [0, 0, True], got
    assert got["free"] == [[0, 0, 0], True], got


def pointers_child(path: str) -> dict:
    """State handles the instance did not hand out: never handed out (junk memory, an unmapped address),
    already freed, another instance's. A binary that dereferenced the unmapped one would crash the child."""
    fmu = fmi2_raw.Fmu(path)
    a, a_clock = _started(fmu, "a", RIGID)
    b, _ = _started(fmu, "b", RIGID)
    junk = create_string_buffer(b"\x5a" * 4096, 4096)
    status, theirs = b.get_state()
    theirs_bytes = b.serialized(theirs)
    status_freed, freed = a.get_state()
    freed_address = freed.value
    out: dict[str, Any] = {"setup": [status, status_freed, a.free_state(freed), freed.value is None], "get_into": {}}
    before = a.snapshot()
    for label, address in (
        ("junk_memory", addressof(junk)),
        ("unmapped", 0x10),
        ("freed", freed_address),
        ("another_instance", theirs.value),
    ):
        out[label] = [
            a.set_state(address),
            a.state_size(address)[0],
            a.serialize(address, 64)[0],
            a.free_state(c_void_p(address)),
        ]
        into = c_void_p(address)
        got = a.get_state(into=into)[0]
        out["get_into"][label] = [got, into.value == address]
        if got == 0 and into.value != address:  # a new state under a new handle: not ours to leak
            a.free_state(into)
    out["unchanged"] = a.snapshot() == before
    out["junk_untouched"] = junk.raw == b"\x5a" * 4096
    out["theirs_intact"] = [b.state_size(theirs)[0], b.serialized(theirs) == theirs_bytes, b.set_state(theirs)]
    # the NULL cases, and a state passed where its address is due
    status, mine = a.get_state()
    out["null"] = [a.free_state_at(None), a.free_state(c_void_p())]
    out["state_for_its_address"] = [status, a.free_state_at(mine.value), a.set_state(mine)]
    out["steps_after"] = a.do_step(a_clock.t, H)
    out["free_theirs"] = b.free_state(theirs)
    a.free()
    b.free()
    fmu.close()
    return out


@pytest.fixture(scope="module")
def pointers(fmus) -> dict:
    return child("pointers_child", str(fmus[0]))


def test_state_handles_not_handed_out_by_this_instance_are_refused(pointers):
    """Set, size, serialise and free of a handle this instance did not hand out (or freed): all fmi2Error,
    nothing dereferenced or changed; the other instance's state still works there."""
    got = pointers
    assert got["setup"] == [0, 0, 0, True], got
    for label in ("junk_memory", "unmapped", "freed", "another_instance"):
        assert got[label] == [3, 3, 3, 3], (label, got[label])
    assert got["unchanged"] and got["junk_untouched"], got
    assert got["theirs_intact"] == [0, True, 0], got
    assert got["null"] == [0, 0], got
    # freed when passed as its own address; afterwards it is a freed handle
    assert got["state_for_its_address"] == [0, 0, 3], got
    assert got["steps_after"] == 0 and got["free_theirs"] == 0, got


def test_get_fmu_state_into_a_handle_not_handed_out_is_refused(pointers):
    """fmi2GetFMUstate(c, &s) with s holding a pointer this instance did not hand out (FMI 2.0: a non-NULL
    *s is a state the FMU returned before): fmi2Error, s unchanged."""
    for label, value in pointers["get_into"].items():
        assert value == [3, True], (label, value)


def resume_child(path: str, start: dict, steps: int, cut: int, h: float) -> dict:
    """A host resuming a saved run in a new instance: a run of `steps` communication steps of `h`; another
    cut after `cut` steps, its state serialised; a new instance (other parameter values set on it first)
    deserialises and sets that state right after fmi2Instantiate and steps on to the end, never initialised."""
    fmu = fmi2_raw.Fmu(path)
    whole, clock = _started(fmu, "whole", start, steps=0)
    uninterrupted = _run(whole, clock, steps, h=h)
    first, first_clock = _started(fmu, "first", start, steps=0)
    _run(first, first_clock, cut, h=h)
    status, state = first.get_state()
    data = first.serialized(state)
    first.free()
    fresh = fmi2_raw.Instance(fmu, "resumed")
    out: dict[str, Any] = {"get": status, "changed": fresh.set_named(theta0=0.1, gravity=9.0)}
    de_status, copy = fresh.deserialize(data)
    out["set"] = [de_status, fresh.set_state(copy)]
    out["time"] = list(fresh.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)) == [0, first_clock.t]
    resumed = _run(fresh, first_clock, steps - cut, h=h)  # the snapshots hold the parameters too: the state's
    out["equal"] = resumed == uninterrupted[cut:]
    out["statuses"] = sorted({s for step in resumed for s in [*step[0], step[1][0]]})
    out["initialise"] = [fresh.setup(0.0), fresh.enter(), fresh.exit()]  # stepComplete: not any more
    out["refusal"] = fresh.messages[-1].text
    out["end"] = [fresh.terminate(), whole.terminate()]
    for inst in (whole, fresh):
        inst.free()
    fmu.close()
    return out


@pytest.mark.parametrize(
    "start, steps, cut, h",
    [(RIGID, 50, 25, 0.01), (FEM, 10, 5, 0.01)],
    ids=["rigid", "fem"],
)
def test_a_new_instance_set_to_a_saved_state_steps_on_without_initialisation_bit_identically(
    fmus, start, steps, cut, h
):
    """Rigid 0..0.5 s (the first impact at 0.17 s), cut at 0.25 s; fem 0..0.1 s, cut at 0.05 s. The new
    instance is in stepComplete once the state is set, with the state's parameters and time."""
    got = child("resume_child", str(fmus[0]), start, steps, cut, h)
    assert got["get"] == 0 and got["changed"] == 0 and got["set"] == [0, 0], got
    assert got["time"] and got["equal"] and got["statuses"] == [0], got
    assert got["initialise"] == [3, 3, 3], got
    assert "fmi2ExitInitializationMode refused in state stepComplete" in got["refusal"], got
    assert got["end"] == [0, 0], got


def resume_rules_child(path: str) -> dict:
    """States taken before initialisation, while stepping and once terminated, set into instances in each
    state (docs/reference/fmi2.md, "Setting an FMU state")."""
    fmu = fmi2_raw.Fmu(path)
    early = fmi2_raw.Instance(fmu, "early")  # a state of a new instance: its parameters and start time
    changed = early.set_named(**RIGID, theta0=0.2)
    status, early_state = early.get_state()
    out: dict[str, Any] = {"early": [changed, status]}
    before = early.serialized(early_state)
    run, clock = _started(fmu, "run", RIGID)
    stepping = run.serialized(run.get_state()[1])
    done, _ = _started(fmu, "done", RIGID)
    out["done"] = done.terminate()
    terminated_state = done.get_state()[1]
    terminated = done.serialized(terminated_state)
    # a state taken before initialisation, into a new instance: it stays instantiated, with the state's values
    fresh = fmi2_raw.Instance(fmu, "fresh")
    handle = fresh.deserialize(before)[1]
    out["before_into_instantiated"] = [
        fresh.set_named(theta0=0.4),
        fresh.set_state(handle),
        fresh.get_named("theta")[0],
    ]
    out["then_initialised"] = [
        fresh.do_step(0.0, H),
        fresh.setup(),
        fresh.enter(),
        fresh.get_named("theta0"),
        fresh.exit(),
    ]
    # a state taken stepping, into initializationMode: stepComplete, Exit refused
    init = fmi2_raw.Instance(fmu, "init")
    out["stepping_into_init"] = [init.setup(), init.enter(), init.set_state(init.deserialize(stepping)[1])]
    out["then_stepping"] = [init.exit(), init.do_step(clock.t, H)]
    # a state taken once terminated: refused by a new instance and a stepping one, taken by a terminated one
    blank = fmi2_raw.Instance(fmu, "blank")
    out["terminated_into_instantiated"] = [blank.set_state(blank.deserialize(terminated)[1]), blank.enter()]
    out["terminated_into_stepping"] = [run.set_state(run.deserialize(terminated)[1]), run.do_step(clock.t, H)]
    out["terminated_into_terminated"] = [done.set_state(terminated_state), done.do_step(0.0, H)]
    other, _ = _started(fmu, "other", {**RIGID, "pendulum.rho": 7000.0})  # other parameters: refused as before
    out["other_parameters"] = other.deserialize(stepping)[0]
    out["messages"] = blank.since(0) + run.since(0)
    for inst in (early, run, done, fresh, init, blank, other):
        inst.free()
    fmu.close()
    return out


def test_a_state_sets_the_instance_to_its_mode_where_the_table_allows_it(fmus):
    got = child("resume_rules_child", str(fmus[0]))
    assert got["early"] == [0, 0] and got["done"] == 0, got
    assert got["before_into_instantiated"] == [0, 0, 3], got  # still instantiated: no Get
    assert got["then_initialised"] == [3, 0, 0, [0, [0.2]], 0], got  # the state's theta0, not 0.4
    assert got["stepping_into_init"] == [0, 0, 0] and got["then_stepping"] == [3, 0], got
    assert got["terminated_into_instantiated"] == [3, 0], got
    assert got["terminated_into_stepping"] == [3, 0], got
    assert got["terminated_into_terminated"] == [0, 3] and got["other_parameters"] == 3, got
    refusals = [m for m in got["messages"] if "fmi2SetFMUstate refused" in m]
    assert len(refusals) == 2 and all("taken in state terminated" in m for m in refusals), got["messages"]


def pid_states_child(path: str) -> dict:
    fmu = fmi2_raw.Fmu(path)
    inst = fmi2_raw.Instance(fmu, "pid")
    out: dict[str, Any] = {
        "capabilities": [fmu.md.coSimulation.canGetAndSetFMUstate, fmu.md.coSimulation.canSerializeFMUstate]
    }
    junk = create_string_buffer(b"\x5a" * 64, 64)
    for state_name, advance in (
        ("instantiated", []),
        ("stepComplete", [inst.setup, inst.enter, inst.exit, lambda: inst.do_step(0.0, H)]),
    ):
        assert [f() for f in advance] == [0] * len(advance), inst.messages[-3:]
        status, state = inst.get_state()
        de_status, de = inst.deserialize(b"\x00" * 64)
        null = c_void_p()
        out[state_name] = [
            status,
            state.value is None,
            inst.set_state(addressof(junk)),
            inst.free_state(null),
            inst.state_size(addressof(junk))[0],
            inst.serialize(addressof(junk), 64)[0],
            de_status,
            de.value is None,
        ]
    out["runs_on"] = [inst.do_step(H, H), inst.terminate()]
    inst.free()
    fmu.close()
    return out


def test_the_pid_takes_states_and_refuses_what_is_not_one(fmus):
    """Its own states get, size and serialise (tests/test_pid.py: the rollback); a pointer it did not hand
    out, a NULL free (fmi2OK: nothing to free) and bytes without this FMU's header are refused."""
    got = child("pid_states_child", str(fmus[1]))
    assert got["capabilities"] == [True, True]
    for state in ("instantiated", "stepComplete"):
        assert got[state] == [0, False, 3, 0, 3, 3, 3, True], (state, got[state])
    assert got["runs_on"] == [0, 0]


# ------------------------------------------------------------------------------------------------------
# No fmi2Fatal: a slave class that raises
# ------------------------------------------------------------------------------------------------------

RAISING_ENTRY = Path(__file__).resolve().parent / "raising_entry.py"
RAISING_SWITCH = RAISING_ENTRY.with_name("raising_switch.py")


def raising_copy(fmu: Path, folder: Path) -> Path:
    """A copy of FemPendulum.fmu whose resources/femp_slave_entry.py is tests/raising_entry.py, with the
    switch it imports (tests/raising_switch.py) beside it."""
    copy = folder / "FemPendulum.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(copy, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            if item.filename == "resources/femp_slave_entry.py":
                dst.writestr(item, RAISING_ENTRY.read_text())
            else:
                dst.writestr(item, src.read(item.filename))
        dst.write(RAISING_SWITCH, "resources/raising_switch.py")
    return copy


class Raiser:
    """Calls into one instance of the raising copy with chosen entry points raising (RAISE_SWITCH)."""

    def __init__(self, inst) -> None:
        self.inst = inst
        self.results: dict[str, list] = {}  # label -> what attempt() saw

    def attempt(self, methods: tuple[str, ...], call: Callable[[], int], switch: str = "*") -> list:
        """`call` while `switch` raises: its status and whether the message of one of `methods` (the entry
        points the call may reach first) was logged."""
        mark = self.inst.mark()
        os.environ[RAISE_SWITCH] = switch
        try:
            status = call()
        finally:
            os.environ[RAISE_SWITCH] = ""
        return [status, any(f"planted failure in {m}" in text for m in methods for text in self.inst.since(mark))]

    def call(self, label: str, methods: tuple[str, ...], call: Callable[[], int], switch: str = "*") -> None:
        self.results[label] = self.attempt(methods, call, switch)

    def variables(self, state: str, sets: tuple[str, ...]) -> None:
        """The four getters (where allowed) and the setters named in `sets` (Real, Integer, ...)."""
        inst = self.inst
        names = {"Real": "torque", "Integer": "model.fidelity", "Boolean": "model.compute_stress"}
        values = {"Real": 1.0, "Integer": 2, "Boolean": False, "String": ""}
        for kind in ("Real", "Integer", "Boolean", "String"):
            name = names.get(kind, "output.vtk_folder")
            if state != "instantiated":
                self.call(f"{state}:fmi2Get{kind}", (f"get_{kind.lower()}",), lambda n=name: inst.get_named(n)[0])
            if kind in sets:
                self.call(
                    f"{state}:fmi2Set{kind}",
                    (f"set_{kind.lower()}",),
                    lambda n=name, k=kind: inst.set_named(**{n: values[k]}),
                )

    def states(self, state: str) -> dict[str, list]:
        """The state functions with the slave's entry points raising. Where a state's bytes are made (at
        get or at size) and read (at deserialise or at set) is the binary's choice, so with one entry
        point raising a chain of calls runs up to the first that does not answer fmi2OK: that one must
        answer fmi2Error with the entry point's message."""
        inst = self.inst
        status, kept = inst.get_state()
        data = inst.serialized(kept)
        self.call(f"{state}:fmi2GetFMUstate", ("_get_fmu_state",), lambda: inst.get_state()[0])
        self.call(f"{state}:fmi2SetFMUstate", ("_set_fmu_state", "_fmu_state_from_bytes"), lambda: inst.set_state(kept))
        held: list[c_void_p] = []  # the handles the chains got, freed at the end

        def get() -> int:
            got, handle = inst.get_state()
            held.append(handle)
            return got

        def deserialize() -> int:
            got, handle = inst.deserialize(data)
            held.append(handle)
            return got

        chains: dict[str, list[Callable[[], int]]] = {
            "_fmu_state_to_bytes": [
                get,
                lambda: inst.state_size(held[-1])[0],
                lambda: inst.serialize(held[-1], len(data))[0],
            ],
            "_fmu_state_from_bytes": [deserialize, lambda: inst.set_state(held[-1])],
            "_set_fmu_state": [deserialize, lambda: inst.set_state(held[-1])],
        }
        seen: dict[str, list] = {}
        for method, calls in chains.items():
            seen[method] = []
            for call in calls:
                seen[method].append(self.attempt((method,), call, method))
                if seen[method][-1][0] != 0:
                    break
        for handle in held:
            if handle.value is not None:
                inst.free_state(handle)
        seen["kept"] = [status, inst.free_state(kept)]
        return seen


def raising_child(path: str) -> dict:
    """Walk an instance of the raising copy through the four states with the switch off and, in each
    state, make the calls allowed there with the slave's entry points raising; then __init__ raising."""
    fmu = fmi2_raw.Fmu(path)
    inst = fmi2_raw.Instance(fmu, "raising")
    out: dict[str, Any] = {"instantiate": inst.c is not None}
    raiser = Raiser(inst)
    chains = {}
    # instantiated
    raiser.call("instantiated:fmi2SetupExperiment", ("setup_experiment",), lambda: inst.setup(0.0))
    raiser.call("instantiated:fmi2EnterInitializationMode", ("enter_initialization_mode",), inst.enter)
    raiser.variables("instantiated", ("Real", "Integer", "Boolean", "String"))
    chains["instantiated"] = raiser.states("instantiated")
    # each refusal kept the state: the walk goes on from where it was
    out["to_init"] = [inst.set_named(**RIGID), inst.setup(0.0), inst.enter()]
    raiser.variables("initializationMode", ("Real", "Integer", "Boolean", "String"))
    chains["initializationMode"] = raiser.states("initializationMode")
    raiser.call("initializationMode:fmi2ExitInitializationMode", ("exit_initialization_mode",), inst.exit)
    out["to_step"] = [inst.exit(), inst.do_step(0.0, H)]
    raiser.variables("stepComplete", ("Real",))
    chains["stepComplete"] = raiser.states("stepComplete")
    raiser.call("stepComplete:fmi2DoStep", ("do_step",), lambda: inst.do_step(H, H))
    raiser.call("stepComplete:fmi2Terminate", ("terminate",), inst.terminate)
    out["step_after"] = [
        inst.do_step(H, H),
        inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)[1] == 2 * H,
        inst.terminate(),
    ]
    raiser.variables("terminated", ())
    chains["terminated"] = raiser.states("terminated")
    # __init__ raising: fmi2Reset (a new slave object) and fmi2Instantiate
    raiser.call("terminated:fmi2Reset", ("__init__",), inst.reset, "__init__")
    inst.free()
    os.environ[RAISE_SWITCH] = "__init__"
    try:
        refused = fmi2_raw.Instance(fmu, "refused")
    finally:
        os.environ[RAISE_SWITCH] = ""
    out["init_raises"] = [refused.c is None, any("planted failure in __init__" in m.text for m in refused.messages)]
    again = fmi2_raw.Instance(fmu, "again")
    out["again"] = [again.c is not None, again.set_named(**RIGID), again.setup(), again.enter(), again.exit()]
    again.free()
    fmu.close()
    out["raised"] = raiser.results
    out["chains"] = chains
    return out


RAISED = [  # state:call, each answered with the entry point it reaches raising
    *(f"instantiated:{c}" for c in ("fmi2SetupExperiment", "fmi2EnterInitializationMode")),
    *(f"{s}:fmi2Set{k}" for s in STATES[:2] for k in ("Real", "Integer", "Boolean", "String")),
    *(f"{s}:fmi2Get{k}" for s in STATES[1:] for k in ("Real", "Integer", "Boolean", "String")),
    *(f"{s}:{c}" for s in STATES for c in ("fmi2GetFMUstate", "fmi2SetFMUstate")),
    "initializationMode:fmi2ExitInitializationMode",
    "stepComplete:fmi2SetReal",
    "stepComplete:fmi2DoStep",
    "stepComplete:fmi2Terminate",
    "terminated:fmi2Reset",
]


def test_a_slave_that_raises_gets_fmi2error_never_fatal(fmus, tmp_path):
    """Each FMI entry point of the slave raising RuntimeError, called in each state where it is allowed:
    fmi2Error with the exception's message logged, the state kept; __init__ raising: fmi2Instantiate
    gives NULL with the message; the process lives and exits 0."""
    got = child("raising_child", str(raising_copy(fmus[0], tmp_path)))
    assert got["instantiate"]
    assert sorted(got["raised"]) == sorted(RAISED)
    for label, value in got["raised"].items():
        assert value == [3, True], (label, value)
    assert sorted(got["chains"]) == sorted(STATES)
    for state, chains in got["chains"].items():
        assert chains.pop("kept") == [0, 0], (state, chains)
        for method, calls in chains.items():  # fmi2OK and no message up to the call that reaches the method
            assert calls[-1] == [3, True] and all(c == [0, False] for c in calls[:-1]), (state, method, calls)
    assert got["to_init"] == [0, 0, 0] and got["to_step"] == [0, 0] and got["step_after"] == [0, True, 0], got
    assert got["init_raises"] == [True, True], got
    assert got["again"] == [True, 0, 0, 0, 0], got


# ------------------------------------------------------------------------------------------------------
# fmi2Discard, the status functions, fmi2Reset
# ------------------------------------------------------------------------------------------------------

DISCARD_START = {**RIGID, "solver.max_substeps": 1, "theta0": 0.25}
SHORT = 2e-3  # solver.max_step: one internal step
LONG = 1e-2  # five internal steps: more than solver.max_substeps allows


def _discard_run(inst, with_discard: bool) -> tuple[list, dict]:
    """Two short steps, the long step (if `with_discard`), then five short steps: per doStep its status and
    the snapshot; and what the status functions said around the discarded step."""
    seen: dict[str, Any] = {}
    record, t = [], 0.0
    for k in range(7):
        if k == 2 and with_discard:
            before = inst.snapshot()
            seen["long"] = inst.do_step(t, LONG)
            seen["kept"] = inst.snapshot() == before
            seen["terminated"] = inst.status("Boolean", fmi2_raw.TERMINATED)
            seen["last_time"] = inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)
            seen["at"] = t
            seen["do_step_status"] = inst.status("", fmi2_raw.DO_STEP_STATUS)[0]
            seen["pending_status"] = inst.status("String", fmi2_raw.PENDING_STATUS)[0]
            seen["integer_status"] = inst.status("Integer", fmi2_raw.DO_STEP_STATUS)[0]
            seen["unknown_kind"] = [inst.status("Real", 99)[0], inst.status("Boolean", 99)[0]]
            seen["null_value"] = [
                inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME, null=True)[0],
                inst.status("Boolean", fmi2_raw.TERMINATED, null=True)[0],
            ]
        status = [inst.set_named(torque=-0.3), inst.do_step(t, SHORT)]
        t += SHORT
        record.append([status, inst.snapshot()])
    seen["end_time"] = [inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME), t]
    return record, seen


def discard_child(path: str) -> dict:
    fmu = fmi2_raw.Fmu(path)
    out: dict[str, Any] = {}
    reference = fmi2_raw.Instance(fmu, "reference")
    assert [reference.setup(), reference.enter()] == [0, 0]
    out["start_values"] = reference.snapshot()
    assert [reference.set_named(**DISCARD_START), reference.exit()] == [0, 0], reference.messages[-3:]
    never_failed, _ = _discard_run(reference, with_discard=False)
    reference.free()

    inst = fmi2_raw.Instance(fmu, "inst")
    runs = []
    for _ in range(2):
        assert [inst.setup(), inst.enter()] == [0, 0], inst.messages[-3:]
        init_snapshot = inst.snapshot()
        assert [inst.set_named(**DISCARD_START), inst.exit()] == [0, 0], inst.messages[-3:]
        mark = inst.mark()
        record, seen = _discard_run(inst, with_discard=True)
        seen["discard_logged"] = any("max_substeps" in m for m in inst.since(mark))
        seen["terminated_before"] = inst.status("Boolean", fmi2_raw.TERMINATED)
        seen["terminate"] = inst.terminate()
        seen["terminated_after"] = inst.status("Boolean", fmi2_raw.TERMINATED)
        seen["last_time_after"] = inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)
        seen["reset"] = inst.reset()
        # instantiated again: what is not allowed there is refused
        seen["instantiated_refuses"] = [inst.get_named("theta")[0], inst.do_step(0.0, SHORT), inst.exit()]
        runs.append({"init_snapshot": init_snapshot, "record": record, "seen": seen})
    inst.free()
    fmu.close()
    out["never_failed"] = never_failed
    out["runs"] = runs
    return out


def test_discard_keeps_the_state_a_retry_matches_a_run_that_never_failed_and_reset_repeats_it(fmus):
    got = child("discard_child", str(fmus[0]))
    first, second = got["runs"]
    seen = first["seen"]
    assert seen["long"] == 2 and seen["kept"] and seen["discard_logged"], seen
    assert seen["terminated"] == [0, 0], seen  # fmi2OK, fmi2False: a discard does not terminate
    assert seen["last_time"] == [0, seen["at"]] and seen["at"] == pytest.approx(2 * SHORT), seen
    assert seen["do_step_status"] == 2 and seen["pending_status"] == 2 and seen["integer_status"] == 2, seen
    assert seen["unknown_kind"] == [3, 3] and seen["null_value"] == [3, 3], seen
    assert first["record"] == got["never_failed"]  # the retry, bit for bit
    assert all(status == [0, 0] for status, _ in first["record"])
    assert first["record"][0][1] != first["record"][-1][1]  # it moved
    end, t = seen["end_time"]
    assert end == [0, t] and math.isclose(t, 7 * SHORT), seen
    assert seen["terminated_before"] == [0, 0] and seen["terminate"] == 0 and seen["terminated_after"] == [0, 1], seen
    assert seen["last_time_after"] == [0, t], seen
    assert seen["reset"] == 0 and seen["instantiated_refuses"] == [3, 3, 3], seen
    # after fmi2Reset: start values (as a new instance has them) and the same run, bit for bit
    assert first["init_snapshot"] == second["init_snapshot"] == got["start_values"]
    assert got["start_values"][1]["solver.max_substeps"] == "0" and got["start_values"][1]["model.fidelity"] == "4"
    assert second["record"] == first["record"] and second["seen"] == seen


def pid_reset_child(path: str) -> dict:
    fmu = fmi2_raw.Fmu(path)
    inst = fmi2_raw.Instance(fmu, "pid")
    runs = []
    for _ in range(2):
        assert [inst.setup(), inst.enter()] == [0, 0], inst.messages[-3:]
        start = inst.snapshot()
        assert inst.set_named(Kp=20.0, Ki=1.0, setpoint=0.3) == 0 and inst.exit() == 0
        record, t = [], 0.0
        for k in range(5):
            status = [inst.set_named(measurement=0.01 * k), inst.do_step(t, H)]
            t += H
            record.append([status, inst.snapshot(), inst.status("Boolean", fmi2_raw.TERMINATED)])
        terminated = [inst.terminate(), inst.status("Boolean", fmi2_raw.TERMINATED)]
        record.append([*terminated, inst.status("Real", fmi2_raw.LAST_SUCCESSFUL_TIME)])
        runs.append([start, record, inst.reset()])
    inst.free()
    fmu.close()
    return runs


def test_pid_reset_returns_to_start_values_and_repeats_the_run(fmus):
    first, second = child("pid_reset_child", str(fmus[1]))
    assert first == second
    start, record, reset = first
    assert start[1]["Kp"] == (10.0).hex() and reset == 0
    assert all(step[0] == [0, 0] and step[2] == [0, 0] for step in record[:-1])
    assert record[-1][:2] == [0, [0, 1]] and record[-1][2][0] == 0
    assert record[0][1] != record[-2][1]  # the output moved


def test_the_raising_entry_names_entry_points_of_pythonfmus_slave_class():
    """RAISING names methods of pythonfmu's Fmi2Slave (what the binary calls): a renamed entry point
    cannot leave the fault test testing nothing."""
    for name in RAISING:
        assert callable(inspect.getattr_static(Fmi2Slave, name).__get__(None, Fmi2Slave)), name
