"""The FMU in Python hosts as users run it: fmpy's command line, several runs and FMUs in one process,
an environment that lacks the FMU's packages, and a run that starts from a saved state.

Every process here must exit normally with 0: pythonfmu's binary alone made
hosts crash at exit and broke a second run in the same process (docs/notes/fmu_layer.md).
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
import re
import subprocess
import sys
import venv
from pathlib import Path
from typing import Any

import numpy as np
import pytest

FMPY = str(Path(sys.executable).parent / "fmpy")
HOST_RUNS = Path(__file__).resolve().parent / "host_runs.py"


def host_run(verb: str, *args: object) -> Any:
    """What tests/host_runs.py VERB prints, run in a fresh interpreter that must exit with 0."""
    run = subprocess.run([sys.executable, str(HOST_RUNS), verb, *map(str, args)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", [None, "2"], ids=["fem-default", "rigid"])
def test_fmpy_command_line_exits_cleanly_every_time(fmus, tmp_path, fidelity):
    fmu, _ = fmus
    start = ["--start-values", "model.fidelity", fidelity] if fidelity else []
    codes, ends = [], []
    for k in range(20):
        out = tmp_path / f"run{k}.csv"
        run = subprocess.run(
            [FMPY, "simulate", str(fmu), "--stop-time", "0.02", "--output-file", str(out), *start],
            capture_output=True,
            text=True,
        )
        codes.append(run.returncode)
        assert run.returncode == 0, run.stderr[-3000:]
        ends.append(np.genfromtxt(out, delimiter=",", names=True)["theta"][-1])
    assert codes == [0] * 20
    assert len(set(ends)) == 1  # and every run computed the same


def test_every_fidelity_in_turn_then_both_fmus_in_one_process(fmus):
    """fmpy deletes each run's extraction folder; the next run, of another fidelity, still imports."""
    ends = host_run("sequence", fmus[0], fmus[1])
    assert list(ends) == ["0:2", "1:3", "2:4", "3:2", "loop"]
    assert ends["0:2"] == ends["3:2"]  # the same run gives the same result after the others
    assert 0.30 < ends["2:4"] < 0.35 and abs(ends["1:3"] - ends["2:4"]) < 1e-4  # released at 0.349 rad
    assert ends["loop"] != ends["0:2"]  # the controller's torque moved the pendulum


def fmpy_only_environment(folder: Path) -> Path:
    """A virtual environment holding fmpy and what it requires (linked from this one), nothing else."""
    venv.create(folder, with_pip=False)
    site = Path(
        subprocess.run(
            [str(folder / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.strip()
    )
    seen, todo = set(), [("fmpy", "")]
    while todo:
        name, marker = todo.pop()
        try:
            dist = importlib.metadata.distribution(name.replace("-", "_"))
        except importlib.metadata.PackageNotFoundError:
            assert marker, f"{name}, which fmpy needs, is not installed here"
            continue  # a requirement for another platform (e.g. pywin32)
        if dist.metadata["Name"].lower() in seen:
            continue
        seen.add(dist.metadata["Name"].lower())
        for requirement in dist.requires or []:
            if "extra ==" not in requirement:
                name = re.match(r"[A-Za-z0-9_.\-]+", requirement).group(0)
                todo.append((name, requirement.partition(";")[2]))
        for file in dist.files or []:
            top = file.parts[0]
            source, target = Path(dist.locate_file(top)), site / top
            if top != ".." and source.exists() and not target.exists():
                target.symlink_to(source)
    assert "ngsolve" not in seen and "scipy" not in seen
    return folder / "bin" / "python"


def test_missing_packages_are_named_with_the_install_command(fmus, tmp_path):
    fmu, _ = fmus
    python = fmpy_only_environment(tmp_path / "venv")
    run = subprocess.run(
        [str(python), "-m", "fmpy", "simulate", str(fmu), "--stop-time", "0.01"],
        capture_output=True,
        text=True,
        env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"},
    )
    assert run.returncode != 0
    error = [line for line in run.stdout.splitlines() if line.startswith("[ERROR]")]
    assert error, run.stdout + run.stderr[-2000:]
    assert "ngsolve is not installed" in error[0] and "scipy is not installed" in error[0]
    assert f"{python} -m pip install" in error[0] and '"ngsolve>=' in error[0]


def host_output(verb: str, *args: object) -> tuple[Any, str]:
    """(the JSON of tests/host_runs.py VERB, everything else it printed), from a fresh interpreter that must
    exit with 0."""
    run = subprocess.run([sys.executable, str(HOST_RUNS), verb, *map(str, args)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    *printed, last = run.stdout.strip().splitlines()
    return json.loads(last), "\n".join(printed)


def test_an_fmu_refuses_to_run_another_copy_of_its_package_already_imported(fmus, tmp_path):
    """Python keeps one module per name: an FMU in a host that has imported fem_pendulum_fmu from elsewhere
    would run that copy's code. A copy with other contents is refused with both named; an identical one runs."""
    fmu, _ = fmus
    same, _ = host_output("foreign", fmu, tmp_path / "same", "same")
    assert same["instantiated"] and math.isfinite(same["theta"])
    changed, printed = host_output("foreign", fmu, tmp_path / "changed", "changed")
    assert not changed["instantiated"]
    assert "already imported fem_pendulum_fmu from" in printed and str(tmp_path / "changed") in printed
    assert "physics/scene.py" in printed


@pytest.mark.parametrize("fidelity", [4, 2], ids=["fem", "rigid"])
def test_a_fresh_instance_started_from_a_saved_state_continues_bit_identically(fmus, tmp_path, fidelity):
    fmu, _ = fmus
    blob = tmp_path / "state.bin"
    original = host_run("original", fmu, blob, fidelity)
    restored = host_run("restored", fmu, blob, fidelity)
    assert restored == original
    assert original[0] != original[-1]  # it moved


def test_fmu_states_a_host_gets_wrong_are_refused_not_dereferenced(fmus):
    """fmi2OK 0, fmi2Error 3: a state the FMU never handed out is refused; the state passed where its
    address is due (a host bug that crashed pythonfmu's binary) is freed; a freed pointer reads NULL."""
    codes = host_run("misuse", fmus[0])
    assert codes == {
        "set_bogus": 3,
        "free_state_itself": 0,
        "set_freed": 3,
        "free_null": 0,
        "free_kept": 0,
        "freed_pointer_is_null": True,
    }
