"""The one declaration of the interface (modelDescription.template.xml) against everything derived from it."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from fem_pendulum_fmu.fmi import interface
from fem_pendulum_fmu.fmi.interface import ENUM_ALIASES, FMU_ONLY_PARAMETERS, OUTPUT_FIELDS, scene_from_values
from fem_pendulum_fmu.fmi.slave import PendulumSlave
from fem_pendulum_fmu.physics.protocol import Outputs
from fem_pendulum_fmu.physics.scene import FIDELITIES, WALL_KINDS, Scene, get_path

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = ROOT / interface.TEMPLATE_NAME

# names, causalities, types and units are a contract with masters and scripts, which address variables by name:
# this table writes the contract out on its own, so that a change to the template shows here
CONTRACT = {
    "torque": ("input", "Real", "N.m"),
    "theta": ("output", "Real", "rad"),
    "omega": ("output", "Real", "rad/s"),
    "gap": ("output", "Real", "m"),
    "contact_force": ("output", "Real", "N"),
    **{
        f"energy.{e}": ("output", "Real", "J")
        for e in ("kinetic", "potential", "strain", "contact", "total", "torque_work")
    },
    "stress.von_mises_max": ("output", "Real", "Pa"),
    "solver.substeps": ("output", "Integer", None),
    "theta0": ("parameter", "Real", "rad"),
    "omega0": ("parameter", "Real", "rad/s"),
    "pendulum.E": ("parameter", "Real", "Pa"),
    "pendulum.nu": ("parameter", "Real", None),
    "pendulum.rho": ("parameter", "Real", "kg/m3"),
    "pendulum.thickness": ("parameter", "Real", "m"),
    "wall.kind": ("parameter", "Enumeration", None),
    "wall.E": ("parameter", "Real", "Pa"),
    "wall.nu": ("parameter", "Real", None),
    "wall.rho": ("parameter", "Real", "kg/m3"),
    "contact.stiffness": ("parameter", "Real", "Pa/m"),
    "gravity": ("parameter", "Real", "m/s2"),
    "model.fidelity": ("parameter", "Enumeration", None),
    "model.mesh_size": ("parameter", "Real", "m"),
    "model.order": ("parameter", "Integer", None),
    "model.compute_stress": ("parameter", "Boolean", None),
    "solver.max_step": ("parameter", "Real", "s"),
    "solver.tolerance": ("parameter", "Real", None),
}


def test_the_design_contract_is_declared():
    ifc = interface.load()
    for name, (causality, typ, unit) in CONTRACT.items():
        v = ifc.by_name(name)
        assert (v.causality, v.type, v.unit) == (causality, typ, unit), name
    assert ifc.by_name("theta").display_unit == "deg" and ifc.by_name("theta0").display_unit == "deg"
    extra = {v.name for v in ifc.variables} - set(CONTRACT)
    assert extra == {
        "model.threads",
        "wall.kind_index",
        "model.fidelity_index",
        "model.modes",
        "solver.max_substeps",
        "solver.scheme",
        "gap_min",
        "contact_force_max",
        "contact_impulse",
        "output.vtk_folder",
        "output.vtk_interval",
    }
    assert [v.value_reference for v in ifc.variables] == list(range(len(ifc.variables)))


def test_template_and_slave_register_the_same_variables():
    ifc = interface.load()
    slave = PendulumSlave(instance_name="check", resources=str(ROOT))
    assert list(slave.vars.keys()) == [v.value_reference for v in ifc.variables]
    for v in ifc.variables:
        registered = slave.vars[v.value_reference]
        assert registered.name == v.name
        assert registered.causality.name == v.causality and registered.variability.name == v.variability
        assert type(registered).__name__ == {"Enumeration": "Integer"}.get(v.type, v.type)
        if v.start is not None:
            assert registered.getter() == v.start
    assert {v.name for v in ifc.of_causality("output")} == set(OUTPUT_FIELDS)
    assert set(OUTPUT_FIELDS.values()) <= set(Outputs.__dataclass_fields__)


def test_start_values_are_the_scene_defaults():
    ifc, scene = interface.load(), Scene()
    for v in ifc.of_causality("parameter"):
        if v.name in ENUM_ALIASES:
            assert v.start == 0  # 0 = the enumeration decides
            continue
        if v.name in FMU_ONLY_PARAMETERS:  # the FMU's field output, not physics: off by default
            assert (v.name, v.start) in {("output.vtk_folder", ""), ("output.vtk_interval", 0.01)}
            continue
        start = v.items[v.start - 1] if v.items else v.start
        assert start == get_path(scene, v.name), v.name
    assert ifc.by_name("wall.kind").items == WALL_KINDS
    assert ifc.by_name("model.fidelity").items == FIDELITIES
    # the Integer alternatives' descriptions spell out the same numbering
    for alias, target in ENUM_ALIASES.items():
        description = ifc.by_name(alias).description
        for number, item in enumerate(ifc.by_name(target).items, 1):
            assert f"{number} {item}" in description


def test_the_scene_the_slaves_parameters_describe():
    slave = PendulumSlave(instance_name="check", resources=str(ROOT))
    assert scene_from_values(slave.values) == Scene()
    slave.values.update({"pendulum.E": 1e6, "wall.kind": 3, "model.fidelity": 2, "model.compute_stress": True})
    scene = scene_from_values(slave.values)
    assert (scene.pendulum.E, scene.wall.kind, scene.model.fidelity, scene.model.compute_stress) == (
        1e6,
        "none",
        "rigid",
        True,
    )
    slave.values.update({"wall.kind_index": 1, "model.fidelity_index": 4})  # an explicit Integer setting wins
    scene = scene_from_values(slave.values)
    assert (scene.wall.kind, scene.model.fidelity) == ("rigid", "fem")
    slave.values["wall.kind"] = 7
    slave.values["wall.kind_index"] = 0
    with pytest.raises(ValueError, match=r"wall.kind = 7 is not allowed: choose one of 1 \(rigid\)"):
        scene_from_values(slave.values)


def test_the_scene_a_masters_partial_values_describe():
    """A sweep's values: some parameters only, enumerations by item name, the FMU-only ones left out."""
    values = {"theta0": 0.3, "model.fidelity": "rigid", "output.vtk_folder": "out", "output.vtk_interval": 0.05}
    assert scene_from_values(values) == Scene().with_values({"theta0": 0.3, "model.fidelity": "rigid"})
    assert scene_from_values({"model.fidelity": "rigid", "model.fidelity_index": 3}).model.fidelity == "reduced"
    with pytest.raises(ValueError, match="model.fidelity = 'wood' is not allowed: choose one of auto"):
        scene_from_values({"model.fidelity": "wood"})
    with pytest.raises(ValueError, match="theta is not a parameter"):
        scene_from_values({"theta": 0.1})


def test_template_is_complete_fmi():
    root = ET.parse(TEMPLATE).getroot()
    units = {u.get("name") for u in root.iter("Unit")}
    assert units == {"rad", "rad/s", "N.m", "m", "N", "N.s", "J", "Pa", "s", "kg/m3", "Pa/m", "m/s2"}
    cs = root.find("CoSimulation").attrib
    for flag in ("canHandleVariableCommunicationStepSize", "canGetAndSetFMUstate", "canSerializeFMUstate"):
        assert cs[flag] == "true"
    assert root.find("DefaultExperiment").attrib == {"startTime": "0.0", "stopTime": "2.0", "stepSize": "0.001"}
    variables = root.find("ModelVariables").findall("ScalarVariable")
    for sv in variables:
        assert len(sv.get("description", "")) > 10, sv.get("name")
        unit = sv[0].get("unit")
        assert unit is None or unit in units
    outputs = [str(i) for i, sv in enumerate(variables, 1) if sv.get("causality") == "output"]
    structure = root.find("ModelStructure")
    assert [u.get("index") for u in structure.find("Outputs")] == outputs
    assert [u.get("index") for u in structure.find("InitialUnknowns")] == outputs
    for placeholder in ("{{GUID}}", "{{DATE}}", "{{VERSION}}"):
        assert placeholder in TEMPLATE.read_text()
        assert placeholder not in interface.render("g", "d", "v")


def test_readme_variable_table_is_generated_from_the_template():
    text = (ROOT / "docs" / "reference" / "interface.md").read_text()
    start, end = "<!-- interface-table:start -->", "<!-- interface-table:end -->"
    table = text[text.index(start) + len(start) : text.index(end)].strip()
    assert table == interface.markdown_table().strip()
    printed = subprocess.run(
        [str(Path(sys.executable).parent / "fem-pendulum"), "interface", "--markdown"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    assert printed.strip() == table
