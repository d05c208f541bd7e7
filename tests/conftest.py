"""Shared fixtures: the FMUs are built once per test session, into a temporary folder."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def fmus(tmp_path_factory) -> tuple[Path, Path]:
    """(FemPendulum.fmu, PidController.fmu) built by `fem-pendulum build` as a user would run it."""
    out = tmp_path_factory.mktemp("dist")
    run = subprocess.run([str(Path(sys.executable).parent / "fem-pendulum"), "build", "--output", str(out / "FemPendulum.fmu")],
                         cwd=out, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.split() == [str(out / "FemPendulum.fmu"), str(out / "PidController.fmu")]
    return out / "FemPendulum.fmu", out / "PidController.fmu"
