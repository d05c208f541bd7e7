"""The package's flat public API (fem_pendulum_fmu/__init__.py) and the scene's list of problems
(physics/scene.py: problems, validate)."""

import subprocess
import sys

import in_child
import pytest

import fem_pendulum_fmu
from fem_pendulum_fmu.physics import fidelity, protocol, scene


def test_every_public_name_is_the_object_of_its_module():
    modules = {"create": fidelity, "Outputs": protocol, "ModelState": protocol, "Scene": scene}
    for name in fem_pendulum_fmu.__all__:
        assert getattr(fem_pendulum_fmu, name) is not None, name
    for name, module in modules.items():
        assert getattr(fem_pendulum_fmu, name) is getattr(module, name)
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        fem_pendulum_fmu.nothing  # noqa: B018


def test_importing_the_package_loads_no_numpy():
    probe = [sys.executable, "-c", "import sys, fem_pendulum_fmu; print('numpy' in sys.modules)"]
    out = subprocess.run(probe, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def modules_after_a_step(fidelity: str) -> list:
    """In a fresh interpreter (tests/in_child.py): the model's class after a step of the default scene at
    this fidelity, and whether NGSolve and SciPy were imported."""
    model = fem_pendulum_fmu.create(scene.Scene().with_values({"model.fidelity": fidelity}))
    model.advance(0.01, 0.0)
    return [type(model).__name__, "ngsolve" in sys.modules, "scipy" in sys.modules]


def test_a_rigid_model_runs_without_importing_ngsolve_or_scipy():
    # only "auto" asks fidelity_rule.py, which computes the reduced model's modes; a rigid scene named as such
    # needs neither (they were 0.1-0.15 s of the rigid FMU's start-up, docs/notes/latency.md); auto still asks the rule
    def in_a_child(fidelity: str) -> list:
        command = in_child.command("test_public_api", "modules_after_a_step", fidelity)
        return in_child.result(subprocess.run(command, capture_output=True, text=True, check=True).stdout)

    assert in_a_child("rigid") == ["RigidModel", False, False]
    assert in_a_child("auto")[2] is True  # the rule's modes


def test_problems_lists_every_bad_value_and_validate_raises_them_all():
    bad = scene.Scene().with_values({"pendulum.nu": 0.5, "model.fidelity": "exact", "solver.max_substeps": -1})
    found = scene.problems(bad)
    assert len(found) == 3
    assert any("pendulum.nu = 0.5" in p and "[0, 0.5)" in p for p in found)
    assert any("model.fidelity = 'exact'" in p and "auto, rigid, reduced, fem" in p for p in found)
    assert any("solver.max_substeps = -1" in p for p in found)
    with pytest.raises(ValueError, match="3 bad parameters") as info:
        scene.validate(bad)
    assert all(p in str(info.value) for p in found)


def test_a_good_scene_has_no_problems_and_one_bad_value_reads_as_before():
    assert scene.problems(scene.compliant()) == []
    with pytest.raises(ValueError, match=r"^parameter pendulum.E = -1.0 is not allowed"):
        scene.validate(scene.stiff(pendulum__E=-1.0))
