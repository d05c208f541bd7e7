"""Random FMI 2.0 co-simulation call sequences through a native C host, judged by the FMUs' contract.

The FMUs' linux64 binary (fem_pendulum_fmu/fmi/shim/) promises a contract: which call is allowed in which
state of the FMI 2.0 co-simulation state machine, which arguments are refused, what the FMU state and
status functions do. This module checks that promise from outside, as a C master would meet it:

- tests/fmi2_sequence_host.c is the host: it loads both FMUs' binaries into one process and executes
  one FMI call per line of its stdin (instances in slots 0..1, FMU states in 16 host-side slots,
  serialised states in 8 byte buffers), answering each call with its status and any value read.
- `Generator` writes seeded random sequences, biased toward legal calls so that they reach deep states
  (initialised, after steps, after a discarded step, after a restored or deserialised state), with
  illegal calls and invalid arguments sprinkled in.
- `Oracle` models every instance (its state, parameters, inputs, time, known outputs) and every FMU
  state handle, and judges each answer: the statuses the contract allows for that call in that state
  with those arguments, the values read back, the pointers handed out and the bytes written.
- `Runner` keeps one host process for many sequences (starting Python and NGSolve costs seconds in a
  native host), restarts it after a crash, and `minimise` shrinks a failing sequence to a short
  reproducer.

The contract as judged here (docs/reference/fmi2.md, "The FMI 2.0 contract"; an instance's states: instantiated,
initializationMode, stepComplete, terminated; stepFailed is never entered: a discarded step leaves the
model as before it):

- setupExperiment and enterInitializationMode in instantiated only; exitInitializationMode in
  initializationMode only (fmi2Error for invalid parameters, the instance staying there); terminate in
  stepComplete only; doStep in stepComplete only; reset, freeInstance, setDebugLogging and the six FMU
  state functions in every state; Get* in every state but instantiated; Set* in every state but
  terminated (in stepComplete only inputs; a parameter fmi2Error whatever its value); the status
  functions in stepComplete and terminated; the functions the FMUs do not provide
  (getDirectionalDerivative, cancelStep) always fmi2Error.
- setRealInputDerivatives, where the FMU declares canInterpolateInputs, where fmi2SetReal of an input
  is allowed (instantiated, initializationMode, stepComplete), of continuous Real inputs, orders 1 and
  2, finite values; getRealOutputDerivatives, up to maxOutputDerivativeOrder, in stepComplete and
  terminated, of continuous Real outputs that are not per-step summaries (gap_min, contact_force_max,
  contact_impulse), theta's first derivative the omega output; else fmi2Error. An FMU that declares
  neither refuses them in every state. Derivatives set are the next successful doStep's (it clears
  them), part of an FMU state, and enter the same-step key of a repeated Discard.
- A refused call answers fmi2Error and changes nothing (a refusal by the state table logs a message
  naming the call and the state); fmi2Fatal is never an answer.
- fmi2Instantiate returns NULL for another GUID (the message names both), another fmuType, no callbacks
  or no logger, no instance name.
- doStep: the step size finite and > 0, the communication point the FMU's time within 1e-9 (relative
  above 1), the pendulum's torque finite; fmi2Discard leaves the state as at the start of the step.
- FMU state handles: only those this instance handed out and did not free are accepted, anything else
  refused without being dereferenced; freeing through the handle's address sets it to NULL, a NULL
  address or a NULL handle is fmi2OK, a handle passed where its address is due is freed;
  getFMUstate/deSerializeFMUstate into a variable holding a live state of this instance replace it in
  place, into NULL hand out a new one, into anything else are refused; serialising into a buffer of at
  least the reported size writes exactly that many bytes, a smaller buffer is fmi2Error; deserialising
  refuses junk, empty, truncated or foreign bytes, and, in an initialised instance, a state taken with
  other parameter values; a deserialised state serialises back identically; setFMUstate of a state
  taken with other parameters, or before initialisation, is refused by an initialised instance, and of a
  state taken in terminated by any instance not terminated; an instance without a model (instantiated,
  initializationMode) takes a state taken before initialisation and stays where it is, with the state's
  parameters, inputs and time, and a state taken after initialisation puts it in stepComplete with the
  state's parameters, model and time (docs/reference/fmi2.md, "Setting an FMU state"). The PID FMU declares
  canGetAndSetFMUstate="false": all six state functions answer fmi2Error there.
- getBooleanStatus(fmi2Terminated) is fmi2True in terminated, and after the same step (time, size,
  torque) was discarded twice running (a deterministic model repeats a Discard for ever); the
  sequences' Discards come from solver.max_substeps, which a shorter step avoids (the Discard no
  shorter step avoids, where it is fmi2True at once, is tests/test_discard_ends_run.py's);
  getRealStatus(fmi2LastSuccessfulTime)
  is the FMU's time; getStatus(fmi2DoStepStatus), getStringStatus(fmi2PendingStatus) and
  getIntegerStatus answer fmi2Discard; an unknown status kind or a NULL value pointer fmi2Error.

Run as a command: python tests/fmi2_sequences.py --sequences 1000 --fem-share 0.2 --two-instance-share 0.2
--seed 1 --fmu-dir DIR (DIR holding FemPendulum.fmu and PidController.fmu, as `fem-pendulum build` writes
them). tests/test_fmi2_sequences.py runs a fast lane of it and one regression test per defect class.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import random
import re
import select
import shutil
import subprocess
import sys
import tempfile
import time
import uuid
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

HERE = Path(__file__).resolve().parent
HOST_SOURCE = HERE / "fmi2_sequence_host.c"

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = range(6)
STATUS_NAMES = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")
SUCCESS = frozenset({OK, WARNING})
STEPPED = frozenset({OK, WARNING, DISCARD})
REFUSED = frozenset({ERROR})
ANY = frozenset({OK, WARNING, DISCARD, ERROR})
NO_STATUS = frozenset({DISCARD})  # what the status functions answer for a status the FMU cannot give
UNAVAILABLE = NO_STATUS  # a status kind that is not this function's (docs/reference/fmi2.md: fmi2Discard)

INSTANTIATED, INIT, STEP, TERMINATED = "instantiated", "initializationMode", "stepComplete", "terminated"
MACHINE_STATES = (INSTANTIATED, INIT, STEP, TERMINATED)
RIGID, FEM = 2, 4  # model.fidelity items
FEM_MESH = 0.06
VIOLATION_KINDS = ("crash", "hang", "fatal", "forbidden-OK", "refused-legal", "wrong-answer", "unlogged-error")
N_STATE_SLOTS, N_HANDLE_SLOTS, N_BUFFERS = 16, 12, 8  # slots 12..15 hold pointers made by the host
TIME_TOL = 1e-9
STATUS_KINDS = {"DoStepStatus": 0, "PendingStatus": 1, "LastSuccessfulTime": 2, "Terminated": 3}
BAD_STATUS_KIND = 99
# the outputs whose values the oracle remembers between the events that change them (a step, a restored state)
CHECKED_OUTPUTS = {"pendulum": ("theta", "omega", "energy.total", "gap"), "pid": ("u",)}
NOT_PROVIDED = {
    "dirderiv": "fmi2GetDirectionalDerivative",
    "cancel": "fmi2CancelStep",
}
DERIVATIVE_CALLS = {"setinder": "fmi2SetRealInputDerivatives", "getoutder": "fmi2GetRealOutputDerivatives"}
# per-step summaries: Real outputs without a time derivative (the slave says why)
SUMMARIES = ("gap_min", "contact_force_max", "contact_impulse")
STATUS_FUNCTIONS = {
    "status": "fmi2GetStatus",
    "realstatus": "fmi2GetRealStatus",
    "intstatus": "fmi2GetIntegerStatus",
    "boolstatus": "fmi2GetBooleanStatus",
    "stringstatus": "fmi2GetStringStatus",
}
TYPE_COMMANDS = {"Real": "real", "Integer": "int", "Boolean": "bool", "String": "string"}
FMI_NAMES = {
    "setup": "fmi2SetupExperiment",
    "setstate": "fmi2SetFMUstate",
    "enter": "fmi2EnterInitializationMode",
    "exit": "fmi2ExitInitializationMode",
    "terminate": "fmi2Terminate",
    "dostep": "fmi2DoStep",
    "get": "fmi2Get",
    "set": "fmi2Set",
    **STATUS_FUNCTIONS,
    **NOT_PROVIDED,
    **DERIVATIVE_CALLS,
}


# ----------------------------------------------------------------------------------------------- the FMUs
@dataclass(frozen=True)
class Variable:
    name: str
    vr: int
    type: str  # Real, Integer (Enumerations too: they are read and written as Integer), Boolean, String
    causality: str
    start: Any
    variability: str = "continuous"

    @property
    def derivable(self) -> str | None:
        """ "input" / "output" for a continuous Real input / output (what has time derivatives), else None."""
        if self.type != "Real" or self.variability != "continuous" or self.causality not in ("input", "output"):
            return None
        return self.causality


@dataclass(frozen=True)
class FmuInfo:
    """One FMU as the host loads it: its extracted folder, library index in the host and variables."""

    kind: str  # "pendulum" or "pid"
    folder: Path
    identifier: str
    guid: str
    lib: int
    variables: dict[str, Variable]
    can_states: bool
    categories: tuple[str, ...]
    start_time: float
    input_order: int = 0  # the highest input derivative order it takes (2 if canInterpolateInputs, else 0)
    output_order: int = 0  # maxOutputDerivativeOrder

    def vr(self, name: str) -> int:
        return self.variables[name].vr

    def by_vr(self, vr: int) -> Variable | None:
        return next((v for v in self.variables.values() if v.vr == vr), None)

    def start_values(self) -> dict[str, Any]:
        return {v.name: v.start for v in self.variables.values() if v.causality in ("parameter", "input")}

    def of_type(self, type_: str, causality: str | None = None) -> list[Variable]:
        return [v for v in self.variables.values() if v.type == type_ and causality in (None, v.causality)]


def _start_value(type_: str, text: str | None) -> Any:
    if type_ == "Real":
        return float(text) if text not in (None, "") else 0.0
    if type_ == "Integer":
        return int(text) if text not in (None, "") else 0
    if type_ == "Boolean":
        return text in ("true", "1")
    return text or ""


def load_fmu(path: Path, lib: int, folder: Path) -> FmuInfo:
    """Extract `path` into `folder` and read its modelDescription.xml."""
    from fmpy import extract, read_model_description

    md = read_model_description(str(path))
    extract(str(path), unzipdir=str(folder))
    assert not re.search(r"\s", str(folder)), "the host's commands are split at spaces"
    variables = {}
    for v in md.modelVariables:
        type_ = "Integer" if v.type == "Enumeration" else v.type
        variables[v.name] = Variable(
            v.name, v.valueReference, type_, v.causality, _start_value(type_, v.start), v.variability
        )
    cs = md.coSimulation
    start = md.defaultExperiment.startTime if md.defaultExperiment and md.defaultExperiment.startTime else 0.0
    return FmuInfo(
        kind="pid" if cs.modelIdentifier == "PidController" else "pendulum",
        folder=folder,
        identifier=cs.modelIdentifier,
        guid=md.guid,
        lib=lib,
        variables=variables,
        can_states=bool(cs.canGetAndSetFMUstate),
        categories=tuple(c.name for c in getattr(md, "logCategories", []) or []),
        start_time=float(start),
        input_order=2 if cs.canInterpolateInputs else 0,
        output_order=int(cs.maxOutputDerivativeOrder or 0),
    )


def compile_host(folder: Path) -> Path:
    """tests/fmi2_sequence_host.c compiled with the system's C compiler into `folder`."""
    import fmpy

    compiler = shutil.which("cc") or shutil.which("gcc")
    assert compiler, "a C compiler is needed for the C host"
    binary = Path(folder) / "fmi2_sequence_host"
    subprocess.run(
        [compiler, "-O1", "-g", "-Wall", "-Wextra", "-Werror", f"-I{Path(fmpy.__file__).parent / 'c-code'}"]
        + [str(HOST_SOURCE), "-ldl", "-o", str(binary)],
        check=True,
    )
    return binary


# ----------------------------------------------------------------------------------------------- the host
class HostDied(Exception):
    """The host process ended while a call was running (a signal: a crash)."""

    def __init__(self, returncode: int | None, log: list[str]) -> None:
        super().__init__(f"host exited with {returncode}")
        self.returncode, self.log = returncode, log


class HostHung(Exception):
    """A call did not answer within the timeout (the host was killed)."""

    def __init__(self, log: list[str]) -> None:
        super().__init__("no answer within the timeout")
        self.log = log


def encode(text: str | None) -> str:
    """A string as one token of the host's protocol."""
    if text is None:
        return "@null"
    if text == "":
        return "%00"
    return "".join(f"%{b:02X}" if b <= 0x20 or b == 0x25 or b >= 0x7F else chr(b) for b in text.encode())


def decode(token: str) -> str | None:
    if token == "@null":
        return None
    raw = re.sub(rb"%([0-9A-Fa-f]{2})", lambda m: bytes([int(m.group(1), 16)]), token.encode())
    return raw.replace(b"\x00", b"").decode("utf-8", "replace")


class Host:
    """One running fmi2_sequence_host with the FMUs loaded, restarted when a call finds it gone.

    Its stderr (the FMUs' log messages) goes to a file in `workdir`; `send` returns the answer and the
    log lines the call produced."""

    def __init__(
        self, binary: Path, fmus: Iterable[FmuInfo], workdir: Path, timeout: float = 60.0, env: dict | None = None
    ) -> None:
        self.binary, self.fmus, self.workdir, self.timeout = Path(binary), list(fmus), Path(workdir), timeout
        self.env = env or {}  # none by default: the FMU starts the Python it was built with (tests/test_c_host.py)
        self.proc: subprocess.Popen | None = None
        self.starts = 0
        self._buffer = b""
        self._log_tail = b""
        self._log_writer: Any = None
        self._log_reader: Any = None

    def _start(self) -> None:
        self._close_files()
        self.starts += 1
        path = self.workdir / f"host-{self.starts}.log"
        self._log_writer = open(path, "wb")  # kept open while the process runs
        self._log_reader = open(path, "rb")
        self._buffer = self._log_tail = b""
        self.proc = subprocess.Popen(
            [str(self.binary)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._log_writer,
            cwd=self.workdir,
            env=self.env,
        )
        for fmu in self.fmus:
            answer, log = self._send(f"load {fmu.lib} {fmu.folder} {fmu.identifier}")
            if answer != "ok":
                raise RuntimeError(f"the host cannot load {fmu.identifier}: {answer} {log}")

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def send(self, line: str) -> tuple[str, list[str]]:
        if not self.running:
            self._start()
        return self._send(line)

    def _send(self, line: str) -> tuple[str, list[str]]:
        assert self.proc is not None and self.proc.stdin is not None and self.proc.stdout is not None
        try:
            self.proc.stdin.write(line.encode() + b"\n")
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            raise HostDied(self._reap(), self.new_log()) from None
        deadline = time.monotonic() + self.timeout
        while True:
            while (end := self._buffer.find(b"\n")) >= 0:
                raw, self._buffer = self._buffer[:end], self._buffer[end + 1 :]
                at = raw.rfind(b"@@ans ")
                if at >= 0:
                    return raw[at + 6 :].decode("utf-8", "replace"), self.new_log()
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.kill()
                raise HostHung(self.new_log())
            ready, _, _ = select.select([self.proc.stdout], [], [], remaining)
            if ready:
                chunk = os.read(self.proc.stdout.fileno(), 1 << 16)
                if not chunk:
                    raise HostDied(self._reap(), self.new_log())
                self._buffer += chunk

    def new_log(self) -> list[str]:
        """The complete lines the host wrote on stderr since the last call."""
        if self._log_reader is None:
            return []
        data = self._log_tail + self._log_reader.read()
        lines = data.split(b"\n")
        self._log_tail = lines.pop()
        return [x.decode("utf-8", "replace") for x in lines]

    def _reap(self) -> int | None:
        assert self.proc is not None
        try:
            return self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.kill()
            return self.proc.returncode

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    def close(self) -> int | None:
        """Quit the host (it frees what is left); its exit code."""
        code = None
        if self.running:
            assert self.proc is not None and self.proc.stdin is not None
            try:
                self.proc.stdin.write(b"quit\n")
                self.proc.stdin.close()
            except (BrokenPipeError, OSError):
                pass
            code = self._reap()
        elif self.proc is not None:
            code = self.proc.returncode
        if self.proc is not None and self.proc.stdout is not None:
            self.proc.stdout.close()
        self.proc = None
        self._close_files()
        return code

    def _close_files(self) -> None:
        for f in (self._log_writer, self._log_reader):
            if f is not None:
                f.close()
        self._log_writer = self._log_reader = None


# ------------------------------------------------------------------------------------------------ calls
class Call(NamedTuple):
    """An abstract FMI call: `op`, the instance slot `k` (or a state slot for host-side ops) and its
    arguments. Arguments that depend on the run (the communication point) are symbolic and resolved by
    the oracle when the call is made, so that a shortened sequence still means the same calls."""

    op: str
    k: int
    args: tuple = ()

    def __str__(self) -> str:
        return f"{self.op}({self.k}{''.join(', ' + repr(a) for a in self.args)})"


@dataclass
class Violation:
    kind: str
    detail: str


NUMBERS = re.compile(r"0x[0-9a-f]+|(?<![A-Za-z])[-+]?\d[\d.e+-]*|\bnan\b|\binf\b")


@dataclass
class Step:
    call: Call
    line: str
    answer: str
    log: list[str]
    violation: Violation | None = None
    why: str = ""

    def signature(self) -> str:
        """What makes two violations the same defect: the kind, the call, the reason and the FMU's own
        message (its first log line of status fmi2Error, if any), without numbers."""
        assert self.violation is not None
        said = next((m.group(1) for x in self.log if (m := re.match(r"\[log \S+ 3 \S+\] (.*)", x))), "")
        text = f"{self.violation.kind} {self.call.op}: {self.violation.detail}" + (
            f" | FMU: {said[:90]}" if said else ""
        )
        return NUMBERS.sub("#", text)


# ------------------------------------------------------------------------------------------------ model
@dataclass
class Snapshot:
    """What an FMU state holds, as the oracle knows it."""

    has_model: bool
    values: dict[str, Any]
    time: float | None
    outputs: dict[str, Any]
    dubious: bool
    rates: dict[tuple[str, int], float] = field(default_factory=dict)
    taken_in: str = STEP  # the instance's state when it was taken


@dataclass
class Instance:
    uid: int
    slot: int
    fmu: FmuInfo
    name: str
    state: str = INSTANTIATED
    has_model: bool = False  # a model built (at exitInitializationMode or from an FMU state): parameters fixed
    values: dict[str, Any] = field(default_factory=dict)  # parameters and inputs by name
    time: float | None = 0.0  # None: not known (see Oracle._setstate)
    outputs: dict[str, Any] = field(default_factory=dict)  # the known values of CHECKED_OUTPUTS
    dubious: bool = False  # NaN parameters or inputs: the physics' answers are not predicted
    lenient: bool = False  # an outcome the contract leaves open happened: only crashes and fatals count
    after_discard: bool = False
    discarded: tuple | None = None  # (t, h, torque) of the last doStep, if it was discarded
    stuck: bool = False  # the same step was discarded twice running: fmi2Terminated is true
    rates: dict[tuple[str, int], float] = field(default_factory=dict)  # input derivatives for the next doStep

    def fresh(self) -> None:
        self.state, self.has_model, self.values = INSTANTIATED, False, self.fmu.start_values()
        self.time, self.outputs, self.dubious, self.lenient, self.after_discard = (
            self.fmu.start_time,
            {},
            False,
            False,
            False,
        )
        self.discarded, self.stuck, self.rates = None, False, {}

    def snapshot(self) -> Snapshot:
        return Snapshot(
            self.has_model, dict(self.values), self.time, dict(self.outputs), self.dubious, dict(self.rates), self.state
        )


@dataclass
class Handle:
    """A pointer the oracle has seen in a state slot: handed out by an FMU (owner) or made by the host."""

    ptr: int
    owner: int | None  # the uid of the instance that handed it out; None for a host-made pointer
    snapshot: Snapshot | None
    live: bool | None  # None: the contract does not say (see Oracle._hand_out)
    size: int | None = None
    origin_hash: str | None = None  # a deserialised state: the hash of its bytes (they serialise back identically)


@dataclass
class Buffer:
    """A byte buffer of the host: a serialised state of an instance of `fmu`."""

    fmu: FmuInfo
    snapshot: Snapshot
    size: int
    hash: str


def effective_fidelity(values: dict[str, Any]) -> int:
    index = int(values.get("model.fidelity_index", 0))
    return index if index != 0 else int(values.get("model.fidelity", 0))


def same_parameters(fmu: FmuInfo, a: dict[str, Any], b: dict[str, Any]) -> bool:
    return all(same_value(a[v.name], b[v.name]) for v in fmu.variables.values() if v.causality == "parameter")


def deserialise_rule(inst: Instance, buf: Buffer) -> tuple[frozenset, str]:
    """What fmi2DeSerializeFMUstate of the serialised state `buf` may answer in `inst` (docs/reference/fmi2.md, FMU
    states): an instance without a model takes any state of its FMU; an initialised one only a state
    taken with the same parameter values (so the same fidelity and mesh)."""
    snap = buf.snapshot
    if buf.fmu is not inst.fmu:
        return REFUSED, f"fmi2DeSerializeFMUstate of a state of {buf.fmu.identifier}"
    if not inst.has_model:
        return (
            SUCCESS,
            f"fmi2DeSerializeFMUstate of a state of this FMU into an instance without a model ({inst.state})",
        )
    if not same_parameters(inst.fmu, snap.values, inst.values):
        differ = [
            f"{v.name} = {snap.values[v.name]!r} (the instance: {inst.values[v.name]!r})"
            for v in inst.fmu.variables.values()
            if v.causality == "parameter" and not same_value(snap.values[v.name], inst.values[v.name])
        ]
        return REFUSED, f"fmi2DeSerializeFMUstate into an initialised instance of a state taken with {differ[0]}"
    if not snap.has_model:
        # docs/reference/fmi2.md says both: the payload check (same parameter values: accepted) and, in its table of
        # status codes, that SetFMUstate refuses such a state; the binary refuses it here already
        return frozenset({OK, WARNING, ERROR}), "fmi2DeSerializeFMUstate of a state taken before initialisation"
    return SUCCESS, f"fmi2DeSerializeFMUstate of a state with the instance's parameters ({inst.state})"


def same_value(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return type(a) is type(b) and a == b


def parameter_validity(fmu: FmuInfo, values: dict[str, Any]) -> str:
    """ "valid", "invalid" (exitInitializationMode must refuse) or "dubious" (the contract does not say)."""
    reals = [v for k, v in values.items() if isinstance(v, float) and fmu.variables[k].causality == "parameter"]
    if any(not math.isfinite(v) for v in reals):
        return "dubious"
    if fmu.kind == "pendulum":
        if not -1.0 < values["pendulum.nu"] < 0.5:
            return "invalid"
        if effective_fidelity(values) not in (1, 2, 3, 4):
            return "dubious"
    return "valid"


def same_float(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def fmt_real(x: float) -> str:
    return repr(float(x))


# ------------------------------------------------------------------------------------------------ oracle
class Oracle:
    """The contract's model of the host's instances and FMU states; `execute` makes one call and judges it."""

    def __init__(self, fmus: dict[str, FmuInfo]) -> None:
        self.fmus = fmus
        self.instances: dict[int, Instance] = {}
        self.slots = [0] * N_STATE_SLOTS
        self.handles: dict[int, Handle] = {}
        self.buffers: dict[int, Buffer] = {}
        self.uids = itertools.count(1)
        self.stats: Counter = Counter()

    # ---------------------------------------------------------------- helpers
    def applicable(self, call: Call) -> bool:
        """Whether the call can be made now (a shortened sequence may lack the instance it needs)."""
        if call.op == "slot":
            return True
        if call.op == "instantiate":
            return call.k not in self.instances
        return call.k in self.instances

    def handle(self, ptr: int) -> Handle | None:
        return self.handles.get(ptr) if ptr else None

    def owned_live(self, inst: Instance, ptr: int) -> bool:
        h = self.handle(ptr)
        return h is not None and h.owner == inst.uid and h.live is True

    def live_handles(self, inst: Instance) -> list[int]:
        """State slots holding a live handle of `inst`."""
        return [j for j in range(N_STATE_SLOTS) if self.owned_live(inst, self.slots[j])]

    def _unsure(self, ptr: int) -> bool:
        h = self.handle(ptr)
        return h is not None and h.live is None

    @staticmethod
    def _judge(status: int, allowed: frozenset, why: str) -> Violation | None:
        if status == FATAL:
            return Violation("fatal", f"answered fmi2Fatal ({why})")
        if status in allowed:
            return None
        expected = "/".join(STATUS_NAMES[s] for s in sorted(allowed))
        got = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
        if allowed == REFUSED:
            kind = "forbidden-OK"
        elif status == ERROR:
            kind = "refused-legal"
        else:
            kind = "wrong-answer"
        return Violation(kind, f"answered {got}, the contract allows {expected}: {why}")

    @staticmethod
    def _logged(log: list[str], call_name: str, state: str | None) -> bool:
        """A log message with status fmi2Error naming the call (and the state)."""
        norm = re.compile(r"[\s_]+")
        for line in log:
            m = re.match(r"\[log \S+ (\d+) \S+\] (.*)", line)
            if not m or int(m.group(1)) != ERROR:
                continue
            text = norm.sub("", m.group(2)).lower()
            if call_name.lower() in text and (state is None or norm.sub("", state).lower() in text):
                return True
        return False

    # ---------------------------------------------------------------- dispatch
    def execute(self, call: Call, send: Callable[[str], tuple[str, list[str]]]) -> Step:
        """Make `call` through `send` (the host), judge the answer and update the model."""
        handler = getattr(self, "_" + call.op)
        inst = self.instances.get(call.k)
        if inst is not None:
            self.stats[f"calls in {inst.state}"] += 1
            if inst.after_discard:
                self.stats["calls after a discard"] += 1
        step = handler(call, send)
        fatal_log = next((x for x in step.log if re.match(rf"\[log \S+ {FATAL} ", x)), None)
        if step.violation is None and fatal_log is not None:
            step.violation = Violation("fatal", f"a log message with status fmi2Fatal: {fatal_log[:200]}")
        if inst is not None and inst.lenient and step.violation and step.violation.kind not in ("crash", "fatal"):
            step.violation = None
        return step

    def _simple(
        self,
        call: Call,
        send: Callable,
        line: str,
        allowed: frozenset,
        why: str,
        table: str | None = None,
    ) -> tuple[Step, int]:
        """Send `line`, judge its status; `table`: the refusal is the state table's (a log must name call and
        state; "" when only the call must be named)."""
        answer, log = send(line)
        status = int(answer.split()[0])
        step = Step(call, line, answer, log, self._judge(status, allowed, why), why)
        if step.violation is None and status == ERROR and table is not None:
            name = FMI_NAMES.get(call.op, call.op)
            if not self._logged(log, name, table or None):
                step.violation = Violation("unlogged-error", f"no fmi2Error log message naming {name} {table}: {why}")
        return step, status

    def _state_rule(self, inst: Instance, allowed_in: tuple[str, ...], name: str) -> tuple[bool, str]:
        if inst.state in allowed_in:
            return True, ""
        return False, f"{name} is not allowed in {inst.state}"

    # ---------------------------------------------------------------- life cycle
    def _instantiate(self, call: Call, send: Callable) -> Step:
        fmu_kind, guid_mode, fmu_type, logging, callbacks, name_mode = call.args
        fmu = self.fmus[fmu_kind]
        other = next((f for f in self.fmus.values() if f is not fmu), None)
        guid = {
            "right": fmu.guid,
            "wrong": "{" + str(uuid.UUID(int=0x5EED << 64 | call.k)) + "}",
            "other": other.guid if other else "{00000000-0000-0000-0000-000000000000}",
            "null": None,
        }[guid_mode]
        name = None if name_mode == "null" else f"{fmu.kind}{call.k}"
        line = f"instantiate {call.k} {fmu.lib} {encode(name)} {encode(guid)} {fmu_type} 0 {logging} {callbacks}"
        problems = []
        if guid_mode != "right":
            problems.append(f"GUID {guid} is not {fmu.guid}")
        if fmu_type != 1:
            problems.append(f"fmuType {fmu_type} is not fmi2CoSimulation")
        if callbacks != "full":
            problems.append("no callbacks" if callbacks == "null" else "no logger")
        if name is None:
            problems.append("instanceName NULL")
        why = "fmi2Instantiate with " + ("; ".join(problems) if problems else "valid arguments")
        answer, log = send(line)
        step = Step(call, line, answer, log, why=why)
        if answer == "ok":
            inst = Instance(next(self.uids), call.k, fmu, name or "")
            inst.fresh()
            self.instances[call.k] = inst
            self.stats["instantiate"] += 1
            if problems:
                step.violation = Violation("forbidden-OK", f"returned an instance: {why}")
        elif answer == "null":
            self.stats["instantiate refused"] += 1
            if not problems:
                step.violation = Violation("refused-legal", f"returned NULL: {why}")
            elif guid_mode in ("wrong", "other") and callbacks == "full" and fmu_type == 1 and name is not None:
                text = " ".join(log)
                if fmu.guid not in text or str(guid) not in text:
                    step.violation = Violation("unlogged-error", f"the log does not name both GUIDs: {why}")
        else:
            step.violation = Violation("wrong-answer", f"unexpected answer {answer!r} ({why})")
        return step

    def _free(self, call: Call, send: Callable) -> Step:
        inst = self.instances.pop(call.k)
        line = f"free {call.k}"
        answer, log = send(line)
        for h in self.handles.values():
            if h.owner == inst.uid:
                h.live = False
        self.stats["free"] += 1
        v = None if answer == "done" else Violation("wrong-answer", f"unexpected answer {answer!r}")
        return Step(call, line, answer, log, v, "fmi2FreeInstance")

    def _debug(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        on, categories = call.args
        line = f"debug {call.k} {on} " + " ".join(categories)
        known = all(c in inst.fmu.categories for c in categories)
        allowed = SUCCESS if known else frozenset({OK, WARNING, ERROR})
        step, _ = self._simple(call, send, line.rstrip(), allowed, f"fmi2SetDebugLogging({categories}) in {inst.state}")
        return step

    def _setup(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        (start,) = call.args
        line = f"setup {call.k} 1 0.0001 {fmt_real(start)} 1 {fmt_real(start + 2.0)}"
        ok, why = self._state_rule(inst, (INSTANTIATED,), "fmi2SetupExperiment")
        step, status = self._simple(
            call, send, line, SUCCESS if ok else REFUSED, why or "setup in instantiated", None if ok else inst.state
        )
        if ok and status in SUCCESS and not inst.has_model:
            inst.time = float(start)
        return step

    def _enter(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        ok, why = self._state_rule(inst, (INSTANTIATED,), "fmi2EnterInitializationMode")
        step, status = self._simple(
            call, send, f"enter {call.k}", SUCCESS if ok else REFUSED, why or "enter", None if ok else inst.state
        )
        if ok and status in SUCCESS:
            inst.state = INIT
        return step

    def _exit(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        ok, why = self._state_rule(inst, (INIT,), "fmi2ExitInitializationMode")
        validity = "valid" if inst.has_model else parameter_validity(inst.fmu, inst.values)
        if not ok:
            allowed = REFUSED
        elif validity == "invalid":
            allowed, why = REFUSED, "exitInitializationMode with invalid parameters (pendulum.nu)"
        elif validity == "dubious":
            allowed, why = frozenset({OK, WARNING, ERROR}), "exitInitializationMode with NaN parameters"
        else:
            allowed, why = SUCCESS, "exitInitializationMode with valid parameters"
        step, status = self._simple(call, send, f"exit {call.k}", allowed, why, None if ok else inst.state)
        if ok and status in SUCCESS:
            inst.state = STEP
            if not inst.has_model:
                inst.has_model, inst.outputs = True, {}
                inst.dubious = inst.dubious or validity == "dubious"
            self.stats["initialised"] += 1
        elif ok and status == ERROR:
            self.stats["exit refused (invalid parameters)"] += 1
        return step

    def _terminate(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        ok, why = self._state_rule(inst, (STEP,), "fmi2Terminate")
        step, status = self._simple(
            call,
            send,
            f"terminate {call.k}",
            SUCCESS if ok else REFUSED,
            why or "terminate",
            None if ok else inst.state,
        )
        if ok and status in SUCCESS:
            inst.state = TERMINATED
            self.stats["terminate"] += 1
        return step

    def _reset(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        step, status = self._simple(call, send, f"reset {call.k}", SUCCESS, f"fmi2Reset in {inst.state}")
        if status in SUCCESS:
            inst.fresh()  # FMU states handed out before stay valid until freed (FMI 2.0)
            self.stats["reset"] += 1
        return step

    def _not_provided(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        why = f"{NOT_PROVIDED[call.op]} is not provided (in {inst.state})"
        step, _ = self._simple(call, send, f"{call.op} {call.k}", REFUSED, why, "")
        return step

    _dirderiv = _cancel = _not_provided

    # ---------------------------------------------------------------- input and output derivatives
    def _derivative_rule(self, inst: Instance, call: Call) -> tuple[frozenset, str, str | None]:
        """(allowed statuses, why, the log's table argument for _simple) of a derivative call."""
        setting = call.op == "setinder"
        name, vrs, orders = DERIVATIVE_CALLS[call.op], call.args[0], call.args[1]
        limit = inst.fmu.input_order if setting else inst.fmu.output_order
        states = (INSTANTIATED, INIT, STEP) if setting else (STEP, TERMINATED)
        if limit == 0:
            return REFUSED, f"{name} is not provided by {inst.fmu.identifier}", ""
        if inst.state not in states:
            return REFUSED, f"{name} is not allowed in {inst.state}", inst.state
        role = "input" if setting else "output"
        for k, (vr, order) in enumerate(zip(vrs, orders, strict=True)):
            var = inst.fmu.by_vr(vr)
            if var is None or var.derivable != role:
                return REFUSED, f"{name} of value reference {vr}, not a continuous Real {role}", ""
            if not 1 <= order <= limit:
                return REFUSED, f"{name} of order {order} (allowed 1 to {limit})", ""
            if setting and not math.isfinite(call.args[2][k]):
                return REFUSED, f"{name} with the value {call.args[2][k]!r}", ""
            if not setting and var.name in SUMMARIES:
                return REFUSED, f"{name} of {var.name}, a per-step summary", ""
        if not setting and inst.fmu.kind == "pendulum" and not math.isfinite(inst.values["torque"]):
            return REFUSED, f"{name} with the torque {inst.values['torque']!r}", None
        if setting or inst.dubious:
            return (SUCCESS if setting else ANY), f"{name} of {len(vrs)} derivatives in {inst.state}", None
        probes = inst.fmu.kind == "pendulum" and effective_fidelity(inst.values) not in (RIGID, 3)
        # the fem model probes three short steps of its scheme, which solver.max_substeps may refuse
        return (SUCCESS | REFUSED if probes else SUCCESS), f"{name} in {inst.state}", None

    def _setinder(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        vrs, orders, values = call.args
        line = f"setinder {call.k} {len(vrs)} " + " ".join([*map(str, vrs), *map(str, orders), *map(fmt_real, values)])
        allowed, why, table = self._derivative_rule(inst, call)
        step, status = self._simple(call, send, line.rstrip(), allowed, why, table)
        if allowed == SUCCESS and status in SUCCESS:
            for vr, order, value in zip(vrs, orders, values, strict=True):
                inst.rates[(inst.fmu.by_vr(vr).name, order)] = float(value)  # type: ignore[union-attr]
            self.stats["input derivatives set"] += 1
        return step

    def _getoutder(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        vrs, orders = call.args
        line = f"getoutder {call.k} {len(vrs)} " + " ".join([*map(str, vrs), *map(str, orders)])
        allowed, why, table = self._derivative_rule(inst, call)
        step, status = self._simple(call, send, line.rstrip(), allowed, why, table)
        if step.violation is None and status in SUCCESS and allowed != REFUSED:
            values = [float(x) for x in step.answer.split()[1:]]
            if len(values) != len(vrs):
                step.violation = Violation("wrong-answer", f"{len(values)} values for {len(vrs)} derivatives")
                return step
            omega = inst.outputs.get("omega")
            for vr, order, value in zip(vrs, orders, values, strict=True):
                var = inst.fmu.by_vr(vr)
                if var is not None and var.name == "theta" and order == 1 and omega is not None and not inst.dubious:
                    if not same_float(value, omega):
                        step.violation = Violation("wrong-answer", f"theta' = {value!r}, the omega output is {omega!r}")
                        return step
            self.stats["output derivatives read"] += 1
        return step

    # ---------------------------------------------------------------- values
    def _get(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        type_, vrs = call.args
        name = f"fmi2Get{type_}"
        line = f"get{TYPE_COMMANDS[type_]} {call.k} {len(vrs)} " + " ".join(map(str, vrs))
        variables = [inst.fmu.by_vr(vr) for vr in vrs]
        bad = [vr for vr, v in zip(vrs, variables, strict=True) if v is None or v.type != type_]
        ok, why = self._state_rule(inst, (INIT, STEP, TERMINATED), name)
        # in initializationMode the pendulum's outputs are those of the model its parameters describe
        previewed = inst.fmu.kind == "pendulum" and inst.state == INIT and not inst.has_model
        validity = parameter_validity(inst.fmu, inst.values) if previewed else "valid"
        outputs = any(v is not None and v.causality == "output" for v in variables)
        if not ok:
            allowed = REFUSED
        elif bad:
            allowed, why = REFUSED, f"{name} of value reference {bad[0]}, not a {type_} variable"
        elif outputs and validity == "invalid":
            allowed, why = REFUSED, f"{name} of outputs in initializationMode with invalid parameters"
        elif outputs and validity == "dubious":
            allowed, why = frozenset({OK, WARNING, ERROR}), f"{name} of outputs in initializationMode, NaN parameters"
        else:
            allowed, why = SUCCESS, f"{name} in {inst.state}"
        step, status = self._simple(call, send, line.rstrip(), allowed, why, None if ok else inst.state)
        if step.violation is None and status in SUCCESS and allowed == SUCCESS:
            tokens = step.answer.split()[1:]
            if len(tokens) != len(vrs):
                step.violation = Violation("wrong-answer", f"{len(tokens)} values for {len(vrs)} references")
                return step
            for var, token in zip(variables, tokens, strict=True):
                assert var is not None
                value = self._parse(type_, token)
                expected = None
                if var.causality in ("parameter", "input"):
                    expected = inst.values[var.name]
                elif var.name in inst.outputs and not inst.dubious:
                    expected = inst.outputs[var.name]
                elif var.name in CHECKED_OUTPUTS[inst.fmu.kind] and not inst.dubious and validity == "valid":
                    inst.outputs[var.name] = value
                if expected is not None and not self._equal(type_, value, expected):
                    step.violation = Violation(
                        "wrong-answer",
                        f"{name} {var.name} = {value!r}, expected {expected!r} (nothing changed it since it was "
                        "set, read or restored)",
                    )
                    break
        return step

    @staticmethod
    def _parse(type_: str, token: str) -> Any:
        if type_ == "Real":
            return float(token)
        if type_ == "Integer":
            return int(token)
        if type_ == "Boolean":
            return bool(int(token))
        return decode(token)

    @staticmethod
    def _equal(type_: str, value: Any, expected: Any) -> bool:
        if type_ == "Real":
            return same_float(float(value), float(expected))
        if type_ == "Boolean":
            return bool(value) == bool(expected)
        return value == expected

    def _set(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        type_, vrs, values = call.args
        name = f"fmi2Set{type_}"
        tokens = [fmt_real(v) if type_ == "Real" else encode(v) if type_ == "String" else str(int(v)) for v in values]
        line = f"set{TYPE_COMMANDS[type_]} {call.k} {len(vrs)} " + " ".join(map(str, vrs)) + " " + " ".join(tokens)
        variables = [inst.fmu.by_vr(vr) for vr in vrs]
        ok, why = self._state_rule(inst, (INSTANTIATED, INIT, STEP), name)
        allowed = REFUSED
        for vr, var, value in zip(vrs, variables, values, strict=True) if ok else ():
            if var is None or var.type != type_:
                why = f"{name} of value reference {vr}, not a {type_} variable"
            elif var.causality not in ("parameter", "input"):
                why = f"{name} of {var.name}, an {var.causality}"
            elif type_ == "String" and value is None:
                why = f"{name} of {var.name} to NULL"
            elif inst.state == STEP and var.causality == "parameter":
                why = f"{name} of parameter {var.name} in stepComplete"
            elif inst.has_model and var.causality == "parameter" and not same_value(value, inst.values[var.name]):
                why = f"{name} of parameter {var.name} to another value after its model was built (from an FMU state)"
            else:
                continue
            break
        else:
            if ok:
                allowed, why = SUCCESS, f"{name} in {inst.state}"
        step, status = self._simple(call, send, line.rstrip(), allowed, why, None if ok else inst.state)
        if allowed == SUCCESS and status in SUCCESS:
            for var, value in zip(variables, values, strict=True):
                assert var is not None
                inst.values[var.name] = (
                    float(value) if type_ == "Real" else bool(value) if type_ == "Boolean" else value
                )
                if var.causality == "parameter" and not inst.has_model:
                    inst.outputs = {}  # the outputs read in initializationMode are those of the parameters
            self._update_dubious(inst)
        return step

    def _update_dubious(self, inst: Instance) -> None:
        """NaN inputs make the physics unpredictable (the pendulum's torque is checked at doStep instead)."""
        if inst.fmu.kind == "pid":
            nan_input = any(
                not math.isfinite(inst.values[v.name]) for v in inst.fmu.variables.values() if v.causality == "input"
            )
            if nan_input:
                inst.dubious = True

    # ---------------------------------------------------------------- stepping
    def _dostep(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        t_mode, h, noset = call.args
        base = inst.time if inst.time is not None else 0.0
        t = {
            "right": base,
            "tiny": base + 5e-12 * max(1.0, abs(base)),
            "wrong": base + 0.01,
            "back": base - 0.001,
            "nan": math.nan,
        }[t_mode]
        line = f"dostep {call.k} {fmt_real(t)} {fmt_real(h)} {noset}"
        ok, why = self._state_rule(inst, (STEP,), "fmi2DoStep")
        torque_ok = inst.fmu.kind != "pendulum" or math.isfinite(inst.values["torque"])
        if not ok:
            allowed = REFUSED
        elif not (math.isfinite(h) and h > 0):
            allowed, why = REFUSED, f"doStep with step size {h!r}"
        elif not math.isfinite(t):
            allowed, why = REFUSED, "doStep at a NaN communication point"
        elif inst.time is None:
            allowed, why = ANY, "doStep while the FMU's time is not known to the oracle"
        elif abs(t - inst.time) > TIME_TOL * max(1.0, abs(inst.time)):
            allowed, why = REFUSED, f"doStep at {t!r}, the FMU's time is {inst.time!r}"
        elif not torque_ok:
            allowed, why = REFUSED, f"doStep with torque {inst.values['torque']!r}"
        elif inst.dubious:
            allowed, why = ANY, "doStep of a model with NaN parameters or inputs"
        elif inst.fmu.kind == "pid":
            allowed, why = SUCCESS, f"doStep of {h!r} s"
        else:
            allowed, why = STEPPED, f"doStep of {h!r} s"
        step, status = self._simple(call, send, line, allowed, why, None if ok else inst.state)
        if allowed != REFUSED and status in SUCCESS:
            inst.time, inst.outputs = t + h, {}
            self.stats["step"] += 1
            if inst.after_discard:
                self.stats["retry after a discard"] += 1
            inst.after_discard, inst.discarded, inst.stuck, inst.rates = False, None, False, {}
        elif allowed != REFUSED and status == DISCARD:
            rates = tuple(sorted((name, value) for name, value in inst.rates.items() if value != 0.0))
            key = (t, h, inst.values.get("torque"), rates)
            inst.stuck, inst.discarded = inst.discarded == key, key
            inst.after_discard = True
            self.stats["discard"] += 1
            if inst.stuck:
                self.stats["the same step discarded again"] += 1
        return step

    # ---------------------------------------------------------------- status functions
    def _status_call(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        kind, null_value = call.args
        name = STATUS_FUNCTIONS[call.op]
        line = f"{call.op} {call.k} {kind} {null_value}"
        ok, why = self._state_rule(inst, (STEP, TERMINATED), name)
        value_check = None
        if not ok:
            allowed = REFUSED
        elif null_value:
            allowed, why = REFUSED, f"{name} with a NULL value pointer"
        elif kind not in STATUS_KINDS.values():
            allowed, why = REFUSED, f"{name} of unknown status kind {kind}"
        else:
            why = f"{name}({kind}) in {inst.state}"
            if call.op == "intstatus":
                allowed = NO_STATUS
            elif call.op == "status":
                allowed = NO_STATUS if kind == STATUS_KINDS["DoStepStatus"] else UNAVAILABLE
            elif call.op == "stringstatus":
                allowed = NO_STATUS if kind == STATUS_KINDS["PendingStatus"] else UNAVAILABLE
            elif call.op == "realstatus" and kind == STATUS_KINDS["LastSuccessfulTime"]:
                allowed, value_check = SUCCESS, inst.time
            elif call.op == "boolstatus" and kind == STATUS_KINDS["Terminated"]:
                allowed, value_check = SUCCESS, inst.state == TERMINATED or inst.stuck
                why += " (" + ("after a discarded step" if inst.after_discard else "no discarded step") + ")"
                why += " (the same step discarded twice running)" if inst.stuck else ""
            else:
                allowed = UNAVAILABLE
        step, status = self._simple(call, send, line, allowed, why, None if ok else inst.state)
        if step.violation is None and status in SUCCESS and value_check is not None:
            value = step.answer.split()[1]
            if call.op == "realstatus":
                got = float(value)
                if not abs(got - value_check) <= TIME_TOL * max(1.0, abs(value_check)):
                    step.violation = Violation(
                        "wrong-answer", f"fmi2LastSuccessfulTime = {got!r}, the FMU's time is {value_check!r}"
                    )
            elif bool(int(value)) != value_check:
                step.violation = Violation(
                    "wrong-answer", f"fmi2Terminated = {bool(int(value))} in {inst.state}: {why}"
                )
            self.stats[f"{call.op} read"] += 1
        return step

    _status = _realstatus = _intstatus = _boolstatus = _stringstatus = _status_call

    # ---------------------------------------------------------------- FMU states
    def _no_states(self, inst: Instance) -> str | None:
        if not inst.fmu.can_states:
            return f'{inst.fmu.identifier} declares canGetAndSetFMUstate="false"'
        return None

    def _describe_ptr(self, inst: Instance, ptr: int) -> str:
        h = self.handle(ptr)
        if not ptr:
            return "NULL"
        if h is None:
            return f"{ptr:#x} (never seen)"
        if h.owner is None:
            return f"{ptr:#x} (a pointer the host made)"
        if h.owner != inst.uid:
            return f"{ptr:#x} (a state of another instance" + (", freed)" if not h.live else ")")
        return f"{ptr:#x} (" + {True: "live", False: "freed", None: "of unknown fate"}[h.live] + ")"

    def _hand_out(self, inst: Instance, q: int, old: int, snapshot: Snapshot, what: str) -> Violation | None:
        """Record that `inst` handed out `q` (in place of `old`); a violation if it cannot be a new handle."""
        if not q:
            return Violation("wrong-answer", f"{what} answered OK and left a NULL state")
        h = self.handle(q)
        if h is not None and h.live and not (h.owner == inst.uid and q == old):
            return Violation("wrong-answer", f"{what} handed out {self._describe_ptr(inst, q)}, a live state already")
        if h is not None and h.owner is None:
            return Violation("wrong-answer", f"{what} handed out {q:#x}, a pointer the host made")
        if old and old != q and self.owned_live(inst, old):
            self.handles[old].live = None  # replaced by another pointer: the contract does not say what became of it
        self.handles[q] = Handle(q, inst.uid, snapshot, True)
        return None

    def _unchanged(self, step: Step, j: int, status: int) -> None:
        """A refused state call leaves the state slot as it was."""
        got = int(step.answer.split()[1], 16)
        if step.violation is None and status == ERROR and got != self.slots[j]:
            step.violation = Violation(
                "wrong-answer", f"refused, but the state slot changed from {self.slots[j]:#x} to {got:#x}"
            )

    def _getstate(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        (j,) = call.args
        old = self.slots[j]
        line = f"getstate {call.k} {j}"
        no = self._no_states(inst)
        if no:
            allowed, why = REFUSED, f"fmi2GetFMUstate: {no}"
        elif self._unsure(old):
            allowed, why = ANY, f"fmi2GetFMUstate into {self._describe_ptr(inst, old)}"
        elif old and not self.owned_live(inst, old):  # FMI 2.0: *s is NULL or a state handed out before
            allowed, why = REFUSED, f"fmi2GetFMUstate into a variable holding {self._describe_ptr(inst, old)}"
        else:  # NULL: a new state; a live state of this instance: replaced in place
            allowed, why = SUCCESS, f"fmi2GetFMUstate into {self._describe_ptr(inst, old)} in {inst.state}"
        step, status = self._simple(call, send, line, allowed, why)
        q = int(step.answer.split()[1], 16)
        self._unchanged(step, j, status)
        if step.violation is None and status in SUCCESS:
            if old and self.owned_live(inst, old) and q != old:
                step.violation = Violation("wrong-answer", f"{why}: the live state was not replaced in place ({q:#x})")
            else:
                step.violation = self._hand_out(inst, q, old, inst.snapshot(), "fmi2GetFMUstate")
            self.slots[j] = q
            self.stats["getstate"] += 1
        return step

    def _setstate(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        (j,) = call.args
        ptr = self.slots[j]
        line = f"setstate {call.k} {j}"
        no = self._no_states(inst)
        h = self.handle(ptr)
        snap = h.snapshot if h is not None else None
        kind = "plain"  # or "build": a model built from the state in an instance that had none
        table = None  # the state machine's refusal (FMU_STATE_RESTORES): its log names the instance's state
        if no:
            allowed, why = REFUSED, f"fmi2SetFMUstate: {no}"
        elif self._unsure(ptr):
            allowed, why = ANY, f"fmi2SetFMUstate of {self._describe_ptr(inst, ptr)}"
        elif not self.owned_live(inst, ptr) or snap is None:
            allowed, why = REFUSED, f"fmi2SetFMUstate of {self._describe_ptr(inst, ptr)}"
        elif snap.taken_in == TERMINATED and inst.state != TERMINATED:
            allowed, why, table = (
                REFUSED,
                f"fmi2SetFMUstate of a state taken in terminated, in {inst.state}",
                inst.state,
            )
            self.stats["set of a state taken in terminated refused"] += 1
        elif inst.has_model and snap.has_model and not self._same_parameters(inst, snap):
            allowed, why = (
                REFUSED,
                "fmi2SetFMUstate of a state taken with other parameters into an initialised instance",
            )
        elif inst.has_model and not snap.has_model:
            allowed, why = (
                REFUSED,
                "fmi2SetFMUstate of a state taken before initialisation into an initialised instance",
            )
        else:
            allowed, why = SUCCESS, f"fmi2SetFMUstate of a live state in {inst.state}"
            kind = "build" if snap.has_model and not inst.has_model else "plain"
        step, status = self._simple(call, send, line, allowed, why, table)
        if allowed != REFUSED and status in SUCCESS and snap is not None:
            if allowed == ANY:
                inst.lenient = True
            elif snap.has_model:
                inst.has_model, inst.values, inst.time = True, dict(snap.values), snap.time
                inst.rates = dict(snap.rates)
                inst.outputs, inst.dubious = dict(snap.outputs), snap.dubious
                if inst.state in (INSTANTIATED, INIT):  # not initialised: it steps on from the state
                    inst.state = STEP
                self.stats["restore into an instance without a model" if kind == "build" else "restore"] += 1
            else:  # a state taken before initialisation: its parameters, inputs and time
                inst.values, inst.outputs, inst.time = dict(snap.values), {}, snap.time
                inst.rates = dict(snap.rates)
                self.stats["restore of a state without a model"] += 1
            inst.after_discard, inst.discarded, inst.stuck = False, None, False
        return step

    def _same_parameters(self, inst: Instance, snap: Snapshot) -> bool:
        return same_parameters(inst.fmu, snap.values, inst.values)

    def _freestate(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        j, mode = call.args
        ptr = self.slots[j]
        line = f"freestate {call.k} {j} {mode}"
        no = self._no_states(inst)
        frees = False
        if no:
            allowed, why = REFUSED, f"fmi2FreeFMUstate: {no}"
        elif mode == "null" or not ptr:
            allowed, why = SUCCESS, "fmi2FreeFMUstate of nothing (NULL)"
        elif self._unsure(ptr):
            allowed, why = ANY, f"fmi2FreeFMUstate of {self._describe_ptr(inst, ptr)}"
        elif self.owned_live(inst, ptr):
            allowed, frees = SUCCESS, True
            why = "fmi2FreeFMUstate of a live state" + (" passed where its address is due" if mode == "value" else "")
        else:
            allowed = REFUSED
            why = f"fmi2FreeFMUstate of {self._describe_ptr(inst, ptr)}" + (
                " as the address" if mode == "value" else ""
            )
        step, status = self._simple(call, send, line, allowed, why)
        after = int(step.answer.split()[1], 16)
        if step.violation is None:
            if status == ERROR and after != ptr:
                step.violation = Violation("wrong-answer", f"refused, but the state slot changed to {after:#x}")
            elif status in SUCCESS and frees:
                expected = 0 if mode == "addr" else ptr
                if after != expected:
                    step.violation = Violation("wrong-answer", f"{why}: the slot holds {after:#x}, not {expected:#x}")
                self.handles[ptr].live = False
                self.stats["freestate" if mode == "addr" else "freestate by value"] += 1
            elif status in SUCCESS and allowed == ANY and ptr in self.handles:
                self.handles[ptr].live = False
        self.slots[j] = after
        return step

    def _size(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        j, null_out = call.args
        ptr = self.slots[j]
        line = f"size {call.k} {j} {null_out}"
        allowed, why = self._size_rule(inst, ptr)
        if null_out and allowed != REFUSED:
            allowed, why = REFUSED, "fmi2SerializedFMUstateSize with a NULL size pointer"
        step, status = self._simple(call, send, line, allowed, why)
        if step.violation is None and status in SUCCESS and allowed == SUCCESS:
            n = int(step.answer.split()[1])
            if n <= 0:
                step.violation = Violation("wrong-answer", f"size {n} of a live state")
            self.handles[ptr].size = n
        return step

    def _size_rule(self, inst: Instance, ptr: int) -> tuple[frozenset, str]:
        no = self._no_states(inst)
        if no:
            return REFUSED, f"fmi2SerializedFMUstateSize: {no}"
        if self._unsure(ptr):
            return ANY, f"fmi2SerializedFMUstateSize of {self._describe_ptr(inst, ptr)}"
        if not self.owned_live(inst, ptr):
            return REFUSED, f"fmi2SerializedFMUstateSize of {self._describe_ptr(inst, ptr)}"
        return SUCCESS, f"fmi2SerializedFMUstateSize of a live state in {inst.state}"

    def _serialize(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        j, mode, delta, b = call.args
        ptr = self.slots[j]
        line = f"serialize {call.k} {j} {mode} {delta} {b}"
        size_allowed, size_why = self._size_rule(inst, ptr)
        answer, log = send(line)
        size_status, n, status, untouched = (int(x) for x in answer.split()[:4])
        step = Step(call, line, answer, log, self._judge(size_status, size_allowed, size_why), size_why)
        if step.violation is not None:
            return step
        if size_allowed == REFUSED or size_status == ERROR:
            allowed, why = REFUSED, f"fmi2SerializeFMUstate of {self._describe_ptr(inst, ptr)}"
        elif mode == "nullbuf":
            allowed, why = REFUSED, "fmi2SerializeFMUstate into a NULL buffer"
        elif mode == "smaller":
            allowed, why = REFUSED, f"fmi2SerializeFMUstate into {max(n - delta, 0)} bytes, the state needs {n}"
        elif size_allowed == ANY:
            allowed, why = ANY, f"fmi2SerializeFMUstate of {self._describe_ptr(inst, ptr)}"
        else:
            allowed = SUCCESS
            more = "exactly the" if mode == "exact" else f"{delta} bytes more than the"
            why = f"fmi2SerializeFMUstate into {more} size"
        step.why = why
        step.violation = self._judge(status, allowed, why)
        if step.violation is None and not untouched and (status in SUCCESS or mode in ("smaller", "nullbuf")):
            what = "bytes past the state's size" if status in SUCCESS else "the buffer although the call was refused"
            step.violation = Violation("wrong-answer", f"{why}: it wrote into {what}")
        h = self.handle(ptr)
        digest = answer.split()[4]
        if step.violation is None and status in SUCCESS and allowed == SUCCESS and h is not None:
            if h.origin_hash is not None and digest != h.origin_hash:
                step.violation = Violation(
                    "wrong-answer", f"{why}: a deserialised state did not serialise back identically"
                )
                return step
            assert h.snapshot is not None
            self.buffers[b] = Buffer(inst.fmu, h.snapshot, n, digest)
            h.size = n
            self.stats["serialise" if mode == "exact" else "serialise into a larger buffer"] += 1
        return step

    def _deser(self, call: Call, send: Callable) -> Step:
        inst = self.instances[call.k]
        j, b, mode, arg = call.args
        old = self.slots[j]
        line = f"deser {call.k} {j} {b} {mode} {arg}"
        buf = self.buffers.get(b)
        no = self._no_states(inst)
        if no:
            allowed, why = REFUSED, f"fmi2DeSerializeFMUstate: {no}"
        elif mode == "nullout":
            allowed, why = REFUSED, "fmi2DeSerializeFMUstate with a NULL state pointer"
        elif self._unsure(old):
            allowed, why = ANY, f"fmi2DeSerializeFMUstate into {self._describe_ptr(inst, old)}"
        elif old and not self.owned_live(inst, old):
            allowed, why = REFUSED, f"fmi2DeSerializeFMUstate into a variable holding {self._describe_ptr(inst, old)}"
        elif mode != "real" or buf is None:
            what = {
                "trunc": f"the first {arg} bytes of a state",
                "junk": f"{arg} random bytes",
                "magic": "a state whose first 4 bytes are inverted",
                "empty": "0 bytes",
                "nullbuf": "a NULL buffer",
            }.get(mode, mode)
            if buf is None and mode in ("real", "trunc", "magic"):
                what = "0 bytes (an empty buffer)"
            allowed, why = REFUSED, f"fmi2DeSerializeFMUstate of {what}"
        else:
            allowed, why = deserialise_rule(inst, buf)
        step, status = self._simple(call, send, line, allowed, why)
        q = int(step.answer.split()[1], 16)
        if mode != "nullout":
            self._unchanged(step, j, status)
        if step.violation is None and status in SUCCESS and buf is not None:
            if old and self.owned_live(inst, old) and q != old:
                step.violation = Violation("wrong-answer", f"{why}: the live state was not replaced in place ({q:#x})")
            else:
                step.violation = self._hand_out(inst, q, old, replace(buf.snapshot), "fmi2DeSerializeFMUstate")
                self.handles[q].origin_hash = buf.hash
            self.stats["deserialise"] += 1
        self.slots[j] = q
        return step

    def _slot(self, call: Call, send: Callable) -> Step:
        op = call.args[0]
        j, i = call.k, call.args[1] if len(call.args) > 1 else call.k
        line = f"slot {op} {j} {i}"
        answer, log = send(line)
        if op == "copy":
            self.slots[i] = self.slots[j]
        else:
            ptr = int(answer, 16)
            self.slots[j] = ptr
            if ptr and ptr not in self.handles:
                self.handles[ptr] = Handle(ptr, None, None, False)
        return Step(call, line, answer, log, None, f"host-side {op}")


# ------------------------------------------------------------------------------------------------ generator
@dataclass
class Plan:
    """One sequence: the instances (FMU kind and fidelity) in slots 0.. and the number of calls."""

    instances: list[tuple[str, int]]
    length: int


class Generator:
    """Seeded random calls for one sequence, chosen from the oracle's current model: mostly legal calls
    that move the instances through the state machine (and into discarded steps, restores and
    deserialisations), with probability `bad` a forbidden call or invalid arguments."""

    def __init__(self, rng: random.Random, plan: Plan, bad: float = 0.2) -> None:
        self.rng, self.plan, self.bad = rng, plan, bad
        self.count = 0
        self.queue: list[Call] = []
        self.started: set[int] = set()
        self.next_buffer = 0

    # the calls of one sequence, one at a time
    def next_call(self, oracle: Oracle) -> Call | None:
        if self.queue:
            return self.queue.pop(0)
        self.count += 1
        if self.count > self.plan.length:
            live = sorted(oracle.instances)
            return Call("free", live[0]) if live else None
        again = 0.3 if not oracle.instances else 0.03  # an instance freed before the end: another in its slot
        for k, (kind, _) in enumerate(self.plan.instances):
            if k not in oracle.instances and (k not in self.started or self.rng.random() < again):
                self.started.add(k)
                return self._instantiate(k, kind)
        if not oracle.instances:
            return None
        k = self.rng.choice(sorted(oracle.instances))
        inst = oracle.instances[k]
        if self.rng.random() < self.bad:
            return self._illegal(oracle, inst)
        return self._legal(oracle, inst)

    def _instantiate(self, k: int, kind: str) -> Call:
        rng = self.rng
        logging = int(rng.random() < 0.3)
        if rng.random() < 0.15:
            bad = rng.choice(["wrong", "other", "null", "type", "nologger", "nocallbacks", "noname"])
            self.queue.append(Call("instantiate", k, (kind, "right", 1, logging, "full", "name")))
            guid = bad if bad in ("wrong", "other", "null") else "right"
            callbacks = {"nologger": "nologger", "nocallbacks": "null"}.get(bad, "full")
            return Call(
                "instantiate",
                k,
                (kind, guid, 0 if bad == "type" else 1, logging, callbacks, "null" if bad == "noname" else "name"),
            )
        return Call("instantiate", k, (kind, "right", 1, logging, "full", "name"))

    # ---------------------------------------------------------------- helpers
    def _target(self, inst: Instance) -> int:
        return self.plan.instances[inst.slot][1] if inst.slot < len(self.plan.instances) else RIGID

    def _configured(self, inst: Instance) -> bool:
        if inst.fmu.kind != "pendulum":
            return True
        target = self._target(inst)
        mesh_ok = target != FEM or inst.values["model.mesh_size"] == FEM_MESH
        return effective_fidelity(inst.values) == target and mesh_ok

    def _configure(self, inst: Instance) -> Call:
        rng, fmu = self.rng, inst.fmu
        target = self._target(inst)
        if target == FEM and inst.values["model.mesh_size"] != FEM_MESH and effective_fidelity(inst.values) == FEM:
            return Call("set", inst.slot, ("Real", (fmu.vr("model.mesh_size"),), (FEM_MESH,)))
        if target == FEM:
            self.queue.append(Call("set", inst.slot, ("Real", (fmu.vr("model.mesh_size"),), (FEM_MESH,))))
        alias = "model.fidelity_index" if rng.random() < 0.3 else "model.fidelity"
        substeps = rng.choice([0, 1, 1, 3])
        vrs, values = [fmu.vr(alias)], [target]
        if alias == "model.fidelity_index" or rng.random() < 0.5:
            vrs.append(fmu.vr("model.fidelity" if alias == "model.fidelity_index" else "model.fidelity_index"))
            values.append(rng.choice([2, 4]) if alias == "model.fidelity_index" else 0)
        vrs.append(fmu.vr("solver.max_substeps"))
        values.append(substeps)
        return Call("set", inst.slot, ("Integer", tuple(vrs), tuple(values)))

    def _parameter_set(self, inst: Instance) -> Call:
        rng, fmu = self.rng, inst.fmu
        if fmu.kind == "pid":
            names = rng.sample(["Kp", "Ki", "Kd", "u_max", "setpoint", "measurement"], rng.randint(1, 3))
            values = [round(rng.uniform(0.0, 20.0), 4) for _ in names]
            return Call("set", inst.slot, ("Real", tuple(fmu.vr(n) for n in names), tuple(values)))
        choice = rng.random()
        if choice < 0.6:
            names = rng.sample(["theta0", "omega0", "gravity", "torque"], rng.randint(1, 3))
            gen = {
                "theta0": lambda: round(rng.uniform(0.05, 0.6), 6),
                "omega0": lambda: round(rng.uniform(-1.0, 1.0), 6),
                "gravity": lambda: rng.choice([9.81, 9.0, 10.5]),
                "torque": lambda: round(rng.uniform(-2.0, 2.0), 6),
            }
            if inst.has_model:  # parameters fixed by a restored model: only the same values are accepted
                values = [inst.values[n] if n != "torque" else gen[n]() for n in names]
            else:
                values = [gen[n]() for n in names]
            return Call("set", inst.slot, ("Real", tuple(fmu.vr(n) for n in names), tuple(values)))
        if choice < 0.75:
            value = (
                inst.values["model.compute_stress"]
                if inst.has_model or self._target(inst) == FEM
                else rng.random() < 0.5
            )
            return Call("set", inst.slot, ("Boolean", (fmu.vr("model.compute_stress"),), (value,)))
        if choice < 0.85:
            return Call("set", inst.slot, ("String", (fmu.vr("output.vtk_folder"),), ("",)))
        return Call(
            "set",
            inst.slot,
            (
                "Integer",
                (fmu.vr("solver.max_substeps"),),
                (inst.values["solver.max_substeps"] if inst.has_model else rng.choice([0, 1]),),
            ),
        )

    def _input_set(self, inst: Instance, value: float | None = None) -> Call:
        rng, fmu = self.rng, inst.fmu
        if fmu.kind == "pid":
            names = rng.sample(["setpoint", "measurement"], rng.randint(1, 2))
            vals = tuple(round(rng.uniform(-1, 1), 6) if value is None else value for _ in names)
            return Call("set", inst.slot, ("Real", tuple(fmu.vr(n) for n in names), vals))
        v = round(rng.uniform(-3.0, 3.0), 6) if value is None else value
        return Call("set", inst.slot, ("Real", (fmu.vr("torque"),), (v,)))

    def _input_derivatives(self, inst: Instance, bad: bool = False) -> Call:
        """setRealInputDerivatives of the FMU's inputs (orders 1 and 2, finite values), or with `bad` one
        wrong reference, order or value."""
        rng, fmu = self.rng, inst.fmu
        inputs = [v.vr for v in fmu.variables.values() if v.derivable == "input"]
        vrs = rng.sample(inputs, rng.randint(1, len(inputs)))
        orders = [rng.choice([1, 2]) for _ in vrs]
        values = [round(rng.uniform(-50.0, 50.0), 4) for _ in vrs]
        if rng.random() < 0.3 and len(vrs) == 1:  # both orders of one input
            vrs, orders, values = vrs * 2, [1, 2], [values[0], round(rng.uniform(-500.0, 500.0), 3)]
        if bad:
            i, kind = rng.randrange(len(vrs)), rng.choice(["output", "parameter", "order", "value", "none"])
            others = [v.vr for v in fmu.variables.values() if (v.causality == "output") == (kind == "output")]
            if kind in ("output", "parameter"):
                vrs[i] = rng.choice([vr for vr in others if vr not in inputs])
            elif kind == "order":
                orders[i] = rng.choice([0, 3, -1])
            elif kind == "value":
                values[i] = rng.choice([math.nan, math.inf])
            else:
                vrs[i] = 999
        return Call("setinder", inst.slot, (tuple(vrs), tuple(orders), tuple(values)))

    def _output_derivatives(self, inst: Instance, bad: bool = False) -> Call:
        """getRealOutputDerivatives of some continuous outputs (orders 1 and 2), or with `bad` a summary,
        an input, order 3 or an unknown reference among them."""
        rng, fmu = self.rng, inst.fmu
        outputs = [v.vr for v in fmu.variables.values() if v.derivable == "output" and v.name not in SUMMARIES]
        if fmu.kind == "pendulum" and rng.random() < 0.5:
            vrs = [fmu.vr("theta")] + rng.sample(outputs, rng.randint(0, 3))
        else:
            vrs = rng.sample(outputs, rng.randint(1, min(4, len(outputs))))
        orders = [rng.choice([1, 2]) for _ in vrs]
        if bad:
            i = rng.randrange(len(vrs))
            summaries = [fmu.vr(n) for n in SUMMARIES if n in fmu.variables]
            choice = rng.choice(["summary", "input", "order", "none"] if summaries else ["input", "order", "none"])
            if choice == "summary":
                vrs[i] = rng.choice(summaries)
            elif choice == "input":
                vrs[i] = next(v.vr for v in fmu.variables.values() if v.causality == "input")
            elif choice == "order":
                orders[i] = rng.choice([0, 3])
            else:
                vrs[i] = 999
        return Call("getoutder", inst.slot, (tuple(vrs), tuple(orders)))

    def _get(self, inst: Instance) -> Call:
        rng, fmu = self.rng, inst.fmu
        r = rng.random()
        if fmu.kind == "pid":
            vrs = rng.sample([v.vr for v in fmu.variables.values()], rng.randint(1, 4))
            return Call("get", inst.slot, ("Real", tuple(vrs)))
        if r < 0.6:
            outs = [fmu.vr(n) for n in CHECKED_OUTPUTS["pendulum"]]
            vrs = rng.sample(outs, rng.randint(1, 3)) + rng.sample(
                [v.vr for v in fmu.of_type("Real")], rng.randint(0, 2)
            )
            return Call("get", inst.slot, ("Real", tuple(vrs)))
        if r < 0.8:
            vrs = rng.sample([v.vr for v in fmu.of_type("Integer")], rng.randint(1, 3))
            return Call("get", inst.slot, ("Integer", tuple(vrs)))
        if r < 0.9:
            return Call("get", inst.slot, ("Boolean", (fmu.vr("model.compute_stress"),)))
        if r < 0.97:
            return Call("get", inst.slot, ("String", (fmu.vr("output.vtk_folder"),)))
        return Call("get", inst.slot, ("Real", ()))

    def _h(self, inst: Instance) -> float:
        rng = self.rng
        if inst.fmu.kind == "pid":
            return rng.choice([0.001, 0.01, 0.1])
        if self._target(inst) == FEM:
            return rng.choice([0.001, 0.001, 0.002, 0.05])
        return rng.choice([0.001, 0.001, 0.002, 0.005, 0.01, 0.05, 0.05])

    def _into_new_slot(self, oracle: Oracle, inst: Instance, make: Callable[[int], Call]) -> Call:
        """A legal state call that hands out a state into a slot: a NULL one, else a live state of `inst`
        (replaced in place), else a slot the host first sets to NULL (as a master does)."""
        empty = [j for j in range(N_HANDLE_SLOTS) if not oracle.slots[j]]
        live = oracle.live_handles(inst)
        if empty or live:
            return make(self.rng.choice(empty or live))
        j = self.rng.randrange(N_HANDLE_SLOTS)
        self.queue.insert(0, make(j))
        return Call("slot", j, ("null", j))

    def _buffer(self) -> int:
        self.next_buffer = (self.next_buffer + 1) % N_BUFFERS
        return self.next_buffer

    def _restorable(self, oracle: Oracle, inst: Instance) -> list[int]:
        """Live handles of `inst` that its SetFMUstate must accept."""
        out = []
        for j in oracle.live_handles(inst):
            snap = oracle.handles[oracle.slots[j]].snapshot
            assert snap is not None
            if inst.has_model and (not snap.has_model or not oracle._same_parameters(inst, snap)):
                continue
            if snap.taken_in == TERMINATED and inst.state != TERMINATED:
                continue
            out.append(j)
        return out

    def _fitting_buffers(self, oracle: Oracle, inst: Instance) -> list[int]:
        """Byte buffers whose fmi2DeSerializeFMUstate `inst` must accept."""
        return [b for b, buf in oracle.buffers.items() if deserialise_rule(inst, buf)[0] == SUCCESS]

    def _state_call(self, oracle: Oracle, inst: Instance) -> Call:
        """A legal FMU state call: take, restore, serialise, deserialise, size or free."""
        rng, k = self.rng, inst.slot
        live = oracle.live_handles(inst)
        restorable = self._restorable(oracle, inst)
        fitting = self._fitting_buffers(oracle, inst)
        options: list[tuple[float, Callable[[], Call]]] = [
            (3.0, lambda: self._into_new_slot(oracle, inst, lambda j: Call("getstate", k, (j,)))),
            (1.0 if live else 0.0, lambda: Call("getstate", k, (rng.choice(live),))),
            (4.0 if restorable else 0.0, lambda: Call("setstate", k, (rng.choice(restorable),))),
            (
                3.0 if live else 0.0,
                lambda: Call(
                    "serialize",
                    k,
                    (rng.choice(live), rng.choice(["exact", "larger"]), rng.choice([1, 7, 100, 5000]), self._buffer()),
                ),
            ),
            (
                2.5 if fitting else 0.0,
                lambda: self._into_new_slot(
                    oracle, inst, lambda j: Call("deser", k, (j, rng.choice(fitting), "real", 0))
                ),
            ),
            (0.7 if live else 0.0, lambda: Call("size", k, (rng.choice(live), 0))),
            (
                1.0 if len(live) > 1 else 0.2 if live else 0.0,
                lambda: Call("freestate", k, (rng.choice(live), rng.choice(["addr", "addr", "addr", "value"]))),
            ),
            (0.2, lambda: Call("freestate", k, (rng.randrange(N_HANDLE_SLOTS), "null"))),
        ]
        return self._pick(options)

    def _pick(self, options: list[tuple[float, Callable[[], Call]]]) -> Call:
        weights = [w for w, _ in options]
        return self.rng.choices([f for _, f in options], weights=weights)[0]()

    # ---------------------------------------------------------------- legal calls
    def _legal(self, oracle: Oracle, inst: Instance) -> Call:
        rng, k = self.rng, inst.slot
        states_ok = inst.fmu.can_states
        configured = self._configured(inst) or inst.has_model
        if inst.state == INSTANTIATED:
            options = [
                (8.0 if not configured else 0.0, lambda: self._configure(inst)),
                (5.0 if configured else 0.3, lambda: Call("enter", k)),
                (2.0, lambda: Call("setup", k, (rng.choice([0.0, 0.0, 0.0, 0.5, 10.0]),))),
                (1.5, lambda: self._parameter_set(inst)),
                (2.0 if states_ok else 0.0, lambda: self._state_call(oracle, inst)),
                (0.3, lambda: Call("debug", k, (rng.randint(0, 1), self._categories(inst)))),
                (0.2, lambda: Call("reset", k)),
                (0.4, lambda: self._input_derivatives(inst)),
            ]
        elif inst.state == INIT:
            validity = parameter_validity(inst.fmu, inst.values)
            options = [
                (8.0 if not configured else 0.0, lambda: self._configure(inst)),
                (6.0 if configured and validity == "valid" else 0.5, lambda: Call("exit", k)),
                (
                    2.0 if validity == "invalid" else 0.0,
                    lambda: Call("set", k, ("Real", (inst.fmu.vr("pendulum.nu"),), (0.3,))),
                ),
                (
                    0.4 if inst.fmu.kind == "pendulum" and not inst.has_model else 0.0,
                    lambda: Call("set", k, ("Real", (inst.fmu.vr("pendulum.nu"),), (0.5,))),
                ),
                (1.5, lambda: self._parameter_set(inst)),
                (1.5, lambda: self._get(inst)),
                (1.5 if states_ok else 0.0, lambda: self._state_call(oracle, inst)),
                (0.2, lambda: Call("reset", k)),
                (0.4, lambda: self._input_derivatives(inst)),
            ]
        elif inst.state == STEP:
            torque_nan = inst.fmu.kind == "pendulum" and not math.isfinite(inst.values["torque"])
            pid_nan = inst.fmu.kind == "pid" and inst.dubious
            options = [
                (
                    12.0 if not torque_nan else 0.5,
                    lambda: Call("dostep", k, ("right", self._h(inst), rng.randint(0, 1))),
                ),
                (4.0 if torque_nan or pid_nan else 0.0, lambda: self._input_set(inst)),
                (4.0, lambda: self._get(inst)),
                (2.0, lambda: self._input_set(inst)),
                (2.0, lambda: self._input_derivatives(inst)),
                (1.5, lambda: self._output_derivatives(inst)),
                (5.0 if states_ok else 0.0, lambda: self._state_call(oracle, inst)),
                (2.5, lambda: self._status(inst, legal=True)),
                (0.4, lambda: Call("terminate", k)),
                (0.3, lambda: Call("reset", k)),
                (0.2, lambda: Call("debug", k, (rng.randint(0, 1), self._categories(inst)))),
                (0.1, lambda: Call("free", k)),
            ]
        else:  # terminated
            options = [
                (
                    2.0 if states_ok else 0.0,
                    lambda: self._into_new_slot(oracle, inst, lambda j: Call("getstate", k, (j,))),
                ),
                (2.0, lambda: self._get(inst)),
                (0.7, lambda: self._output_derivatives(inst)),
                (2.0, lambda: self._status(inst, legal=True)),
                (1.5 if states_ok else 0.0, lambda: self._state_call(oracle, inst)),
                (2.0, lambda: Call("reset", k)),
                (1.0, lambda: Call("free", k)),
            ]
        return self._pick(options)

    def _categories(self, inst: Instance) -> tuple[str, ...]:
        cats = list(inst.fmu.categories)
        return tuple(self.rng.sample(cats, self.rng.randint(0, min(2, len(cats))))) if cats else ()

    def _status(self, inst: Instance, legal: bool) -> Call:
        rng, k = self.rng, inst.slot
        if legal:
            op, kind = rng.choice(
                [
                    ("realstatus", 2),
                    ("realstatus", 2),
                    ("boolstatus", 3),
                    ("boolstatus", 3),
                    ("status", 0),
                    ("stringstatus", 1),
                    ("intstatus", rng.randint(0, 3)),
                ]
            )
            return Call(op, k, (kind, 0))
        op = rng.choice(list(STATUS_FUNCTIONS))
        r = rng.random()
        if r < 0.4:
            return Call(op, k, (BAD_STATUS_KIND, 0))
        if r < 0.7:
            return Call(op, k, (rng.randint(0, 3), 1))
        return Call(op, k, (rng.randint(0, 3), 0))  # a kind that may not be this function's

    # ---------------------------------------------------------------- illegal calls
    def _illegal(self, oracle: Oracle, inst: Instance) -> Call:
        rng, k, fmu = self.rng, inst.slot, inst.fmu
        forbidden = self._forbidden(inst)
        options: list[tuple[float, Callable[[], Call]]] = [
            (4.0 if forbidden else 0.0, lambda: rng.choice(forbidden)),
            (1.0, lambda: self._bad_get(inst)),
            (1.5, lambda: self._bad_set(inst)),
            (1.5 if inst.state == STEP else 0.2, lambda: self._bad_step(inst)),
            (1.0, lambda: self._status(inst, legal=False)),
            (0.5, lambda: Call(rng.choice(list(NOT_PROVIDED)), k)),
            (0.8, lambda: self._input_derivatives(inst, bad=True)),
            (0.8, lambda: self._output_derivatives(inst, bad=True)),
            (3.0 if fmu.can_states else 1.0, lambda: self._bad_state(oracle, inst)),
            (0.3, lambda: Call("debug", k, (1, ("noSuchCategory",)))),
        ]
        return self._pick(options)

    def _forbidden(self, inst: Instance) -> list[Call]:
        k, s = inst.slot, inst.state
        calls = []
        if s != INSTANTIATED:
            calls += [Call("setup", k, (0.0,)), Call("enter", k)]
        else:
            calls += [Call("get", k, ("Real", (1,))), Call("terminate", k)]
        if s != INIT:
            calls.append(Call("exit", k))
        if s != STEP:
            calls += [Call("dostep", k, ("right", 0.001, 1)), Call("terminate", k)]
        if s in (INSTANTIATED, INIT):
            calls += [Call("realstatus", k, (2, 0)), Call("boolstatus", k, (3, 0)), Call("status", k, (0, 0))]
        if s == TERMINATED:
            calls += [self._input_set(inst), self._input_derivatives(inst)]
        if s in (INSTANTIATED, INIT):
            calls.append(self._output_derivatives(inst))
        return calls

    def _bad_get(self, inst: Instance) -> Call:
        rng, fmu, k = self.rng, inst.fmu, inst.slot
        if fmu.kind == "pid":
            return rng.choice(
                [
                    Call("get", k, ("Integer", (3,))),
                    Call("get", k, ("Real", (7,))),
                    Call("get", k, ("Boolean", (0,))),
                    Call("get", k, ("String", (1,))),
                ]
            )
        return rng.choice(
            [
                Call("get", k, ("Real", (fmu.vr("solver.substeps"),))),  # an Integer
                Call("get", k, ("Real", (1, 999))),
                Call("get", k, ("Integer", (fmu.vr("theta"),))),
                Call("get", k, ("Boolean", (fmu.vr("torque"),))),
                Call("get", k, ("String", (fmu.vr("theta0"),))),
                Call("get", k, ("Integer", (4_000_000_000,))),
            ]
        )

    def _bad_set(self, inst: Instance) -> Call:
        rng, fmu, k = self.rng, inst.fmu, inst.slot
        if fmu.kind == "pid":
            return rng.choice(
                [
                    Call("set", k, ("Real", (2,), (1.0,))),  # the output u
                    Call("set", k, ("Real", (0, 9), (1.0, 1.0))),
                    Call("set", k, ("Integer", (3,), (1,))),
                    Call("set", k, ("Real", (3,), (inst.values["Kp"],))),  # a parameter: refused in stepComplete
                    self._input_set(inst, math.nan),
                ]
            )
        r = rng.random()
        if r < 0.2:
            return Call("set", k, ("Real", (fmu.vr("theta"),), (0.1,)))  # an output
        if r < 0.35:  # a parameter, same value (refused in stepComplete whatever the value)
            return Call("set", k, ("Real", (fmu.vr("torque"), fmu.vr("theta0")), (0.25, inst.values["theta0"])))
        if r < 0.5:
            return Call("set", k, ("Real", (fmu.vr("torque"), fmu.vr("omega0")), (-0.5, 0.123)))
        if r < 0.6:
            return Call("set", k, ("Integer", (fmu.vr("torque"),), (1,)))
        if r < 0.7:
            return Call("set", k, ("Real", (fmu.vr("torque"), 1000), (0.5, 0.5)))
        if r < 0.8:
            return Call("set", k, ("String", (fmu.vr("output.vtk_folder"),), (None,)))
        if r < 0.9:
            return self._input_set(inst, rng.choice([math.nan, math.inf]))
        return Call("set", k, ("Real", (fmu.vr("theta0"),), (math.nan,)))

    def _bad_step(self, inst: Instance) -> Call:
        rng, k = self.rng, inst.slot
        return rng.choice(
            [
                Call("dostep", k, ("wrong", 0.001, 1)),
                Call("dostep", k, ("back", 0.001, 0)),
                Call("dostep", k, ("nan", 0.001, 1)),
                Call("dostep", k, ("right", 0.0, 1)),
                Call("dostep", k, ("right", -0.001, 1)),
                Call("dostep", k, ("right", math.nan, 1)),
                Call("dostep", k, ("right", math.inf, 0)),
                Call("dostep", k, ("tiny", 0.001, 1)),  # within the tolerance: legal
            ]
        )

    def _bad_state(self, oracle: Oracle, inst: Instance) -> Call:
        """A state call with a pointer that is not a live state of this instance, or invalid arguments."""
        rng, k = self.rng, inst.slot
        live = oracle.live_handles(inst)
        foreign = [
            j
            for j in range(N_STATE_SLOTS)
            for i in oracle.instances.values()
            if i is not inst and oracle.owned_live(i, oracle.slots[j])
        ]
        dead = [
            j
            for j in range(N_STATE_SLOTS)
            if (h := oracle.handle(oracle.slots[j])) is not None and h.owner is not None and h.live is False
        ]
        junk_slot = N_HANDLE_SLOTS + rng.randrange(N_STATE_SLOTS - N_HANDLE_SLOTS)
        restorable = self._restorable(oracle, inst)
        unsettable = [j for j in live if j not in restorable]  # taken before initialisation, or in terminated
        if unsettable and rng.random() < 0.5:
            return Call("setstate", k, (rng.choice(unsettable),))
        r = rng.random()
        if r < 0.25:  # make a pointer nobody handed out, then use it
            op = rng.choice(["heap", "static", "small"])
            self.queue.append(self._use_pointer(inst, junk_slot, readable=op != "small"))
            return Call("slot", junk_slot, (op, junk_slot))
        if r < 0.4 and live:  # keep a copy of a live state, free it, use the copy
            j = rng.choice(live)
            self.queue += [Call("freestate", k, (j, "addr")), self._use_pointer(inst, junk_slot, readable=False)]
            return Call("slot", j, ("copy", junk_slot))
        if r < 0.5 and (dead or foreign):
            return self._use_pointer(inst, rng.choice(dead + foreign), readable=False)
        if r < 0.6:
            return self._use_pointer(
                inst, rng.choice([j for j in range(N_HANDLE_SLOTS) if not oracle.slots[j]] or [0]), readable=False
            )
        if r < 0.75 and live:
            return Call(
                "serialize",
                k,
                (
                    rng.choice(live),
                    rng.choice(["smaller", "smaller", "nullbuf"]),
                    rng.choice([1, 7, 10**9]),
                    self._buffer(),
                ),
            )
        if r < 0.8 and live:
            return Call("size", k, (rng.choice(live), 1))
        mode = rng.choice(["trunc", "junk", "magic", "empty", "nullbuf", "nullout", "real"])
        buffers = sorted(oracle.buffers) or [0]
        b = rng.choice(buffers)
        size = oracle.buffers[b].size if b in oracle.buffers else 0
        arg = {"trunc": rng.randint(0, max(size - 1, 0)), "junk": rng.choice([1, 16, 300, 5000])}.get(mode, 0)
        return self._into_new_slot(oracle, inst, lambda j: Call("deser", k, (j, b, mode, arg)))

    def _use_pointer(self, inst: Instance, j: int, readable: bool) -> Call:
        rng, k = self.rng, inst.slot
        ops = ["setstate", "size", "serialize", "freestate", "getstate"]
        op = rng.choice(ops)
        if op == "size":
            return Call("size", k, (j, 0))
        if op == "serialize":
            return Call("serialize", k, (j, "exact", 0, self._buffer()))
        if op == "freestate":
            return Call("freestate", k, (j, "value" if readable and rng.random() < 0.5 else "addr"))
        return Call(op, k, (j,))


def make_plan(rng: random.Random, fem_share: float, two_share: float, pid_share: float) -> Plan:
    def one() -> tuple[str, int]:
        if rng.random() < pid_share:
            return ("pid", 0)
        return ("pendulum", FEM if rng.random() < fem_share else RIGID)

    instances = [one()]
    if rng.random() < two_share:
        instances.append(one())
    return Plan(instances, rng.randint(15, 70))


# ------------------------------------------------------------------------------------------------ runner
@dataclass
class SequenceResult:
    steps: list[Step]
    violation_at: int | None = None  # index in steps
    stats: Counter = field(default_factory=Counter)
    seconds: float = 0.0

    @property
    def violation(self) -> Violation | None:
        return self.steps[self.violation_at].violation if self.violation_at is not None else None


class Runner:
    """Runs sequences through one host process, restarted after a crash or a hang."""

    def __init__(self, host: Host, fmus: dict[str, FmuInfo]) -> None:
        self.host, self.fmus = host, fmus
        self.crashes = 0

    def run(self, source: Generator | list[Call]) -> SequenceResult:
        oracle = Oracle(self.fmus)
        calls = iter(source) if isinstance(source, list) else None
        result = SequenceResult([])
        t0 = time.perf_counter()
        sent: list[str] = []

        def send(line: str) -> tuple[str, list[str]]:
            sent.append(line)
            return self.host.send(line)

        while True:
            call = next(calls, None) if calls is not None else source.next_call(oracle)  # type: ignore[union-attr]
            if call is None:
                break
            if not oracle.applicable(call):
                continue
            try:
                step = oracle.execute(call, send)
            except (HostDied, HostHung) as exc:
                kind = "hang" if isinstance(exc, HostHung) else "crash"
                code = getattr(exc, "returncode", None)
                detail = "no answer within the timeout" if kind == "hang" else f"the host died (exit {code})"
                step = Step(call, sent[-1] if sent else str(call), "", exc.log, Violation(kind, detail), "")
                self.crashes += 1
                result.steps.append(step)
                result.violation_at = len(result.steps) - 1
                oracle.instances.clear()
                break
            result.steps.append(step)
            if step.violation is not None:
                result.violation_at = len(result.steps) - 1
                break
        self._cleanup(oracle)
        result.stats = oracle.stats
        result.seconds = time.perf_counter() - t0
        return result

    def _cleanup(self, oracle: Oracle) -> None:
        """Free what the sequence left (after a violation), forget the host's state slots and buffers."""
        try:
            for k in sorted(oracle.instances):
                self.host.send(f"free {k}")
            if self.host.running:
                self.host.send("clear")
        except (HostDied, HostHung):
            self.crashes += 1


def replay_fails_alike(runner: Runner, calls: list[Call], signature: str) -> SequenceResult | None:
    result = runner.run(list(calls))
    if result.violation is None:
        return None
    step = result.steps[result.violation_at]  # type: ignore[index]
    return result if step.signature() == signature else None


def minimise(runner: Runner, result: SequenceResult, budget: int = 40) -> list[Step] | None:
    """The shortest failing prefix of a failing sequence, then shortened further by dropping calls that
    the failure does not need (while the same violation still ends it); None when the prefix alone does
    not fail again in a fresh host."""
    assert result.violation_at is not None
    last = result.steps[result.violation_at]
    assert last.violation is not None
    signature = last.signature()
    calls = [s.call for s in result.steps[: result.violation_at + 1]]
    runner.host.close()  # a fresh host: the reproducer must not need what earlier sequences left
    again = replay_fails_alike(runner, calls, signature)
    if again is None:
        return None
    best = again.steps
    calls = [s.call for s in best]
    tries = 0
    chunk = max(1, (len(calls) - 1) // 2)
    while chunk >= 1 and tries < budget:
        i, shrunk = 0, False
        while i < len(calls) - 1 and tries < budget:
            candidate = calls[:i] + calls[i + chunk :] if i + chunk < len(calls) else None
            if candidate is None:
                break
            tries += 1
            found = replay_fails_alike(runner, candidate, signature)
            if found is not None:
                best = found.steps
                calls = [s.call for s in best]
                shrunk = True
            else:
                i += chunk
        if not shrunk:
            chunk //= 2
    return best


# ------------------------------------------------------------------------------------------------ campaign
@dataclass
class Campaign:
    """Figures of many sequences."""

    sequences: int = 0
    calls: int = 0
    answers: Counter = field(default_factory=Counter)
    violations: Counter = field(default_factory=Counter)
    coverage: Counter = field(default_factory=Counter)
    kinds: Counter = field(default_factory=Counter)  # sequence kinds
    first: dict[str, SequenceResult] = field(default_factory=dict)  # the first sequence of each signature
    counts: Counter = field(default_factory=Counter)  # sequences per signature
    seconds: float = 0.0
    host_starts: int = 0

    def add(self, plan: Plan, result: SequenceResult) -> None:
        self.sequences += 1
        self.calls += sum(s.call.op != "slot" for s in result.steps)  # FMI calls, not the host's own slot ops
        self.kinds[
            "+".join(f"{k}{'-fem' if f == FEM else '-rigid' if f == RIGID else ''}" for k, f in plan.instances)
        ] += 1
        for s in result.steps:
            head = s.answer.split()[0] if s.answer else "no answer"
            if s.call.op == "slot":
                continue
            if s.call.op == "serialize" and s.answer:
                self.answers[STATUS_NAMES[int(s.answer.split()[2])]] += 1
            elif head.lstrip("-").isdigit() and 0 <= int(head) < len(STATUS_NAMES):
                self.answers[STATUS_NAMES[int(head)]] += 1
            elif s.call.op == "instantiate":
                self.answers["instance" if head == "ok" else "NULL" if head == "null" else head] += 1
        self.coverage.update(result.stats)
        v = result.violation
        if v is not None:
            self.violations[v.kind] += 1
            step = result.steps[result.violation_at]  # type: ignore[index]
            sig = step.signature()
            self.counts[sig] += 1
            self.first.setdefault(sig, result)


def run_campaign(
    runner: Runner,
    n: int,
    seed: int,
    fem_share: float,
    two_share: float,
    pid_share: float,
    progress: Callable[[int, Campaign], None] | None = None,
) -> Campaign:
    rng = random.Random(seed)
    campaign = Campaign()
    t0 = time.perf_counter()
    starts0 = runner.host.starts
    for i in range(n):
        plan = make_plan(rng, fem_share, two_share, pid_share)
        result = runner.run(Generator(random.Random(rng.getrandbits(64)), plan))
        campaign.add(plan, result)
        if progress is not None:
            progress(i + 1, campaign)
    campaign.seconds = time.perf_counter() - t0
    campaign.host_starts = runner.host.starts - starts0
    return campaign


def format_steps(steps: list[Step], indent: str = "    ") -> str:
    out = []
    for s in steps:
        out.append(f"{indent}{s.line}  ->  {s.answer or '(no answer)'}")
        if s.violation is not None:
            out.append(f"{indent}  ^ {s.violation.kind}: {s.violation.detail}")
            out += [f"{indent}    {line}" for line in s.log[-6:]]
    return "\n".join(out)


def report(campaign: Campaign, reproducers: dict[str, list[Step] | None]) -> str:
    lines = [
        f"sequences {campaign.sequences}  calls {campaign.calls}  seconds {campaign.seconds:.1f}  "
        f"host starts {campaign.host_starts}",
        "sequence kinds: " + ", ".join(f"{k} {v}" for k, v in sorted(campaign.kinds.items())),
        "answers: " + ", ".join(f"{k} {v}" for k, v in sorted(campaign.answers.items(), key=lambda kv: -kv[1])),
        "coverage: " + ", ".join(f"{k} {v}" for k, v in sorted(campaign.coverage.items())),
        "violations: " + ", ".join(f"{k} {campaign.violations.get(k, 0)}" for k in VIOLATION_KINDS),
    ]
    for sig, count in campaign.counts.most_common():
        lines.append(f"\n[{count} sequence(s)] {sig}")
        steps = reproducers.get(sig)
        if sig not in reproducers:
            result = campaign.first[sig]
            steps = result.steps[: (result.violation_at or 0) + 1]
            lines.append(f"  failing prefix ({len(steps)} calls, not minimised):")
        elif steps is None:
            result = campaign.first[sig]
            steps = result.steps[: (result.violation_at or 0) + 1]
            lines.append(f"  did not fail again alone in a fresh host; its prefix ({len(steps)} calls):")
        else:
            lines.append(f"  minimal reproducer ({len(steps)} calls; host lines, answers):")
        lines.append(format_steps(steps or []))
    return "\n".join(lines)


def setup_fmus(fmu_dir: Path, workdir: Path) -> dict[str, FmuInfo]:
    return {
        "pendulum": load_fmu(Path(fmu_dir) / "FemPendulum.fmu", 0, workdir / "FemPendulum"),
        "pid": load_fmu(Path(fmu_dir) / "PidController.fmu", 1, workdir / "PidController"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sequences", type=int, default=1000)
    parser.add_argument("--fem-share", type=float, default=0.2, help="share of pendulum instances running fem")
    parser.add_argument("--two-instance-share", type=float, default=0.2, help="share of sequences with two instances")
    parser.add_argument("--pid-share", type=float, default=0.1, help="share of instances of the PID FMU")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--fmu-dir", type=Path, required=True, help="folder with FemPendulum.fmu, PidController.fmu")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds a call may take")
    parser.add_argument("--minimise", type=int, default=25, help="violation classes to minimise (the most frequent)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="fmi2_sequences_") as tmp:
        work = Path(tmp)
        fmus = setup_fmus(args.fmu_dir, work)
        host = Host(compile_host(work), fmus.values(), work, timeout=args.timeout)
        runner = Runner(host, fmus)

        def progress(i: int, c: Campaign) -> None:
            if i % 100 == 0:
                print(f"... {i} sequences, {c.calls} calls, violations {dict(c.violations)}", file=sys.stderr)

        try:
            campaign = run_campaign(
                runner, args.sequences, args.seed, args.fem_share, args.two_instance_share, args.pid_share, progress
            )
            reproducers = {}
            for sig, _ in campaign.counts.most_common(args.minimise):
                reproducers[sig] = minimise(runner, campaign.first[sig])
        finally:
            host.close()
    print(report(campaign, reproducers))
    return 1 if campaign.violations else 0


if __name__ == "__main__":
    sys.exit(main())
