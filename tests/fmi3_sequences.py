"""Random FMI 3.0 co-simulation call sequences through fmpy's FMU3Slave, judged by the FMI 3.0 state machine.

The FMI 3.0 FMU's binary (fem_pendulum_fmu/fmi/shim/fmi3_*.c, docs/reference/fmi3.md) promises, as the FMI 2.0
one does (tests/fmi2_sequences.py, its larger sibling through a C host): each call is answered as the
table of shim/fmi3_calls.h says for the instance's state (instantiated, initializationMode, eventMode,
stepMode, terminated), a refused call answers fmi3Error with an error-level log message (debug logging
off) and changes nothing, fmi3Fatal is never an answer, FMU state handles are checked. `Oracle` models
one instance and says which statuses each call may answer; `run_sequences` draws seeded random calls,
biased toward legal ones so that the sequences reach stepMode, event mode, early returns, restored and
deserialised states, instances resumed from a state without initialisation (shim/state_machine.h,
FMU_STATE_RESTORES) and resets, with illegal calls and bad arguments mixed in, and returns the violations.
Rigid fidelity (the contract does not depend on the fidelity; the FMI 2.0 sequences run fem).

    python tests/in_child.py fmi3_sequences run_sequences '["FemPendulum3.fmu", 40, 1]'
"""

from __future__ import annotations

import math
import random
import shutil
from dataclasses import dataclass, field
from typing import Any

from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

OK, DISCARD, ERROR, FATAL = 0, 2, 3, 4
INITIALISED = {"init", "event", "step", "terminated"}
SETTABLE = {"instantiated", "init", "event", "step"}
LIFE_CYCLE = (
    "enterInitializationMode",
    "exitInitializationMode",
    "enterEventMode",
    "updateDiscreteStates",
    "enterStepMode",
    "terminate",
    "reset",
)
# the legal way on from each state, drawn more often than the others
NEXT = {"instantiated": "enterInitializationMode", "init": "exitInitializationMode", "event": "enterStepMode"}


@dataclass
class Oracle:
    """What the contract says of one instance: its state, time, torque, and the FMU states it handed out."""

    event_mode: bool
    state: str = "instantiated"
    time: float = 0.0
    torque: float = 0.0
    live: list[Any] = field(default_factory=list)  # (handle, time, torque, taken) handed out and not freed
    freed: list[Any] = field(default_factory=list)  # freed handles: fmi3FreeFMUState set them to NULL
    blobs: list[bytes] = field(default_factory=list)

    def restored(self, taken: str) -> str | None:
        """The state after setting an FMU state taken in `taken` ("init": before initialisation, "step" or
        "event": stepping, "terminated"), or None where it is refused (shim/state_machine.h,
        FMU_STATE_RESTORES): an instance not yet initialised takes the mode of one taken stepping."""
        fresh = self.state in {"instantiated", "init"}
        if taken == "terminated":
            return "terminated" if self.state == "terminated" else None
        if taken == "init":
            return self.state if fresh else None
        return "step" if fresh else self.state

    def transition(self, call: str) -> tuple[set[str], str | None]:
        """The states a life-cycle call is allowed in, and the state it leads to."""
        after_exit = "event" if self.event_mode else "step"
        return {
            "enterInitializationMode": ({"instantiated"}, "init"),
            "exitInitializationMode": ({"init"}, after_exit),
            "enterEventMode": ({"step"} if self.event_mode else set(), "event"),
            "updateDiscreteStates": ({"event"}, "event"),
            "enterStepMode": ({"event"}, "step"),
            "terminate": ({"step", "event"}, "terminated"),
            "reset": ({"instantiated", "init", "event", "step", "terminated"}, "instantiated"),
        }[call]


@dataclass
class Tally:
    calls: int = 0
    statuses: dict[int, int] = field(default_factory=dict)
    reached: dict[str, int] = field(default_factory=dict)
    violations: list[str] = field(default_factory=list)


class Sequence:
    """One instance driven by seeded random calls; every answer judged by the oracle."""

    def __init__(self, fmu: str, folder: str, rng: random.Random, tally: Tally) -> None:
        self.md = read_model_description(fmu)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.rng, self.tally = rng, tally
        self.messages: list[tuple[int, str]] = []
        self.oracle = Oracle(event_mode=rng.random() < 0.5)
        self.slave = FMU3Slave(guid=self.md.guid, unzipDirectory=folder, modelIdentifier="FemPendulum")
        self.slave.instantiate(
            eventModeUsed=self.oracle.event_mode,
            earlyReturnAllowed=rng.random() < 0.5,
            logMessage=lambda env, status, category, message: self.messages.append((status, message.decode())),
        )

    def judge(self, name: str, allowed: set[int], action) -> int:
        """Run `action`, check its status is one of `allowed` and an error was logged; the status."""
        logged = len(self.messages)
        try:
            result = action()
            status = OK
        except FMICallException as exc:
            status, result = exc.status, None
        self.tally.calls += 1
        self.tally.statuses[status] = self.tally.statuses.get(status, 0) + 1
        where = f"{name} in {self.oracle.state} at t = {self.oracle.time!r}"
        if status not in allowed:
            said = self.messages[-1][1] if len(self.messages) > logged else "nothing logged"
            self.tally.violations.append(f"{where}: status {status}, the contract allows {sorted(allowed)} ({said})")
        if status == ERROR and not any(s == ERROR for s, _ in self.messages[logged:]):
            self.tally.violations.append(f"{where}: fmi3Error without an error-level log message")
        self.result = result
        return status

    def life_cycle(self, call: str) -> None:
        states, after = self.oracle.transition(call)
        action = getattr(self.slave, call)
        if call == "enterInitializationMode":
            action = lambda: self.slave.enterInitializationMode(startTime=0.0)  # noqa: E731
        ok = self.oracle.state in states
        if self.judge(call, {OK} if ok else {ERROR}, action) == OK and after is not None:
            self.oracle.state = after
            if call == "reset":  # the states taken before stay valid (docs/reference/fmi2.md, Life cycle)
                self.oracle.time, self.oracle.torque = 0.0, 0.0
            if call == "enterInitializationMode":  # the same parameters in every life: every state fits
                fidelity = [self.vr["model.fidelity"]]
                self.judge("setInt64 model.fidelity", {OK}, lambda: self.slave.setInt64(fidelity, [2]))

    def do_step(self) -> None:
        o, rng = self.oracle, self.rng
        h = rng.choice([1e-3, 1e-3, 0.02, 0.3, 0.0, -1e-3, math.nan])
        t = o.time if rng.random() < 0.9 else o.time + 0.1
        valid = o.state == "step" and h > 0 and t == o.time and math.isfinite(o.torque)
        if self.judge("doStep", {OK, DISCARD} if valid else {ERROR}, lambda: self.slave.doStep(t, h)) == OK:
            event, _, early, last = self.result
            if not t < last <= t + h + 1e-12:
                self.tally.violations.append(f"doStep from {t!r} of {h!r}: lastSuccessfulTime {last!r}")
            o.time = last
            for flag, key in ((early, "early return"), (event, "event")):
                self.tally.reached[key] = self.tally.reached.get(key, 0) + bool(flag)

    def variables(self) -> None:
        o, rng = self.oracle, self.rng
        pick = rng.randrange(6)
        if pick == 0:
            value = rng.choice([0.0, 0.3, -0.5, math.nan])
            if (
                self.judge(
                    "setFloat64 torque",
                    {OK} if o.state in SETTABLE else {ERROR},
                    lambda: self.slave.setFloat64([self.vr["torque"]], [value]),
                )
                == OK
            ):
                o.torque = value
        elif pick == 1:  # a fixed parameter, its own value
            ok = o.state in {"instantiated", "init"}
            self.judge(
                "setFloat64 gravity",
                {OK} if ok else {ERROR},
                lambda: self.slave.setFloat64([self.vr["gravity"]], [9.81]),
            )
        elif pick == 2:
            status = self.judge(
                "getFloat64",
                {OK} if o.state in INITIALISED else {ERROR},
                lambda: self.slave.getFloat64([self.vr["theta"], self.vr["time"]]),
            )
            if status == OK and o.state != "init" and self.result[1] != o.time:
                self.tally.violations.append(f"time reads {self.result[1]!r}, the FMU's time is {o.time!r}")
        elif pick == 3:
            self.judge("getInt64 bad reference", {ERROR}, lambda: self.slave.getInt64([9999]))
        elif pick == 4:  # the array output: nValues must count its elements
            n = rng.choice([15, 15, 14, 1])
            ok = o.state in INITIALISED and n == 15
            self.judge(
                f"getFloat64 gap_profile {n}",
                {OK} if ok else {ERROR},
                lambda: self.slave.getFloat64([self.vr["gap_profile"]], nValues=n),
            )
        else:
            self.judge("getFloat32", {ERROR}, lambda: self.slave.getFloat32([self.vr["theta"]]))

    def states(self) -> None:
        o, rng = self.oracle, self.rng
        pick = rng.randrange(5)
        # states are taken where their time is known: in initializationMode (after the fidelity is set), stepMode,
        # eventMode and terminated
        if pick == 0 and o.state != "instantiated":
            if self.judge("getFMUState", {OK}, self.slave.getFMUState) == OK:
                o.live.append((self.result, o.time, o.torque, o.state))
        elif pick == 1 and (o.live or o.freed):
            self.set_state(*rng.choice([(h, True) for h in o.live] + [(h, False) for h in o.freed]))
        elif pick == 2 and o.live:
            entry = o.live.pop(rng.randrange(len(o.live)))
            self.judge("freeFMUState", {OK}, lambda: self.slave.freeFMUState(entry[0]))
            o.freed.append(entry)
        elif pick == 3 and o.live:
            handle, t, torque, taken = rng.choice(o.live)
            if self.judge("serializeFMUState", {OK}, lambda: self.slave.serializeFMUState(handle)) == OK:
                blob = self.result
                o.blobs.append(blob)
                # a state taken before initialisation does not fit an initialised instance (its model)
                fits = taken != "init" or o.state in {"instantiated", "init"}
                allowed = {OK} if fits else {ERROR}
                if self.judge("deserializeFMUState", allowed, lambda: self.slave.deserializeFMUState(blob)) == OK:
                    o.live.append((self.result, t, torque, taken))
        elif pick == 4:
            blob = rng.choice([b"junk", *(b[:-1] for b in o.blobs[-1:])])
            self.judge("deserializeFMUState junk", {ERROR}, lambda: self.slave.deserializeFMUState(blob))

    def set_state(self, entry: tuple, live: bool) -> None:
        """fmi3SetFMUState of a state handed out (freed unless `live`). Every state of this FMU fits: the
        parameters are the same in every sequence (docs/reference/fmi2.md, FMU states); where it may be set and
        the state after are the table's (Oracle.restored)."""
        o = self.oracle
        handle, t, torque, taken = entry
        after = o.restored(taken) if live else None
        if self.judge("setFMUState", {ERROR} if after is None else {OK}, lambda: self.slave.setFMUState(handle)) == OK:
            key = "resumed" if o.state != after else "restored"  # resumed: an instance not initialised, now stepping
            o.time, o.torque, o.state = t, torque, after
            self.tally.reached[key] = self.tally.reached.get(key, 0) + 1

    def run(self, length: int) -> None:
        o = self.oracle
        self.life_cycle("enterInitializationMode")
        for _ in range(length):
            self.tally.reached[o.state] = self.tally.reached.get(o.state, 0) + 1
            r = self.rng.random()
            legal = {**NEXT, "terminated": "reset"}.get(o.state)
            stepping = [e for e in o.live if e[3] in ("step", "event")]
            if o.state in ("instantiated", "init") and stepping and r < 0.15:  # a host resuming a saved run
                self.set_state(self.rng.choice(stepping), True)
            elif legal is not None and r < 0.35:
                self.life_cycle(legal)
            elif r < 0.55:
                self.do_step()
            elif r < 0.7:
                self.variables()
            elif r < 0.85:
                self.states()
            else:
                self.life_cycle(self.rng.choice(LIFE_CYCLE))

    def close(self) -> None:
        self.slave.fmi3FreeInstance(self.slave.component)  # in any state; fmpy's freeInstance unloads too
        self.slave.freeLibrary()


def run_sequences(fmu: str, count: int, seed: int, length: int = 40) -> dict:
    """Run `count` sequences of `length` random calls each (seeded), one instance at a time; the tally."""
    folder = extract(fmu)
    tally = Tally()
    try:
        for k in range(count):
            sequence = Sequence(fmu, folder, random.Random(seed * 100_003 + k), tally)
            sequence.run(length)
            sequence.close()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return {
        "calls": tally.calls,
        "statuses": tally.statuses,
        "reached": tally.reached,
        "violations": tally.violations[:20],
    }
