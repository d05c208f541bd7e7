"""The wheel carries the compiled core: installed where there is no C compiler, every fidelity runs it.

The wheel is the one CI built and installed (FEM_PENDULUM_WHEEL, set by .ci/run), or one built here. It is
unpacked into a folder of its own and run in a child process whose PATH holds no compiler and whose
environment has no CC: the core must come from the wheel, as it does on a user's machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from wheel_child import final_theta

ROOT = Path(__file__).resolve().parents[1]
STEPS = 20  # 1 ms steps: every fidelity takes its whole loop (step control, Newton, outputs) on the core
CHILD = Path(__file__).with_name("wheel_child.py")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    given = os.environ.get("FEM_PENDULUM_WHEEL")
    if given:
        return Path(given)
    out = tmp_path_factory.mktemp("wheel")
    build = [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--wheel-dir", str(out), str(ROOT)]
    subprocess.run(build, check=True, capture_output=True, timeout=600)
    return next(out.glob("fem_pendulum_fmu-*.whl"))


def test_the_wheel_is_a_platform_wheel_with_the_core(wheel: Path) -> None:
    tag = wheel.name.removesuffix(".whl").split("-")[-1]
    assert tag.startswith(("linux_", "manylinux")), f"{wheel.name} is not a Linux platform wheel"
    names = zipfile.ZipFile(wheel).namelist()
    assert [n for n in names if n.startswith("fem_pendulum_fmu/physics/core/_femp_core.")], names


def test_every_fidelity_runs_the_wheels_core_without_a_compiler(wheel: Path, tmp_path: Path) -> None:
    target, empty = tmp_path / "site", tmp_path / "bin"
    empty.mkdir()
    install = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", "--target", str(target)]
    subprocess.run([*install, str(wheel)], check=True, capture_output=True, timeout=300)
    env = {k: v for k, v in os.environ.items() if k not in ("CC", "PYTHONPATH")}
    env.update(PATH=str(empty), PYTHONPATH=str(target))
    command = [sys.executable, str(CHILD), str(STEPS)]
    run = subprocess.run(command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    result = json.loads(run.stdout.splitlines()[-1])
    assert Path(result["core"]).resolve().is_relative_to(target.resolve())
    # the same core and data as this process's package: the same bits
    for fidelity, theta in result["thetas"].items():
        assert float.fromhex(theta) == final_theta(fidelity, STEPS), fidelity
