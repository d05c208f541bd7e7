"""The FMI 3.0 modelDescription.xml, rendered from the one declaration of the interface.

The template (modelDescription.template.xml, FMI 2.0 form) is rendered as for the FMI 2.0 FMU, with the names
of FMI 3.0's functions and statuses in its texts (interface.render, fmi_names.py), and translated here: the same
variable names, value references, units, display units, descriptions, start values and model structure, with
FMI 3.0's types (Real -> Float64, Integer -> Int32, Enumeration -> Enumeration of an EnumerationType, Boolean,
String), the instantiation token in place of the GUID, FMI 3.0's independent variable `time`, the array outputs
of ARRAY_OUTPUTS and the co-simulation capabilities of the FMI 3.0 binary (shim/fmi3_*.c): event mode,
intermediate update and early return, FMU states. docs/notes/fmu_layer.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from xml.dom import minidom
from xml.etree import ElementTree as ET

from ..physics.head_gaps import profile_angles
from ..physics.scene import PendulumGeometry
from .fmi_names import FMI3_TYPES
from .interface import load

DESCRIPTION_ATTRIBUTES = ("name", "valueReference", "description", "causality", "variability", "initial")


@dataclass(frozen=True)
class ArrayOutput:
    """An FMI 3.0 array output of the slave (fmi/slave3.py reads it from the model's outputs)."""

    name: str
    size: int
    unit: str
    description: str


# physics/head_gaps.py: points of the head's outer boundary every 22.5 degrees from the one facing the wall, each
# moved as the body moves it, and their signed distances to the wall block; the `gap` output is the minimum over
# the whole boundary
GAP_POINTS = len(profile_angles(PendulumGeometry()))
ARRAY_OUTPUTS = (
    ArrayOutput(
        "gap_profile",
        GAP_POINTS,
        "m",
        f"Signed distance to the wall block of {GAP_POINTS} points of the head's outer boundary, every 22.5 degrees "
        "counter-clockwise from the one facing the wall in the hanging position (those in the rod's joint left "
        "out), negative = penetration; the gap output is the minimum over the whole boundary",
    ),
)
CAPABILITIES = {
    "needsExecutionTool": "true",
    "canBeInstantiatedOnlyOncePerProcess": "false",
    "canGetAndSetFMUState": "true",
    "canSerializeFMUState": "true",
    "canHandleVariableCommunicationStepSize": "true",
    "hasEventMode": "true",
    "providesIntermediateUpdate": "true",
    "canReturnEarlyAfterIntermediateUpdate": "true",
    "mightReturnEarlyFromDoStep": "true",
    "maxOutputDerivativeOrder": "2",  # the FMI 2.0 slave's (fmi3GetOutputDerivatives)
}


def time_reference() -> int:
    """The value reference of FMI 3.0's independent variable `time`: after the template's variables."""
    return max(v.value_reference for v in load().variables) + 1


def array_references() -> dict[str, int]:
    """The value references of the array outputs, after `time`."""
    first = time_reference() + 1
    return {array.name: first + k for k, array in enumerate(ARRAY_OUTPUTS)}


def _copy_units(root2: ET.Element, root3: ET.Element) -> None:
    units = root2.find("UnitDefinitions")
    if units is not None:
        root3.append(units)


def _type_definitions(root2: ET.Element) -> ET.Element:
    types = ET.Element("TypeDefinitions")
    for simple in root2.iter("SimpleType"):
        enum = simple.find("Enumeration")
        if enum is None:
            continue
        typed = ET.SubElement(types, "EnumerationType", name=simple.attrib["name"])
        if simple.get("description"):
            typed.set("description", simple.attrib["description"])
        for item in enum.findall("Item"):
            typed.append(item)
    return types


def _variable(scalar: ET.Element) -> ET.Element:
    (typed,) = list(scalar)
    tag = "Enumeration" if typed.tag == "Enumeration" else FMI3_TYPES[typed.tag]
    var = ET.Element(tag, {k: scalar.attrib[k] for k in DESCRIPTION_ATTRIBUTES if k in scalar.attrib})
    for key in ("declaredType", "unit", "displayUnit"):
        if key in typed.attrib:
            var.set(key, typed.attrib[key])
    start = typed.get("start")
    if start is not None and tag == "String":
        ET.SubElement(var, "Start", value=start)
    elif start is not None:
        var.set("start", start)
    return var


def _extra_variables(variables: ET.Element) -> None:
    """FMI 3.0's independent variable and the array outputs."""
    ET.SubElement(
        variables,
        "Float64",
        name="time",
        valueReference=str(time_reference()),
        causality="independent",
        variability="continuous",
        unit="s",
        description="Simulation time",
    )
    references = array_references()
    for array in ARRAY_OUTPUTS:
        var = ET.SubElement(
            variables,
            "Float64",
            name=array.name,
            valueReference=str(references[array.name]),
            causality="output",
            variability="continuous",
            initial="calculated",
            unit=array.unit,
            description=array.description,
        )
        ET.SubElement(var, "Dimension", start=str(array.size))


def _model_structure(root2: ET.Element, references: list[str]) -> ET.Element:
    """Outputs and InitialUnknowns by value reference (FMI 2.0's are 1-based indices)."""

    def by_reference(indices: str) -> str:
        return " ".join(references[int(i) - 1] for i in indices.split())

    structure = ET.Element("ModelStructure")
    extra = list(array_references().values())
    for section, tag in (("Outputs", "Output"), ("InitialUnknowns", "InitialUnknown")):
        node = root2.find(f"ModelStructure/{section}")
        unknowns = node.findall("Unknown") if node is not None else []
        first = unknowns[0].get("dependencies", "") if unknowns else ""
        for unknown in unknowns:
            attributes = {"valueReference": references[int(unknown.attrib["index"]) - 1]}
            if "dependencies" in unknown.attrib:
                attributes["dependencies"] = by_reference(unknown.attrib["dependencies"])
            ET.SubElement(structure, tag, attributes)
        for vr in extra:  # the arrays depend on what theta depends on
            ET.SubElement(structure, tag, valueReference=str(vr), dependencies=by_reference(first))
    return structure


def to_fmi3(model_description: str, token: str) -> str:
    """The FMI 3.0 modelDescription.xml of the FMI 2.0 form rendered from the template for FMI 3.0
    (interface.render with fmi_version=3)."""
    root2 = ET.fromstring(model_description)
    attributes = {k: v for k, v in root2.attrib.items() if k not in ("guid", "numberOfEventIndicators")}
    attributes.update(fmiVersion="3.0", instantiationToken=token)
    root3 = ET.Element("fmiModelDescription", attributes)
    cosim2 = root2.find("CoSimulation")
    identifier = cosim2.attrib["modelIdentifier"] if cosim2 is not None else "FemPendulum"
    ET.SubElement(root3, "CoSimulation", {"modelIdentifier": identifier, **CAPABILITIES})
    _copy_units(root2, root3)
    root3.append(_type_definitions(root2))
    for section in ("LogCategories", "DefaultExperiment"):
        node = root2.find(section)
        if node is not None:
            root3.append(node)
    variables = ET.SubElement(root3, "ModelVariables")
    scalars = root2.findall("ModelVariables/ScalarVariable")
    for scalar in scalars:
        variables.append(_variable(scalar))
    _extra_variables(variables)
    root3.append(_model_structure(root2, [s.attrib["valueReference"] for s in scalars]))
    text = minidom.parseString(ET.tostring(root3, encoding="unicode")).toprettyxml(indent="  ")
    return "\n".join(line for line in text.splitlines() if line.strip()) + "\n"
