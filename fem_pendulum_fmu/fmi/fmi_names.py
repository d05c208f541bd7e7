"""What the FMU's texts call the FMI functions, statuses and types they name, in each FMI version: the one table.

The template writes such a name as a placeholder, `{{fmi:discard}}`, and a clause that only the FMI 2.0 FMU has
(FMI 3.0 co-simulation has no input derivatives) as `{{fmi2:...}}`; `fmi_text` fills them in for a version when the
template is read (interface.py: the FMI 2.0 words, for the slave and the README) or rendered (interface.render, for
the FMI 2.0 and the FMI 3.0 modelDescription). The slaves' messages take their names from `FmiNames`: the FMI 2.0
slave (slave.py, variable_access.py) from FMI2_NAMES, the one the FMI 3.0 slave holds (slave3.py) from FMI3_NAMES.
The binaries' own messages name the calls of their state machine's tables (shim/state_machine.h, shim/fmi3_calls.h).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields
from typing import Literal

FmiVersion = Literal[2, 3]

# each FMI 2.0 type of the template and the FMI 3.0 FMU's type for it (model_description3.py; an Enumeration is one
# in both, read and set as Int64)
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}


@dataclass(frozen=True)
class FmiNames:
    """The names one FMI version gives to what the FMU's texts mention (a field per name; the template's
    placeholders are the field names)."""

    version: FmiVersion
    exit_initialization_mode: str
    terminated: str  # what tells a master that no shorter step can avoid a Discard
    warning: str
    discard: str
    error: str
    fatal: str
    get_output_derivatives: str
    set_real_input_derivatives: str | None  # None: FMI 3.0 co-simulation has no input derivatives
    deserialize_fmu_state: str
    get_real: str
    set_real: str
    get_integer: str
    set_integer: str
    get_enumeration: str
    set_enumeration: str
    enumeration_type: str  # the type they take
    get_boolean: str
    set_boolean: str
    get_string: str
    set_string: str

    def type_name(self, fmi2_type: str) -> str:
        """The FMI 2.0 type `fmi2_type` (Real, Integer, Boolean, String) as this version names it."""
        return fmi2_type if self.version == 2 else FMI3_TYPES.get(fmi2_type, fmi2_type)


FMI2_NAMES = FmiNames(
    version=2,
    exit_initialization_mode="fmi2ExitInitializationMode",
    terminated="fmi2Terminated",
    warning="fmi2Warning",
    discard="fmi2Discard",
    error="fmi2Error",
    fatal="fmi2Fatal",
    get_output_derivatives="fmi2GetRealOutputDerivatives",
    set_real_input_derivatives="fmi2SetRealInputDerivatives",
    deserialize_fmu_state="fmi2DeSerializeFMUstate",
    get_real="fmi2GetReal",
    set_real="fmi2SetReal",
    get_integer="fmi2GetInteger",
    set_integer="fmi2SetInteger",
    get_enumeration="fmi2GetInteger",
    set_enumeration="fmi2SetInteger",
    enumeration_type="Integer",
    get_boolean="fmi2GetBoolean",
    set_boolean="fmi2SetBoolean",
    get_string="fmi2GetString",
    set_string="fmi2SetString",
)
FMI3_NAMES = FmiNames(
    version=3,
    exit_initialization_mode="fmi3ExitInitializationMode",
    terminated="fmi3DoStep's terminateSimulation",
    warning="fmi3Warning",
    discard="fmi3Discard",
    error="fmi3Error",
    fatal="fmi3Fatal",
    get_output_derivatives="fmi3GetOutputDerivatives",
    set_real_input_derivatives=None,
    deserialize_fmu_state="fmi3DeserializeFMUState",
    get_real="fmi3GetFloat64",
    set_real="fmi3SetFloat64",
    get_integer="fmi3GetInt32",
    set_integer="fmi3SetInt32",
    get_enumeration="fmi3GetInt64",
    set_enumeration="fmi3SetInt64",
    enumeration_type="Int64 (Enumeration)",
    get_boolean="fmi3GetBoolean",
    set_boolean="fmi3SetBoolean",
    get_string="fmi3GetString",
    set_string="fmi3SetString",
)
NAMES: dict[FmiVersion, FmiNames] = {2: FMI2_NAMES, 3: FMI3_NAMES}

_PLACEHOLDER = re.compile(r"\{\{fmi:(\w+)\}\}")
_FMI2_CLAUSE = re.compile(r"\{\{fmi2:((?:[^{}]|\{\{fmi:\w+\}\})*)\}\}")  # it may hold placeholders
_WORDS = tuple(f.name for f in fields(FmiNames) if f.name != "version")


def fmi_text(text: str, version: FmiVersion) -> str:
    """`text` with its {{fmi2:...}} clauses kept (FMI 2.0) or left out (FMI 3.0) and its {{fmi:name}} placeholders
    named as `version` names them. ValueError for a placeholder that names nothing in this version."""
    names = NAMES[version]

    def name(match: re.Match[str]) -> str:
        word = match.group(1)
        value = getattr(names, word) if word in _WORDS else None
        if value is None:
            raise ValueError(f"{match.group(0)} names nothing in FMI {version}.0 (the names: {', '.join(_WORDS)})")
        return str(value)

    return _PLACEHOLDER.sub(name, _FMI2_CLAUSE.sub(lambda m: m.group(1) if version == 2 else "", text))
