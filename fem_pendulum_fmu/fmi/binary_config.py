"""What the FMU's binary (shim/) is told about its FMU at compile time, read from the modelDescription.

The binary checks every call against the state machine and every Get/Set against the variables'
type, causality and variability before the Python slave is called, for any slave (the pendulum's
and the PID's alike): the GUID and capability flags become -D flags, the variables a generated
header, `fmu_variables.h`, included by shim/variables.c.
"""

from __future__ import annotations

from xml.etree import ElementTree

TYPES = ("Real", "Integer", "Boolean", "String")  # an Enumeration is read and set as an Integer
# FMI 3.0: the variable elements and the binary's kind of each (an Enumeration is read and set as an Int64)
FMI3_KINDS = {"Float64": "REAL", "Int32": "INTEGER", "Boolean": "BOOLEAN", "String": "STRING", "Enumeration": "INT64"}


# the highest input derivative order an FMU that can interpolate its inputs takes (FMI 2.0 declares none;
# both of this project's slaves take a polynomial of degree 2: docs/reference/fmi2.md)
INPUT_DERIVATIVE_ORDER = 2


def capability_defines(model_description: str) -> list[str]:
    """The compiler's -D flags: the GUID, the FMU state capabilities, the input derivative order (0 unless
    canInterpolateInputs) and maxOutputDerivativeOrder."""
    root = ElementTree.fromstring(model_description)
    cosim = root.find("CoSimulation")
    flags = cosim.attrib if cosim is not None else {}

    def on(name: str) -> int:
        return int(flags.get(name, "false") == "true")

    if root.get("fmiVersion") == "3.0":  # the instantiation token plays the GUID's part (fmi3_functions.c)
        return [
            "-DFMI3_BINARY",
            f'-DFMU_GUID="{root.attrib["instantiationToken"]}"',
            f"-DFMU_CAN_GET_SET_STATE={on('canGetAndSetFMUState')}",
            f"-DFMU_CAN_SERIALIZE_STATE={on('canSerializeFMUState')}",
            f"-DFMU_MAX_OUTPUT_DERIVATIVE_ORDER={int(flags.get('maxOutputDerivativeOrder', '0'))}",
        ]
    return [
        f'-DFMU_GUID="{root.attrib["guid"]}"',
        f"-DFMU_CAN_GET_SET_STATE={on('canGetAndSetFMUstate')}",
        f"-DFMU_CAN_SERIALIZE_STATE={on('canSerializeFMUstate')}",
        f"-DFMU_INPUT_DERIVATIVE_ORDER={INPUT_DERIVATIVE_ORDER * on('canInterpolateInputs')}",
        f"-DFMU_MAX_OUTPUT_DERIVATIVE_ORDER={int(flags.get('maxOutputDerivativeOrder', '0'))}",
    ]


def settable_in(causality: str, variability: str, initial: str | None, fmi3: bool = False) -> str:
    """The states (shim/state_machine.h masks) in which FMI 2.0 (or 3.0) lets a host set such a variable."""
    if variability == "constant" or causality in ("output", "calculatedParameter", "local", "independent"):
        before = causality == "output" and initial in ("exact", "approx")  # never so in this project's FMUs
        return "STATE_INSTANTIATED | STATE_INITIALIZATION_MODE" if before else "0"
    if causality == "input" or variability == "tunable":
        event = " | STATE_EVENT_MODE" if fmi3 else ""
        return f"STATE_INSTANTIATED | STATE_INITIALIZATION_MODE | STATE_STEP_COMPLETE{event}"
    return "STATE_INSTANTIATED | STATE_INITIALIZATION_MODE"  # a fixed parameter


def described(causality: str, variability: str) -> str:
    """What the variable is, for the binary's messages: "an output", "a discrete output", "a fixed parameter"."""
    if causality == "parameter":
        return f"a {variability} parameter"
    if causality == "output" and variability == "discrete":
        return "a discrete output"
    return {"input": "an input", "output": "an output", "calculatedParameter": "a calculated parameter"}.get(
        causality, f"a {causality} variable"
    )


def role(type_: str, causality: str, variability: str) -> str:
    """ROLE_INPUT / ROLE_OUTPUT for a continuous Real input / output (what has time derivatives), else
    ROLE_OTHER."""
    if type_ != "Real" or variability != "continuous" or causality not in ("input", "output"):
        return "ROLE_OTHER"
    return "ROLE_INPUT" if causality == "input" else "ROLE_OUTPUT"


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _row(var: ElementTree.Element, kind: str, real: str, fmi3: bool, size: int) -> str:
    causality = var.get("causality", "local")
    variability = var.get("variability", "continuous")
    settable = settable_in(causality, variability, var.get("initial"), fmi3)
    return (
        f"    {{{var.get('valueReference')}u, KIND_{kind}, {_c_string(var.get('name', ''))}, "
        f"{_c_string(described(causality, variability))}, {settable}, {role(real, causality, variability)}, {size}}},"
    )


def _fmi3_size(var: ElementTree.Element) -> int:
    """The number of elements of an FMI 3.0 variable: 1, or the product of its fixed Dimensions."""
    size = 1
    for dim in var.findall("Dimension"):
        size *= int(dim.attrib["start"])
    return size


def variables_header(model_description: str) -> str:
    """fmu_variables.h: one row per variable, {value reference, type, name, what it is, settable states,
    role, number of elements}."""
    root = ElementTree.fromstring(model_description)
    rows = []
    if root.get("fmiVersion") == "3.0":
        for var in root.find("ModelVariables") or []:
            if var.tag in FMI3_KINDS:
                real = "Real" if var.tag == "Float64" else var.tag
                rows.append(_row(var, FMI3_KINDS[var.tag], real, True, _fmi3_size(var)))
    for var in root.iter("ScalarVariable"):
        kind = next((child.tag for child in var if child.tag in (*TYPES, "Enumeration")), None)
        if kind is None:
            continue
        kind = "Integer" if kind == "Enumeration" else kind
        rows.append(_row(var, kind.upper(), kind, False, 1))
    head = "/* generated by fem_pendulum_fmu/fmi/binary_config.py from modelDescription.xml */\n"
    return head + "\n".join(rows) + "\n"
