"""Reads modelDescription.template.xml, the one declaration of the FMI interface.

The slave registers its variables from it, the builder (fmi/builder.py) renders it
into the FMU's modelDescription.xml, and `fem-pendulum interface --markdown`
prints the README's variable table from it. `scene_from_values` turns parameter
values into the `Scene` they describe, for the slave and the masters alike: the
tables of what is not a scene parameter (ENUM_ALIASES, FMU_ONLY_PARAMETERS) live
here only.
"""

from __future__ import annotations

import argparse
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal, get_args

from ..physics.names import python_name
from ..physics.scene import Scene
from .fmi_names import FMI3_TYPES, FmiVersion, fmi_text

TEMPLATE_NAME = "modelDescription.template.xml"
# Integer aliases of enumerations, for masters that cannot set enumerations (libcosim); 0 = the enumeration decides
ENUM_ALIASES = {"wall.kind_index": "wall.kind", "model.fidelity_index": "model.fidelity"}
# parameters of the FMU's field output (fmi/vtk_output.py), not of the physics: no Scene field takes them
FMU_ONLY_PARAMETERS = ("output.vtk_folder", "output.vtk_interval")
# the FMU's outputs, in the template's order
OUTPUT_NAMES = (
    "theta",
    "omega",
    "gap",
    "contact_force",
    "energy.kinetic",
    "energy.potential",
    "energy.strain",
    "energy.contact",
    "energy.total",
    "energy.torque_work",
    "stress.von_mises_max",
    "solver.substeps",
    "gap_min",
    "contact_force_max",
    "contact_impulse",
)
# FMI output name -> field of physics.protocol.Outputs: the same name, '.' written '_' (physics/names.py)
OUTPUT_FIELDS = {name: python_name(name) for name in OUTPUT_NAMES}


VariableType = Literal["Real", "Integer", "Boolean", "Enumeration", "String"]
Causality = Literal["parameter", "calculatedParameter", "input", "output", "local", "independent"]
Variability = Literal["constant", "fixed", "tunable", "discrete", "continuous"]


@dataclass(frozen=True)
class Variable:
    """One variable of the FMI interface as the template declares it."""

    name: str
    value_reference: int
    type: VariableType
    causality: Causality
    variability: Variability
    description: str
    start: float | int | bool | str | None = None
    unit: str | None = None
    display_unit: str | None = None
    declared_type: str | None = None
    items: tuple[str, ...] = field(default=())  # enumeration item names, in value order 1, 2, ...

    def item_name(self, value: int) -> str:
        """Enumeration value -> item name; ValueError naming the allowed values."""
        if not 1 <= int(value) <= len(self.items):
            allowed = ", ".join(f"{i} ({n})" for i, n in enumerate(self.items, 1))
            raise ValueError(f"parameter {self.name} = {value!r} is not allowed: choose one of {allowed}")
        return self.items[int(value) - 1]

    def item_number(self, name: str) -> int:
        """Enumeration item name -> value (1, 2, ...), the reverse of item_name; ValueError naming the allowed items."""
        if name not in self.items:
            allowed = f"choose one of {', '.join(self.items)}" if self.items else "it is not an enumeration"
            raise ValueError(f"parameter {self.name} = {name!r} is not allowed: {allowed}")
        return self.items.index(name) + 1


@dataclass(frozen=True)
class Interface:
    model_identifier: str
    variables: tuple[Variable, ...]
    start_time: float
    stop_time: float
    step_size: float

    def by_name(self, name: str) -> Variable:
        for v in self.variables:
            if v.name == name:
                return v
        raise KeyError(name)

    def of_causality(self, causality: Causality) -> tuple[Variable, ...]:
        return tuple(v for v in self.variables if v.causality == causality)


def scene_from_values(values: Mapping[str, Any], interface: Interface | None = None) -> Scene:
    """The scene that FMI parameter values describe; parameters `values` leaves out keep the Scene's
    defaults (the template's start values, tests/test_interface.py).

    Enumerations may be given by number, as fmi2SetInteger takes them, or by item name, as a sweep's
    table holds them; an Integer alias other than 0 wins over its enumeration; FMU-only parameters
    are left out. ValueError names a value that is not allowed or a name that is not a parameter.
    """
    interface = interface or load()
    parameters = {v.name: v for v in interface.of_causality("parameter")}
    scene_values: dict[str, Any] = {}
    for name, value in values.items():
        if name not in parameters:
            raise ValueError(f"{name} is not a parameter of the FMU (see `fem-pendulum interface`)")
        if name not in ENUM_ALIASES and name not in FMU_ONLY_PARAMETERS:
            scene_values[name] = _scene_value(parameters[name], value)
    for alias, target in ENUM_ALIASES.items():
        index = int(values.get(alias, 0))
        if index != 0:
            scene_values[target] = _alias_item(alias, parameters[target], index)
    return Scene().with_values(scene_values)


TYPE_REQUIREMENTS = {"Real": "a number", "Integer": "an integer", "Boolean": "true or false"}
"""What a value of each FMI type must be, in the one wording every message about a bad value uses
("... is not allowed: it must be a number"; a choice: "... is not allowed: choose one of ...")."""


def requirement(type_name: str, items: tuple[str, ...] = ()) -> str:
    """The clause of a message refusing a value that is not of its variable's type or vocabulary."""
    if items:
        numbers = f"1 to {len(items)}" if len(items) > 1 else "1"
        return f"choose one of {', '.join(items)} (or their numbers {numbers})"
    return f"it must be {TYPE_REQUIREMENTS.get(type_name, 'a number')}"


def parameter(interface: Interface, name: str) -> Variable:
    """The parameter `name`, for a value from text; ValueError saying what `name` is otherwise."""
    try:
        var = interface.by_name(name)
    except KeyError:
        raise ValueError(f"{name} is not a variable of the FMU (see `fem-pendulum interface`)") from None
    if var.causality != "parameter":
        raise ValueError(f"{name} is an {var.causality}, not a parameter: only parameters take a start value here")
    return var


def parse_text(var: Variable, text: str) -> float | int | bool | str:
    """A parameter's value from text (a command line's NAME=VALUE, a sweep's grid or table) by its declared
    type: an enumeration's item name or number, true/false (or 1/0), an integer, a number, a String as
    written. ValueError: "parameter NAME = 'TEXT' is not allowed: ..." (`requirement`)."""
    if var.type == "String" and not var.items:
        return text  # a folder's name keeps its spaces
    text = text.strip()
    try:
        if var.items:
            return text if text in var.items else var.item_name(int(text))
        if var.type == "Boolean":
            if text.lower() not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return text.lower() in ("true", "1")
        return int(text) if var.type == "Integer" else float(text)
    except ValueError:
        raise ValueError(
            f"parameter {var.name} = {text!r} is not allowed: {requirement(var.type, var.items)}"
        ) from None


def _alias_item(alias: str, target: Variable, index: int) -> str:
    """The item an Integer alias other than 0 picks; a ValueError naming the alias (not its enumeration) and the
    values it takes."""
    if not 1 <= index <= len(target.items):
        allowed = ", ".join([f"0 (use {target.name})", *(f"{i} ({n})" for i, n in enumerate(target.items, 1))])
        raise ValueError(f"parameter {alias} = {index!r} is not allowed: choose one of {allowed}")
    return target.items[index - 1]


def _scene_value(var: Variable, value: Any) -> Any:
    """A parameter's value as the Scene holds it: enumerations by item name, numbers of the declared type."""
    if var.items and isinstance(value, str):
        var.item_number(value)  # a ValueError naming the items when it is none of them
        return value
    if var.items:
        return var.item_name(value)
    if var.type == "Real":
        return float(value)
    if var.type == "Integer":
        return int(value)
    if var.type == "Boolean":
        return bool(value)
    return value


def template_path(resources: str | os.PathLike | None = None) -> Path:
    """The template inside an FMU's resources folder, else the one this package carries (fmi/)."""
    candidates = []
    if resources:
        candidates.append(Path(resources) / TEMPLATE_NAME)
    if os.environ.get("FEM_PENDULUM_TEMPLATE"):
        candidates.append(Path(os.environ["FEM_PENDULUM_TEMPLATE"]))
    here = Path(__file__).resolve().parent
    candidates.append(here / TEMPLATE_NAME)
    for path in candidates:
        if path.is_file():
            return path
    raise FileNotFoundError(f"{TEMPLATE_NAME} not found; looked in: {', '.join(map(str, candidates))}")


def _start(typ: str, text: str | None) -> float | int | bool | str | None:
    if text is None:
        return None
    if typ == "String":
        return text
    if typ == "Real":
        return float(text)
    if typ == "Boolean":
        return text.strip().lower() in ("true", "1")
    return int(text)


def _attribute(element: ET.Element, name: str) -> str:
    """A required attribute of a template element; ValueError naming it when it is missing."""
    value = element.get(name)
    if value is None:
        raise ValueError(f"{TEMPLATE_NAME}: <{element.tag}> has no attribute {name}")
    return value


def _word(element: ET.Element, name: str, value: str | None, vocabulary: Any) -> Any:
    """`value` if it is a word of the Literal `vocabulary`; ValueError naming it and the words otherwise."""
    words = get_args(vocabulary)
    if value not in words:
        raise ValueError(
            f"{TEMPLATE_NAME}: <{element.tag}> {name} = {value!r} is not allowed: choose one of {', '.join(words)}"
        )
    return value


def _child(element: ET.Element, tag: str) -> ET.Element:
    """A required child of a template element; ValueError naming it when it is missing."""
    child = element.find(tag)
    if child is None:
        raise ValueError(f"{TEMPLATE_NAME}: <{element.tag}> has no <{tag}>")
    return child


@lru_cache(maxsize=8)
def _parse(path: str) -> Interface:
    root = ET.parse(path).getroot()
    enums: dict[str | None, tuple[str, ...]] = {}
    for st in root.iter("SimpleType"):
        en = st.find("Enumeration")
        if en is not None:
            items = sorted(en.findall("Item"), key=lambda it: int(_attribute(it, "value")))
            enums[st.get("name")] = tuple(_attribute(it, "name") for it in items)
    variables = []
    for sv in _child(root, "ModelVariables").findall("ScalarVariable"):
        (typed,) = list(sv)
        declared = typed.get("declaredType")
        variables.append(
            Variable(
                name=_attribute(sv, "name"),
                value_reference=int(_attribute(sv, "valueReference")),
                type=_word(typed, "type", typed.tag, VariableType),
                causality=_word(sv, "causality", sv.get("causality", "local"), Causality),
                variability=_word(sv, "variability", sv.get("variability", "continuous"), Variability),
                description=fmi_text(sv.get("description", ""), 2),  # FMI 2.0's words (fmi_names.py)
                start=_start(typed.tag, typed.get("start")),
                unit=typed.get("unit"),
                display_unit=typed.get("displayUnit"),
                declared_type=declared,
                items=enums.get(declared, ()),
            )
        )
    de = _child(root, "DefaultExperiment")
    return Interface(
        _attribute(_child(root, "CoSimulation"), "modelIdentifier"),
        tuple(variables),
        float(_attribute(de, "startTime")),
        float(_attribute(de, "stopTime")),
        float(_attribute(de, "stepSize")),
    )


def load(resources: str | os.PathLike | None = None) -> Interface:
    """The interface declared in the template (see template_path for where it is looked for)."""
    return _parse(str(template_path(resources)))


def render(guid: str, date: str, version: str, path: Path | None = None, fmi_version: FmiVersion = 2) -> str:
    """The template's text with its placeholders filled: the FMU's modelDescription.xml, its texts naming what
    `fmi_version` names (fmi_names.py; the FMI 3.0 FMU's is then translated by model_description3.py)."""
    text = (path or template_path()).read_text()
    text = text.replace("{{GUID}}", guid).replace("{{DATE}}", date).replace("{{VERSION}}", version)
    return fmi_text(text, fmi_version)


def markdown_table(interface: Interface | None = None) -> str:
    """The variable table for the README (the type as the FMI 2.0 and the FMI 3.0 FMU declare it)."""
    interface = interface or load()
    header = "| name | causality | type (FMI 2.0 / 3.0) | unit | start | description |"
    rows = [header, "|---|---|---|---|---|---|"]
    for v in interface.variables:
        unit = (v.unit or "") + (f" (display {v.display_unit})" if v.display_unit else "")
        typ = f"Enumeration ({', '.join(v.items)})" if v.items else f"{v.type} / {FMI3_TYPES[v.type]}"
        if v.start is None:
            start = ""
        elif v.items:
            start = v.items[int(v.start) - 1]
        else:
            start = f"{v.start:g}" if v.type == "Real" else str(v.start)
        rows.append(f"| `{v.name}` | {v.causality} | {typ} | {unit} | {start} | {v.description} |")
    return "\n".join(rows)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--markdown", action="store_true", help="print the variables as a Markdown table")
    parser.add_argument(
        "--write-readme",
        type=Path,
        metavar="README",
        help="replace the table between the interface-table markers of this Markdown file",
    )


def command(args: argparse.Namespace) -> None:
    if args.write_readme:
        text = args.write_readme.read_text()
        start, end = "<!-- interface-table:start -->", "<!-- interface-table:end -->"
        head, _, rest = text.partition(start)
        _, _, tail = rest.partition(end)
        args.write_readme.write_text(f"{head}{start}\n{markdown_table()}\n{end}{tail}")
    elif args.markdown:
        print(markdown_table())
    else:
        for v in load().variables:
            print(v.value_reference, v.name, v.causality, v.type, v.unit or "", v.start)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Print the FMU's variables.")
    add_arguments(parser)
    command(parser.parse_args(argv))


if __name__ == "__main__":
    main()
