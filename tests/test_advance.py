"""advance documented where help() looks (each fidelity's, from the protocol) and its torque 0 by default."""

import inspect

import pytest

import fem_pendulum_fmu
from fem_pendulum_fmu import create, steel


@pytest.mark.parametrize("fidelity", ["rigid", "reduced", "fem"])
def test_advance_without_a_torque_is_advance_with_torque_zero(fidelity):
    scene = steel(model_fidelity=fidelity, model_mesh_size=0.06)
    quiet, zero = create(scene), create(scene)
    for k in range(1, 4):
        assert quiet.advance(k * 1e-2) == zero.advance(k * 1e-2, torque=0.0)
    assert inspect.signature(quiet.advance).parameters["torque"].default == 0.0


@pytest.mark.parametrize("fidelity", ["rigid", "reduced", "fem"])
def test_help_of_each_fidelitys_advance_says_t_end_is_absolute(fidelity):
    doc = inspect.getdoc(create(steel(model_fidelity=fidelity, model_mesh_size=0.06)).advance)
    assert "absolute time `t_end`" in doc
    assert all(section in doc for section in ("Parameters\n---", "Returns\n---", "Raises\n---"))


def test_the_public_functions_have_numpydoc_sections():
    for name in ("create", "steel", "validate"):
        doc = inspect.getdoc(getattr(fem_pendulum_fmu, name))
        assert all(section in doc for section in ("Parameters\n---", "Returns\n---", "Raises\n---")), name
    for method in ("advance", "output_derivatives", "outputs", "get_state", "set_state", "fields"):
        assert "\n---" in inspect.getdoc(getattr(fem_pendulum_fmu.PendulumModel, method)), method
