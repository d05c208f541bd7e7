"""A sweep takes the FMU-only parameters (fmi/interface.py, FMU_ONLY_PARAMETERS) as the FMU does, and the
masters load nothing of the slave (fem_pendulum_fmu/fmi/slave.py, which imports pythonfmu).

Short by design: rigid fidelity, 0.1 s, one local worker.
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

import pytest

from fem_pendulum_fmu.fmi.interface import FMU_ONLY_PARAMETERS
from fem_pendulum_fmu.masters.sweep.command import _samples, add_arguments
from fem_pendulum_fmu.masters.sweep.driver import SweepSettings, run_sweep

PACKAGE = Path(__file__).resolve().parents[1] / "fem_pendulum_fmu"
STOP, INTERVAL = 0.1, 0.05


def sweep_samples(*items: str) -> list:
    """The samples of `fem-pendulum sweep ITEMS...`, parsed as the command parses them."""
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return _samples(parser.parse_args(list(items)))


def test_a_sweep_setting_every_fmu_only_parameter_runs_every_sample(fmus, tmp_path):
    assert set(FMU_ONLY_PARAMETERS) == {"output.vtk_folder", "output.vtk_interval"}  # each one is set below
    vtk = tmp_path / "vtk"
    common = ("--set", "model.fidelity=rigid", "--set", f"output.vtk_interval={INTERVAL}")
    chosen = sweep_samples(*common, "--param", "theta0=0.2,0.35", "--set", f"output.vtk_folder={vtk}")
    chosen += sweep_samples(*common, "--param", "theta0=0.3")  # the interval alone: no field output, as the FMU
    settings = SweepSettings(fmu=fmus[0], out=tmp_path / "out", stop_time=STOP, workers=1, progress=False)
    table = run_sweep(chosen, settings)
    assert list(table["status"]) == ["ok"] * 3, list(table["message"])
    assert table["energy_error"].notna().all()
    # each sample with a folder writes its own frames, at 0, 0.05 and 0.1 s, into FOLDER/SAMPLE_ID
    assert sorted(p.name for p in vtk.iterdir()) == sorted(s.sample_id for s in chosen[:2])
    for sample in chosen[:2]:
        index = (vtk / sample.sample_id / "pendulum.pvd").read_text()
        assert index.count("<DataSet") == round(STOP / INTERVAL) + 1, index


def _imports(path: Path) -> set[str]:
    """The fem_pendulum_fmu modules and the other top-level packages `path` imports, anywhere in it."""
    module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = module.rsplit(".", 1)[0] if path.name != "__init__.py" else module.removesuffix(".__init__")
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join([*package.split(".")[: len(package.split(".")) - node.level + 1], *base.split(".")])
                base = base.rstrip(".")
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def _module_file(name: str) -> Path | None:
    parts = name.split(".")
    for candidate in (
        PACKAGE.parent.joinpath(*parts).with_suffix(".py"),
        PACKAGE.parent.joinpath(*parts, "__init__.py"),
    ):
        if candidate.is_file():
            return candidate
    return None


@pytest.mark.parametrize("start", ["masters/sweep/worker.py", "masters/sweep/driver.py", "masters/sweep/command.py"])
def test_the_sweep_loads_nothing_of_the_slave_nor_pythonfmu(start):
    """The package modules the sweep's worker (and the rest of the sweep) can import, followed through the
    package: none is fmi/slave.py, none imports pythonfmu (every Dask worker would load it)."""
    seen: set[Path] = set()
    todo = [PACKAGE / start]
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        names = _imports(path)
        assert not any(name.split(".")[0] == "pythonfmu" for name in names), path
        # a module and the packages above it (their __init__.py run first)
        prefixes = {".".join(name.split(".")[:k]) for name in names for k in range(1, name.count(".") + 2)}
        todo += [file for file in map(_module_file, prefixes) if file is not None]
    assert PACKAGE / "fmi" / "slave.py" not in seen
    assert PACKAGE / "fmi" / "interface.py" in seen  # the one scene_from_values


def test_no_master_imports_the_slave():
    for path in (PACKAGE / "masters").rglob("*.py"):
        assert not any(name.startswith("fem_pendulum_fmu.fmi.slave") for name in _imports(path)), path
