"""The FMI 3.0 FMU names FMI 3.0's functions, statuses and types; the FMI 2.0 FMU names FMI 2.0's.

Both take the names from one table (fem_pendulum_fmu/fmi/fmi_names.py): the template's placeholders in the
modelDescription, the slaves' messages. Checked on the built FMUs' modelDescription.xml; on the messages of a set
of refused calls through each binary (a bad parameter, a bad fidelity index, re-entering initialisation, a Discard
repeated, output derivatives under a NaN torque and of a per-step summary, calls after terminate), each FMU in a
child process as in tests/test_fmu3.py; and on the messages the slaves give for what only a binary without the
checks lets through (pythonfmu's and pythonfmu3's, on Windows).
"""

from __future__ import annotations

import zipfile
from ctypes import byref
from pathlib import Path
from xml.etree import ElementTree

import pytest
from fmpy import extract, fmi2, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.logging import addLoggerProxy
from fmu3_instance import child

MODULE = Path(__file__).stem
ROOT = Path(__file__).resolve().parents[1]
RIGID = 2  # model.fidelity item
STEP_MODE = {2: "stepComplete", 3: "stepMode"}  # what each binary calls the state after initialisation


def model_description(fmu: Path) -> tuple[str, dict[str, str]]:
    """The FMU's modelDescription.xml and its descriptions by variable or log category name."""
    with zipfile.ZipFile(fmu) as archive:
        text = archive.read("modelDescription.xml").decode()
    root = ElementTree.fromstring(text)
    return text, {e.get("name", ""): e.get("description", "") for e in root.iter() if e.get("description") is not None}


def test_the_fmi3_model_description_names_fmi3_only(fmu3):
    text, described = model_description(fmu3)
    assert "fmi2" not in text and "{{" not in text
    assert "a doStep that needs more answers fmi3Discard with the state kept" in described["solver.max_substeps"]
    assert described["logStatusDiscard"].startswith("Messages with fmi3Discard status")
    assert described["logStatusError"].startswith("Messages with fmi3Error status")
    # FMI 3.0 co-simulation has no input derivatives: the torque is held over a step, nothing else
    assert described["torque"].endswith("counter-clockwise positive, held constant over a communication step")


def test_the_fmi2_model_description_still_names_fmi2(fmus):
    text, described = model_description(fmus[0])
    assert "fmi3" not in text and "{{" not in text
    assert "a doStep that needs more answers fmi2Discard with the state kept" in described["solver.max_substeps"]
    assert described["logStatusWarning"] == "Messages with fmi2Warning status"
    assert (
        "derivatives of order 1 and 2 set by fmi2SetRealInputDerivatives (cleared by the step)" in described["torque"]
    )


def test_a_placeholder_is_a_name_of_the_version():
    from fem_pendulum_fmu.fmi.fmi_names import fmi_text  # here: the children load the FMUs' own package

    assert fmi_text("a{{fmi2:, by {{fmi:set_real_input_derivatives}}}} {{fmi:error}}", 2) == (
        "a, by fmi2SetRealInputDerivatives fmi2Error"
    )
    assert fmi_text("a{{fmi2:, by {{fmi:set_real_input_derivatives}}}} {{fmi:error}}", 3) == "a fmi3Error"
    with pytest.raises(ValueError, match="names nothing in FMI 3.0"):
        fmi_text("{{fmi:set_real_input_derivatives}}", 3)
    with pytest.raises(ValueError, match="names nothing in FMI 2.0"):
        fmi_text("{{fmi:no_such_function}}", 2)


class Host:
    """fmpy's FMU2Slave or FMU3Slave of the pendulum FMU, instantiated with a logger that collects (debug logging
    off: errors and Discards reach the log regardless), and the calls the refusals need."""

    def __init__(self, fmu: str, version: int) -> None:
        md = read_model_description(fmu)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.start = {v.name: v.start for v in md.modelVariables}
        self.version, self.messages = version, []
        kind = FMU2Slave if version == 2 else FMU3Slave
        self.fmu = kind(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier="FemPendulum", instanceName="w")
        if version == 3:
            self.fmu.instantiate(logMessage=lambda env, status, category, message: self._log(message))
            return
        callbacks = fmi2.fmi2CallbackFunctions()
        self._logger = fmi2.fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: self._log(message))
        callbacks.logger = self._logger  # kept: C holds the pointer
        callbacks.allocateMemory = fmi2.defaultCallbacks.allocateMemory
        callbacks.freeMemory = fmi2.defaultCallbacks.freeMemory
        addLoggerProxy(byref(callbacks))
        self.fmu.instantiate(callbacks=callbacks)

    def _log(self, message: bytes) -> None:
        self.messages.append(message.decode())

    def enter(self) -> None:
        if self.version == 2:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=0.0)

    def set(self, name: str, value: float, kind: str = "real") -> None:
        setter = {
            2: {"real": "setReal", "integer": "setInteger", "enumeration": "setInteger"},
            3: {"real": "setFloat64", "integer": "setInt32", "enumeration": "setInt64"},
        }[self.version][kind]
        getattr(self.fmu, setter)([self.vr[name]], [value])

    def derivative(self, name: str) -> None:
        get = self.fmu.getRealOutputDerivatives if self.version == 2 else self.fmu.getOutputDerivatives
        get([self.vr[name]], [1])


def refused_messages(fmu: str, version: int) -> dict[str, dict]:
    """(In a child.) For each case of refused calls: their statuses and the messages they logged."""
    host, cases = Host(fmu, version), {}

    def case(name: str, *calls) -> None:
        mark, statuses = len(host.messages), []
        for call in calls:
            try:
                call()
                statuses.append(0)
            except FMICallException as exc:  # fmpy raises for anything above a warning
                statuses.append(int(exc.status))
        cases[name] = {"statuses": statuses, "messages": host.messages[mark:]}

    host.enter()
    host.set("pendulum.nu", 0.5)
    case("bad parameter", host.fmu.exitInitializationMode)
    host.set("pendulum.nu", float(host.start["pendulum.nu"]))
    host.set("model.fidelity_index", 9, "integer")
    case("bad fidelity index", host.fmu.exitInitializationMode)
    host.set("model.fidelity_index", 0, "integer")
    host.set("model.fidelity", RIGID, "enumeration")
    host.set("solver.max_substeps", 1, "integer")
    host.fmu.exitInitializationMode()
    case("re-entering initialisation", host.enter, host.fmu.exitInitializationMode)

    def long_step() -> None:  # over the first contact: more than one internal step
        host.fmu.doStep(0.0, 0.5)

    case("discard", long_step, long_step)
    host.set("torque", float("nan"))
    case("derivatives", lambda: host.derivative("theta"), lambda: host.derivative("gap_min"))
    host.set("torque", 0.0)
    host.fmu.terminate()
    case("after terminate", lambda: host.fmu.doStep(0.0, 1e-3), lambda: host.set("torque", 1.0), host.fmu.terminate)
    host.fmu.freeInstance()
    return cases


@pytest.fixture(scope="module")
def refusals(fmus, fmu3) -> dict[int, dict[str, dict]]:
    return {2: child(MODULE, "refused_messages", str(fmus[0]), 2), 3: child(MODULE, "refused_messages", str(fmu3), 3)}


@pytest.mark.parametrize("version", [3, 2])
def test_refused_calls_name_the_fmi_version_s_functions(refusals, version):
    from fem_pendulum_fmu.fmi.fmi_names import NAMES

    cases, names, other = refusals[version], NAMES[version], f"fmi{5 - version}"
    every = [m for c in cases.values() for m in c["messages"]]
    assert not [m for m in every if other in m], every  # no name of the other version, anywhere

    def said(name: str, *parts: str) -> bool:
        return any(all(p in m for p in parts) for m in cases[name]["messages"])

    assert cases["bad parameter"]["statuses"] == [3]
    assert said("bad parameter", "pendulum.nu", f"(correct them and call {names.exit_initialization_mode} again)")
    assert cases["bad fidelity index"]["statuses"] == [3]
    assert said(
        "bad fidelity index",
        "parameter model.fidelity_index = 9 is not allowed: choose one of 0 (use model.fidelity), 1 (auto), ",
        f"call {names.exit_initialization_mode} again",
    )
    assert not said("bad fidelity index", "model.fidelity = 9")  # named by its own name, not its enumeration's
    assert cases["re-entering initialisation"]["statuses"] == [3, 3]
    assert said(
        "re-entering initialisation", f"fmi{version}ExitInitializationMode refused in state {STEP_MODE[version]}"
    )
    assert cases["discard"]["statuses"] == [2, 2]
    assert said("discard", "doStep discarded at t = 0.0", "solver.max_substeps = 1")
    assert said("discard", f"the same step was discarded before: end the run ({names.terminated} is true)")
    assert cases["derivatives"]["statuses"] == [3, 3]
    assert said("derivatives", f"{names.get_output_derivatives} refused: torque = nan is not allowed")
    assert said("derivatives", "gap_min", f"not a continuous {names.type_name('Real')} output")
    assert cases["after terminate"]["statuses"] == [3, 3, 3]
    assert said("after terminate", f"fmi{version}DoStep refused in state terminated")
    assert said("after terminate", f"{names.set_real} refused in state terminated")
    assert said("after terminate", f"fmi{version}Terminate refused in state terminated")


def test_the_slaves_name_their_version_s_calls_where_no_binary_checks_first():
    """What pythonfmu's and pythonfmu3's binaries pass on unchecked: the slaves refuse it, in their version's names
    (no binary here: the messages are queued)."""
    from fem_pendulum_fmu.fmi.slave import PendulumSlave
    from fem_pendulum_fmu.fmi.slave3 import PendulumSlave3

    slave2, slave3 = PendulumSlave(instance_name="w2", resources=str(ROOT)), PendulumSlave3(instance_name="w3")
    theta, fidelity = (slave2.interface.by_name(n).value_reference for n in ("theta", "model.fidelity"))
    slave2.get_real([999])
    slave2.set_integer([theta], [1])
    slave3.get_float64([999])
    slave3.set_int64([theta], [1])
    slave3.get_int32([theta])
    slave3.set_float64([fidelity], [1.0])
    said2 = [m.msg for m in slave2._get_log_queue()]
    said3 = [m.msg for m in slave3.log_queue]
    assert [m.split(" refused: ")[0] for m in said2] == ["fmi2GetReal", "fmi2SetInteger"]
    assert "value reference 999 is no variable of this FMU" in said2[0] and "theta, not of type Integer" in said2[1]
    assert [m.split(" refused: ")[0] for m in said3] == [
        "fmi3GetFloat64",
        "fmi3SetInt64",
        "fmi3GetInt32",
        "fmi3SetFloat64",
    ]
    assert "theta, not of type Int64 (Enumeration)" in said3[1] and "theta, not of type Int32" in said3[2]
    assert "model.fidelity, not of type Float64" in said3[3]
