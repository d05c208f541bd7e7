"""The FMUs' FMI 2.0 contract (docs/reference/fmi2.md) as a native C master meets it (tests/fmi2_sequence_host.c).

A fast lane of random call sequences judged by the contract's state table and argument rules
(tests/fmi2_sequences.py), and one plain regression test per defect class the contract fixes: each
of them failed with pythonfmu's binary in front (serialising into a larger buffer read past the state,
a deserialised state made the next state call fatal, fmi2Terminated stuck at true after a discarded
step, no state machine, any GUID accepted) or with an earlier version of ours.
"""

from __future__ import annotations

import pytest
from fmi2_sequences import (
    DISCARD,
    ERROR,
    OK,
    VIOLATION_KINDS,
    Call,
    Host,
    Runner,
    compile_host,
    load_fmu,
    minimise,
    report,
    run_campaign,
)

RIGID = 2
FAST_LANE = {"n": 100, "seed": 20261202, "fem_share": 0.04, "two_share": 0.25, "pid_share": 0.06}


@pytest.fixture(scope="module")
def lab(fmus, tmp_path_factory):
    """The FMUs extracted and the host compiled and started once for this module: (host, FMU infos)."""
    work = tmp_path_factory.mktemp("fmi2_sequences")
    pendulum, pid = fmus
    infos = {"pendulum": load_fmu(pendulum, 0, work / "FemPendulum"), "pid": load_fmu(pid, 1, work / "PidController")}
    host = Host(compile_host(work), infos.values(), work, timeout=60.0)
    yield host, infos
    host.close()


@pytest.fixture(scope="module")
def fast_lane(lab):
    """About 100 random sequences (mostly rigid, a few PID, a couple of fem, a quarter with two instances),
    the campaign and its report with the minimal reproducers of the first few violation classes."""
    host, infos = lab
    runner = Runner(host, infos)
    c = FAST_LANE
    campaign = run_campaign(runner, c["n"], c["seed"], c["fem_share"], c["two_share"], c["pid_share"])
    reproducers = {sig: minimise(runner, campaign.first[sig], budget=15) for sig, _ in campaign.counts.most_common(6)}
    text = report(campaign, reproducers)
    print(text)
    return campaign, text


def test_random_sequences_never_crash_hang_answer_fatal_or_accept_a_forbidden_call(fast_lane):
    campaign, text = fast_lane
    assert campaign.sequences == FAST_LANE["n"] and campaign.calls > 2000, text
    assert {k: campaign.violations[k] for k in ("crash", "hang", "fatal", "forbidden-OK")} == dict.fromkeys(
        ("crash", "hang", "fatal", "forbidden-OK"), 0
    ), text


def test_random_sequences_get_the_answers_and_values_the_contract_promises(fast_lane):
    """Legal calls succeed, values read back are those set or restored, refusals are logged."""
    campaign, text = fast_lane
    others = [k for k in VIOLATION_KINDS if k not in ("crash", "hang", "fatal", "forbidden-OK")]
    assert {k: campaign.violations[k] for k in others} == dict.fromkeys(others, 0), text


def test_random_sequences_reach_the_interesting_states(fast_lane):
    campaign, text = fast_lane
    cov, kinds = campaign.coverage, campaign.kinds
    assert cov["discard"] >= 40 and cov["retry after a discard"] >= 15 and cov["calls after a discard"] >= 80, text
    assert cov["restore"] >= 20 and cov["restore into an instance without a model"] >= 1, text
    assert cov["set of a state taken in terminated refused"] >= 1, text
    assert cov["deserialise"] >= 5 and cov["serialise"] >= 10 and cov["serialise into a larger buffer"] >= 10, text
    assert cov["reset"] >= 15 and cov["terminate"] >= 5 and cov["calls in terminated"] >= 30, text
    assert cov["exit refused (invalid parameters)"] >= 1 and cov["instantiate refused"] >= 5, text
    assert campaign.answers["Error"] >= 300 and campaign.answers["Discard"] >= 60, text
    assert sum(v for k, v in kinds.items() if "+" in k) >= 15, text  # two instances at once
    assert sum(v for k, v in kinds.items() if "fem" in k) >= 2 and sum(v for k, v in kinds.items() if "pid" in k) >= 3


SLOW_RUN = {"n": 1000, "seed": 1, "fem_share": 0.2, "two_share": 0.2, "pid_share": 0.1}


@pytest.mark.slow
def test_a_thousand_random_sequences_with_fem_and_two_instances_find_no_violation(lab):
    """The slow run docs/reference/fmi2.md reports (also `python tests/fmi2_sequences.py --sequences 1000 --seed 1
    --fem-share 0.2 --two-instance-share 0.2`): every violation kind zero, fem and pairs well covered."""
    host, infos = lab
    c = SLOW_RUN
    campaign = run_campaign(Runner(host, infos), c["n"], c["seed"], c["fem_share"], c["two_share"], c["pid_share"])
    text = report(campaign, {})
    assert campaign.sequences == 1000 and campaign.calls > 30000, text
    assert not any(campaign.violations.values()), text
    assert sum(v for k, v in campaign.kinds.items() if "fem" in k) >= 100, text
    assert sum(v for k, v in campaign.kinds.items() if "+" in k) >= 100, text


FAKE_HOST = """#!/bin/sh
# answers like tests/fmi2_sequence_host.c, but a doStep never answers and a GetReal crashes
while read -r cmd rest; do
  case "$cmd" in
    load|instantiate|clear) echo "@@ans ok" ;;
    free) echo "@@ans done" ;;
    dostep) exec sleep 30 ;;
    getreal) kill -SEGV $$ ;;
    *) echo "@@ans 0" ;;
  esac
done
"""


def test_the_driver_reports_a_hang_and_a_crash_and_restarts_the_host(lab, tmp_path):
    """The judge of the fast lane: a call without an answer is a hang, a host killed by a signal a crash."""
    _, infos = lab
    fake = tmp_path / "fake_host"
    fake.write_text(FAKE_HOST)
    fake.chmod(0o755)
    host = Host(fake, infos.values(), tmp_path, timeout=1.0)
    runner = Runner(host, infos)
    start = [Call("instantiate", 0, ("pendulum", "right", 1, 0, "full", "name")), Call("enter", 0), Call("exit", 0)]
    try:
        hung = runner.run([*start, Call("dostep", 0, ("right", 0.001, 1)), Call("terminate", 0)])
        crashed = runner.run([*start, Call("get", 0, ("Real", (1,)))])
        fine = runner.run(start)
    finally:
        host.close()
    assert hung.violation is not None and hung.violation.kind == "hang" and hung.violation_at == 3
    assert hung.steps[-1].line.startswith("dostep 0 0.0 0.001")
    assert crashed.violation is not None and crashed.violation.kind == "crash" and "-11" in crashed.violation.detail
    assert fine.violation is None and len(fine.steps) == 3 and host.starts == 3


# ------------------------------------------------------------------------------------- regression tests
class Driver:
    """Scripted calls through the host: `send` returns the answer's tokens and keeps the call's log."""

    def __init__(self, host: Host, infos: dict) -> None:
        self.host, self.infos = host, infos
        self.pendulum, self.pid = infos["pendulum"], infos["pid"]
        self.log: list[str] = []

    def send(self, line: str) -> list[str]:
        answer, self.log = self.host.send(line)
        return answer.split()

    def status(self, line: str) -> int:
        return int(self.send(line)[0])

    def vr(self, name: str, fmu: str = "pendulum") -> int:
        return self.infos[fmu].vr(name)

    def logged(self, *words: str) -> bool:
        """A log line with status fmi2Error containing all `words`."""
        return any(" 3 " in line.split("]")[0] and all(w in line for w in words) for line in self.log)

    def instantiate(self, k: int = 0, fmu: str = "pendulum", guid: str | None = None, **kw) -> str:
        info = self.infos[fmu]
        args = {"type": 1, "callbacks": "full", "name": f"{fmu}{k}", "logging": 0} | kw
        return self.send(
            f"instantiate {k} {info.lib} {args['name']} {guid or info.guid} {args['type']} 0 {args['logging']} "
            f"{args['callbacks']}"
        )[0]

    def start(self, k: int = 0, substeps: int = 0, start: float = 0.0, reals: dict | None = None) -> None:
        """A rigid pendulum in slot k, initialised (solver.max_substeps = substeps, start time `start`)."""
        assert self.instantiate(k) == "ok", self.log
        self.configure(k, substeps, start, reals)
        assert self.status(f"exit {k}") == OK, self.log

    def configure(self, k: int, substeps: int = 0, start: float = 0.0, reals: dict | None = None) -> None:
        """setupExperiment, enterInitializationMode and the rigid fidelity's parameters (slot k instantiated)."""
        assert self.status(f"setup {k} 0 0 {start!r} 0 0") == OK, self.log
        assert self.status(f"enter {k}") == OK, self.log
        fid, sub = self.vr("model.fidelity"), self.vr("solver.max_substeps")
        assert self.status(f"setint {k} 2 {fid} {sub} {RIGID} {substeps}") == OK, self.log
        for name, value in (reals or {}).items():
            assert self.status(f"setreal {k} 1 {self.vr(name)} {value!r}") == OK, self.log

    def real(self, k: int, name: str, fmu: str = "pendulum") -> float:
        tokens = self.send(f"getreal {k} 1 {self.vr(name, fmu)}")
        assert int(tokens[0]) == OK, self.log
        return float(tokens[1])

    def steps(self, k: int, t: float, h: float, n: int) -> tuple[float, list[float]]:
        """n steps of h from t, all fmi2OK: the time after them and theta after each."""
        thetas = []
        for _ in range(n):
            assert self.status(f"dostep {k} {t!r} {h!r} 1") == OK, self.log
            t = t + h
            thetas.append(self.real(k, "theta"))
        return t, thetas

    def last_successful_time(self, k: int = 0) -> float:
        tokens = self.send(f"realstatus {k} 2 0")
        assert int(tokens[0]) == OK, self.log
        return float(tokens[1])

    def serialise(self, k: int, j: int, b: int, mode: str = "exact", delta: int = 0) -> tuple[int, int, int, int, str]:
        """(size status, n, status, untouched, hash) of fmi2SerializedFMUstateSize + fmi2SerializeFMUstate."""
        size_status, n, status, untouched, digest = self.send(f"serialize {k} {j} {mode} {delta} {b}")
        return int(size_status), int(n), int(status), int(untouched), digest

    def state(self, line: str) -> tuple[int, int]:
        """(status, the state slot after the call) of a getstate / freestate / deser line."""
        status, pointer = self.send(line)
        return int(status), int(pointer, 16)


@pytest.fixture
def d(lab):
    host, infos = lab
    driver = Driver(host, infos)
    yield driver
    for k in (0, 1):  # whatever the test left: the slots are free for the next one
        if host.running:
            host.send(f"free {k}")
    if host.running:
        host.send("clear")


def test_serialising_into_a_larger_buffer_writes_exactly_the_state(d):
    """pythonfmu's binary copied the buffer's size out of the state's bytes: reads past them (a segfault)."""
    d.start()
    d.steps(0, 0.0, 1e-3, 10)
    assert d.state("getstate 0 0")[0] == OK
    for delta in (1, 100, 1 << 20):
        size_status, n, status, untouched, _ = d.serialise(0, 0, 0, "larger", delta)
        assert (size_status, status, untouched) == (OK, OK, 1) and n > 80, d.log
    status, ptr = d.state("deser 0 1 0 real 0")  # the bytes written are a whole state
    assert status == OK and ptr != 0, d.log
    assert d.status("setstate 0 1") == OK, d.log


def test_a_deserialised_state_works_with_every_state_function(d):
    """With pythonfmu's binary the size of a deserialised state was fatal; it serialises back identically."""
    d.start()
    t, _ = d.steps(0, 0.0, 1e-3, 5)
    theta5 = d.real(0, "theta")
    assert d.state("getstate 0 0")[0] == OK
    size_status, n, status, _, digest = d.serialise(0, 0, 0)
    assert (size_status, status) == (OK, OK), d.log
    d.steps(0, t, 1e-3, 5)
    status, ptr = d.state("deser 0 1 0 real 0")
    assert status == OK and ptr != 0, d.log
    assert d.send("size 0 1 0") == ["0", str(n)], d.log
    assert d.serialise(0, 1, 2) == (OK, n, OK, 1, digest), d.log
    assert d.status("setstate 0 1") == OK, d.log
    assert d.real(0, "theta") == theta5 and d.last_successful_time() == t
    assert d.state("getstate 0 1") == (OK, ptr), d.log  # into a live state of this instance: in place
    assert d.state("freestate 0 1 addr") == (OK, 0), d.log
    t2, _ = d.steps(0, t, 1e-3, 5)  # the instance goes on from the restored state
    assert d.last_successful_time() == t2
    assert d.status("setstate 0 1") == ERROR  # NULL now


def test_junk_truncated_or_foreign_bytes_are_refused_at_deserialise(d):
    d.start()
    assert d.state("getstate 0 0")[0] == OK
    _, n, status, _, _ = d.serialise(0, 0, 0)
    assert status == OK
    data = bytes.fromhex(d.send("dump 0")[0])
    at = data.find(d.pendulum.guid.encode())
    assert len(data) == n and at >= 0  # the header names the FMU's GUID
    refused = [
        "junk 300",
        "junk 5000",
        "empty 0",
        "nullbuf 0",
        f"trunc {n - 1}",
        f"trunc {n // 2}",
        "trunc 80",
        "magic 0",
        f"flip {at + 3}",  # another FMU's GUID
        "nullout 0",
    ]
    for what in refused:
        mode, arg = what.split()
        assert d.state(f"deser 0 3 0 {mode} {arg}") == (ERROR, 0), (what, d.log)
        assert d.logged("fmi2DeSerializeFMUstate"), (what, d.log)
    # an initialised instance refuses a state taken with other parameter values
    d.start(1, reals={"theta0": 0.25})
    assert d.state("deser 1 4 0 real 0") == (ERROR, 0), d.log
    assert d.logged("theta0"), d.log
    assert d.steps(0, 0.0, 1e-3, 2) and d.steps(1, 0.0, 1e-3, 2)  # both go on
    assert d.state("deser 0 4 0 real 0")[0] == OK  # the bytes were fine all along


def test_serialising_into_a_smaller_buffer_is_refused_and_writes_nothing(d):
    d.start()
    assert d.state("getstate 0 0")[0] == OK
    for mode, delta in (("smaller", 1), ("smaller", 40), ("smaller", 10**9), ("nullbuf", 0)):
        size_status, n, status, untouched, _ = d.serialise(0, 0, 0, mode, delta)
        assert (size_status, status, untouched) == (OK, ERROR, 1) and n > 0, (mode, delta, d.log)
        assert d.logged("fmi2SerializeFMUstate"), d.log
    assert d.serialise(0, 0, 0)[2] == OK


def test_instantiate_refuses_a_wrong_guid_fmu_type_or_callbacks(d):
    wrong = "{12345678-0000-4000-8000-000000000000}"
    assert d.instantiate(0, guid=wrong) == "null"
    assert d.logged(wrong, d.pendulum.guid), d.log  # the message names both
    assert d.instantiate(0, guid=d.pid.guid) == "null"  # the other FMU's GUID
    assert d.instantiate(0, fmu="pid", guid=d.pendulum.guid) == "null"
    assert d.instantiate(0, type=0) == "null"  # fmi2ModelExchange
    assert d.instantiate(0, callbacks="nologger") == "null"
    assert d.instantiate(0, callbacks="null") == "null"
    assert d.instantiate(0, name="@null") == "null"
    assert d.instantiate(0, guid="@null") == "null"
    assert d.instantiate(0) == "ok" and d.instantiate(1, fmu="pid") == "ok"


def test_terminated_is_false_after_a_discard_and_the_retry_succeeds(d):
    """pythonfmu's binary answered fmi2Terminated = true after any discarded step."""
    d.start(0, substeps=1)
    d.start(1, substeps=1)
    t, _ = d.steps(0, 0.0, 1e-3, 3)
    assert d.status(f"dostep 0 {t!r} 0.05 1") == DISCARD, d.log  # more internal steps than solver.max_substeps
    assert d.send("boolstatus 0 3 0") == ["0", "0"], d.log
    assert d.last_successful_time() == t
    assert d.send("status 0 0 0")[0] == str(DISCARD)  # fmi2DoStepStatus: no step is pending
    _, thetas = d.steps(0, t, 1e-3, 1)  # the retry with a shorter step
    _, reference = d.steps(1, 0.0, 1e-3, 4)  # the same steps without the discarded one
    assert thetas[-1] == reference[-1]  # the discarded step left the model exactly as it was
    assert d.status("terminate 0") == OK and d.send("boolstatus 0 3 0") == ["0", "1"]


def test_last_successful_time_is_the_fmus_time(d):
    d.start(0, substeps=1, start=0.25)
    assert d.last_successful_time() == 0.25  # the start time before any step
    t, _ = d.steps(0, 0.25, 0.002, 2)
    assert d.last_successful_time() == t  # the end of the last successful step
    assert d.state("getstate 0 0")[0] == OK
    assert d.status(f"dostep 0 {t!r} 0.05 1") == DISCARD
    assert d.last_successful_time() == t  # the start of the discarded step
    t2, _ = d.steps(0, t, 0.002, 3)
    assert d.last_successful_time() == t2
    assert d.status("setstate 0 0") == OK and d.last_successful_time() == t  # a restored state's time
    assert d.status("terminate 0") == OK and d.last_successful_time() == t


def test_terminate_is_refused_in_instantiated_and_initialization_mode(d):
    assert d.instantiate(0) == "ok"
    assert d.status("terminate 0") == ERROR
    assert d.logged("fmi2Terminate", "instantiated"), d.log  # names the call and the state
    d.configure(0)
    assert d.status("terminate 0") == ERROR and d.logged("fmi2Terminate", "initializationMode"), d.log
    assert d.status("exit 0") == OK  # nothing was changed by the refusals
    d.steps(0, 0.0, 1e-3, 2)
    assert d.status("terminate 0") == OK
    assert d.status("terminate 0") == ERROR and d.logged("fmi2Terminate", "terminated"), d.log
    assert d.status("dostep 0 0.002 0.001 1") == ERROR


def test_exit_without_enter_is_refused(d):
    assert d.instantiate(0) == "ok"
    assert d.status("exit 0") == ERROR and d.logged("fmi2ExitInitializationMode", "instantiated"), d.log
    d.configure(0)  # still instantiated: setupExperiment and enterInitializationMode work
    assert d.status("enter 0") == ERROR and d.logged("fmi2EnterInitializationMode", "initializationMode"), d.log
    assert d.status("exit 0") == OK
    assert d.status("exit 0") == ERROR and d.status("setup 0 0 0 0.0 0 0") == ERROR
    d.steps(0, 0.0, 1e-3, 2)


def test_get_before_initialisation_is_refused(d):
    assert d.instantiate(0) == "ok"
    for line in ("getreal 0 1 1", "getint 0 1 12", "getbool 0 1 28", "getstring 0 1 40"):
        assert d.send(line) == ["3"], (line, d.log)
        assert d.logged("fmi2Get", "instantiated"), d.log
    for kind in ("realstatus 0 2 0", "boolstatus 0 3 0"):  # status functions too
        assert d.status(kind) == ERROR
    d.configure(0)
    assert d.real(0, "theta0") == d.pendulum.variables["theta0"].start


def test_freed_foreign_and_never_handed_out_states_are_refused(d):
    d.start(0)
    d.start(1)
    assert d.state("getstate 0 0")[0] == OK
    assert d.send("slot copy 0 12")  # the host keeps the pointer, then frees the state
    assert d.state("freestate 0 0 addr") == (OK, 0)
    for made in ("heap 13 13", "static 14 14", "small 15 15"):
        assert d.send(f"slot {made}")
    assert d.state("getstate 1 5")[0] == OK  # another instance's live state
    for j in (12, 13, 14, 15, 5):
        assert d.status(f"setstate 0 {j}") == ERROR, (j, d.log)
        assert d.logged("fmi2SetFMUstate"), d.log
        assert d.send(f"size 0 {j} 0")[0] == "3"
        size_status, _, status, _, _ = d.serialise(0, j, 0)
        assert (size_status, status) == (ERROR, ERROR), (j, d.log)
        before = d.send(f"slot copy {j} {j}")[0]
        assert d.state(f"freestate 0 {j} addr") == (ERROR, int(before, 16)), (j, d.log)
    assert d.state("freestate 0 13 value")[0] == ERROR  # junk where a state's address is due
    assert d.status("setstate 1 5") == OK  # the other instance's state is still its own
    assert d.state("freestate 0 0 null")[0] == OK and d.state("freestate 0 0 addr") == (OK, 0)  # NULL: nothing
    status, ptr = d.state("getstate 0 6")
    assert status == OK
    assert d.state("freestate 0 6 value") == (OK, ptr)  # the state itself where its address is due: freed
    assert d.status("setstate 0 6") == ERROR
    d.steps(0, 0.0, 1e-3, 2)


def test_reset_returns_to_instantiated_and_the_run_repeats_bit_identically(d):
    reals = {"theta0": 0.4, "torque": 0.3}
    d.start(0, reals=reals)
    assert d.state("getstate 0 0")[0] == OK
    _, first = d.steps(0, 0.0, 1e-3, 30)
    assert d.status("reset 0") == OK
    assert d.status("getreal 0 1 1") == ERROR and d.logged("instantiated"), d.log  # instantiated again
    assert d.status("dostep 0 0.03 0.001 1") == ERROR
    d.configure(0)
    start = {n: d.pendulum.variables[n].start for n in ("theta0", "torque")}
    assert [d.real(0, n) for n in ("theta0", "torque")] == list(start.values())  # start values
    for name, value in reals.items():
        assert d.status(f"setreal 0 1 {d.vr(name)} {value!r}") == OK
    assert d.status("exit 0") == OK
    _, again = d.steps(0, 0.0, 1e-3, 30)
    assert again == first
    assert d.status("setstate 0 0") == OK  # a state taken before the reset stays valid
    assert d.steps(0, 0.0, 1e-3, 30)[1] == first


def test_a_refused_set_changes_nothing(d):
    """fmi2SetReal of the torque and a parameter in stepComplete: refused as a whole, the torque kept."""
    d.start(0)
    torque, theta0 = d.vr("torque"), d.vr("theta0")
    assert d.status(f"setreal 0 2 {torque} {theta0} 0.25 {d.real(0, 'theta0')!r}") == ERROR
    assert d.real(0, "torque") == 0.0
    assert d.status(f"setreal 0 2 {torque} 1000 0.25 0.5") == ERROR  # an unknown value reference
    assert d.real(0, "torque") == 0.0


def test_a_nan_communication_point_is_refused_and_changes_nothing(d):
    d.start(0)
    assert d.status("dostep 0 nan 0.001 1") == ERROR
    assert d.status("dostep 0 inf 0.001 1") == ERROR
    t, _ = d.steps(0, 0.0, 1e-3, 2)
    assert d.last_successful_time() == t


def test_the_pid_refuses_what_the_contract_refuses(d):
    assert d.instantiate(0, fmu="pid") == "ok"
    assert d.status("enter 0") == OK and d.status("exit 0") == OK
    u, kp = d.vr("u", "pid"), d.vr("Kp", "pid")
    assert d.status(f"setreal 0 1 {u} 1.0") == ERROR  # an output
    assert d.status(f"setreal 0 1 {kp} 10.0") == ERROR  # a parameter in stepComplete, whatever its value
    for t, h in (("0.0", "nan"), ("0.0", "inf"), ("0.0", "0.0"), ("0.0", "-0.001"), ("nan", "0.001"), ("0.5", "0.01")):
        assert d.status(f"dostep 0 {t} {h} 1") == ERROR, (t, h, d.log)
    assert d.status("dostep 0 0.0 0.01 1") == OK
    status, state = d.state("getstate 0 0")  # its own states it takes; nothing a state is not
    assert status == OK and state != 0
    assert d.send("size 0 1 0")[0] == "3" and d.state("freestate 0 1 null")[0] == OK  # an empty slot; NULL: nothing
    assert d.status(f"setinder 0 1 {u} 1 0.5") == ERROR  # an output
    assert d.status(f"setinder 0 1 {d.vr('setpoint', 'pid')} 3 0.5") == ERROR  # order 3
    assert d.send(f"getoutder 0 1 {kp} 1")[0] == "3"  # a parameter


def test_the_time_after_restoring_a_state_taken_before_initialisation(d):
    """A state taken before initialisation brings its time; a setupExperiment after it sets the start time
    again. fmi2LastSuccessfulTime and the communication point doStep accepts agree either way."""
    for k in (0, 1):
        assert d.instantiate(k) == "ok"
        assert d.status(f"setup {k} 0 0 0.5 0 0") == OK
        assert d.state(f"getstate {k} {k}")[0] == OK  # taken at time 0.5
    assert d.status("setstate 0 0") == OK  # then a setup: its start time
    d.configure(0, start=0.0)
    d.configure(1, start=0.0)  # a setup, then the state: the state's time
    assert d.status("setstate 1 1") == OK
    for k, t in ((0, 0.0), (1, 0.5)):
        assert d.status(f"exit {k}") == OK
        assert d.last_successful_time(k) == t, k
        assert d.status(f"dostep {k} {t!r} 0.001 1") == OK, (k, d.log)


def test_a_failed_exit_leaves_nothing_behind(d):
    """exitInitializationMode refused for pendulum.nu = 0.5; a state restored afterwards steps normally."""
    d.start(0)
    assert d.state("getstate 0 0")[0] == OK
    assert d.status("reset 0") == OK
    d.configure(0, reals={"pendulum.nu": 0.5})
    assert d.status("exit 0") == ERROR and d.logged("pendulum.nu"), d.log
    assert d.status("setstate 0 0") == OK, d.log  # builds the model from the state's parameters: stepComplete
    assert d.status("exit 0") == ERROR and d.logged("refused in state stepComplete"), d.log
    assert d.status("dostep 0 0.0 0.001 1") == OK, d.log


def test_a_new_instance_set_to_a_saved_state_steps_on_without_initialisation(d):
    """A host resuming a saved run in a new instance: the bytes of a state taken after 20 steps, deserialised
    and set in a new instance right after fmi2Instantiate; it steps on as the first instance does, never
    initialised. A state taken once terminated is refused there (the instance stays instantiated)."""
    d.start(0, reals={"torque": -0.5})
    t, _ = d.steps(0, 0.0, 1e-3, 20)
    assert d.state("getstate 0 0")[0] == OK and d.serialise(0, 0, 0)[2] == OK
    _, ahead = d.steps(0, t, 1e-3, 10)
    assert d.status("terminate 0") == OK and d.state("getstate 0 1")[0] == OK and d.serialise(0, 1, 1)[2] == OK
    assert d.instantiate(1) == "ok"
    assert d.state("deser 1 2 1 real 0")[0] == OK
    assert d.status("setstate 1 2") == ERROR and d.logged("taken in state terminated"), d.log
    assert d.state("deser 1 3 0 real 0")[0] == OK
    assert d.status("setstate 1 3") == OK, d.log
    assert d.last_successful_time(1) == t and d.steps(1, t, 1e-3, 10)[1] == ahead
    assert d.status("enter 1") == ERROR and d.logged("refused in state stepComplete"), d.log


# lifecycle entry points, and the rest: an instance reaches stepComplete only when the first do not raise
RAISING_AT_START = ("setup_experiment", "enter_initialization_mode", "exit_initialization_mode")
RAISING_LATER = (
    "do_step", "get_real", "get_integer", "set_real", "set_integer", "terminate", "_get_fmu_state",
)  # fmt: skip


@pytest.mark.parametrize("raising", [RAISING_AT_START, RAISING_LATER], ids=["life-cycle", "step-mode"])
def test_a_slave_that_raises_answers_error_never_fatal_in_a_native_host(fmus, tmp_path, raising):
    """A copy of the pendulum whose slave raises in the named entry points (tests/test_fmi2_contract.py's
    raising copy): each such call answers fmi2Error with the exception in the log, never fmi2Fatal, and the
    host goes on; fmi2Reset and fmi2FreeInstance still work."""
    from test_fmi2_contract import RAISE_SWITCH, raising_copy

    info = load_fmu(raising_copy(fmus[0], tmp_path), 0, tmp_path / "raising")
    host = Host(compile_host(tmp_path), [info], tmp_path, env={RAISE_SWITCH: ",".join(raising)})
    d = Driver(host, {"pendulum": info, "pid": info})
    try:
        assert d.instantiate(0) == "ok"
        later = raising == RAISING_LATER
        for call in ("setup 0 0 0 0.0 0 0", "enter 0"):
            assert d.status(call) == (OK if later else ERROR), d.log
            assert later or d.logged("RuntimeError", "planted failure"), d.log
        # Enter raised: still instantiated, so Exit is refused by the state machine, before the slave
        assert d.status("exit 0") == (OK if later else ERROR) and (later or d.logged("refused in state instantiated"))
        if later:
            theta, torque = d.vr("theta"), d.vr("torque")
            for call in ("dostep 0 0.0 0.001 1", f"getreal 0 1 {theta}", f"setreal 0 1 {torque} 0.5", "getstate 0 0"):
                assert d.status(call) == ERROR and d.logged("RuntimeError", "planted failure"), (call, d.log)
            assert d.status("terminate 0") == ERROR  # and the instance stays in stepComplete
            assert d.status("dostep 0 0.0 0.001 1") == ERROR
        assert d.status("reset 0") == OK
        assert host.send("free 0")[0] == "done" and host.running
    finally:
        host.close()
