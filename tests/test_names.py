"""One name for one thing (physics/names.py): the FMU's names in Python, each '.' written '_', and the
names used before that rule still working, each with a DeprecationWarning."""

import dataclasses

import pytest

import fem_pendulum_fmu
from fem_pendulum_fmu.fmi import interface
from fem_pendulum_fmu.physics import scene
from fem_pendulum_fmu.physics.names import OLD_OUTPUT_NAMES, python_name
from fem_pendulum_fmu.physics.protocol import CONTINUOUS_OUTPUTS, SUMMARY_OUTPUTS, OutputDerivatives, Outputs

FIELDS = [f.name for f in dataclasses.fields(Outputs)]
PYTHON_ONLY = {"time", "contact_hold"}  # the FMU's time is its own; the hold steers the steps, it is no output


def test_every_fmu_output_is_the_outputs_field_of_its_name_and_back():
    outputs = [v.name for v in interface.load().of_causality("output")]
    assert {name: python_name(name) for name in outputs} == interface.OUTPUT_FIELDS
    assert all(python_name(name) in FIELDS for name in outputs)
    by_field = {python_name(name): name for name in outputs}
    assert len(by_field) == len(outputs)  # the rule names no two outputs alike
    assert {f for f in FIELDS if f not in by_field} == PYTHON_ONLY
    assert set(CONTINUOUS_OUTPUTS) | set(SUMMARY_OUTPUTS) == set(FIELDS) - {"time"}


def test_every_fmu_parameter_of_the_scene_is_a_preset_keyword_by_the_rule():
    parameters = [v for v in interface.load().of_causality("parameter") if v.name in scene.scene_names()]
    assert len(parameters) >= 20
    for var in parameters:
        value = var.items[0] if var.items else var.start
        made = scene.steel(**{python_name(var.name): value})
        assert scene.get_path(made, var.name) == value, var.name
    with pytest.raises(KeyError, match="pendulum_X"):
        scene.steel(pendulum_X=1.0)


@pytest.mark.parametrize(("old", "new"), OLD_OUTPUT_NAMES.items())
def test_an_old_outputs_name_reads_the_new_field_with_a_deprecation_warning(old, new):
    out = Outputs(**{new: 7})
    with pytest.warns(DeprecationWarning, match=f"'{old}' is deprecated: it is now '{new}'"):
        assert getattr(out, old) == 7
    with pytest.raises(AttributeError):
        setattr(out, old, 8)  # read-only: the field is the one name to write
    with pytest.warns(DeprecationWarning, match=f"'{old}'"):
        assert Outputs(**{old: 9}) == Outputs(**{new: 9})
    with pytest.warns(DeprecationWarning, match=f"'{old}'"):
        assert out.as_dict()[old] == 7
    assert old in out.as_dict() and old not in out.as_dict().keys()  # indexable, not listed


def test_the_output_derivatives_answer_the_old_names_with_a_deprecation_warning():
    d = OutputDerivatives(0.0, {"energy_total": 1.0}, {"energy_total": 2.0})
    with pytest.warns(DeprecationWarning, match="'total'"):
        assert d.of("total", 2) == 2.0
    with pytest.warns(DeprecationWarning, match="'total'"):
        assert d.first["total"] == 1.0
    with pytest.raises(KeyError):
        d.of("nothing", 1)


def test_the_presets_are_steel_and_rubber_and_the_old_names_warn():
    assert sorted(scene.PRESETS) == ["rubber", "steel"]
    assert scene.PRESETS["steel"]() == scene.Scene()
    assert scene.rubber().pendulum.E == 1e6
    for old, new in (("stiff", scene.steel), ("compliant", scene.rubber)):
        with pytest.warns(DeprecationWarning, match=f"preset '{old}' is deprecated"):
            assert scene.PRESETS[old] is new
        with pytest.warns(DeprecationWarning, match=f"preset '{old}' is deprecated"):
            assert getattr(fem_pendulum_fmu, old)(theta0=0.1) == new(theta0=0.1)
    with pytest.raises(KeyError):
        scene.PRESETS["soft"]


def test_the_old_keyword_form_warns_and_the_dotted_form_is_kept():
    with pytest.warns(DeprecationWarning, match="'pendulum__E' is deprecated: it is now 'pendulum_E'"):
        assert scene.steel(pendulum__E=1e9) == scene.steel(pendulum_E=1e9)
    assert scene.steel(**{"pendulum.E": 1e9}) == scene.steel(pendulum_E=1e9)
