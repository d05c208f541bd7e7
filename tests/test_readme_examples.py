"""The README's Python examples run as written (as scikit-fem's tests/test_examples.py runs its examples).

Each ```python block of README.md runs as a script in a fresh interpreter, in a folder where
`dist/FemPendulum.fmu` exists (the session's build), and must exit 0 and print what it promises.
A new block needs an entry in CHECKS: the test fails on a block it does not know.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)


def python_blocks(text: str) -> list[str]:
    return BLOCK.findall(text)


def _numbers(stdout: str) -> list[float]:
    return [float(word) for word in stdout.split()]


def check_fmpy_api(stdout: str) -> None:
    # theta at 1 s and the smallest gap, released from 15 deg against the rigid wall
    theta, gap_min = _numbers(stdout)
    # measured: theta(1 s) = 0.2447 rad, gap_min = -2.09e-5 m (21 um penetration at the impact)
    assert abs(theta) <= math.radians(15.0) * 1.001  # no torque: never beyond the release angle
    assert -1e-4 < gap_min < 0.0  # it reaches the wall, and the stiff penalty keeps it within 0.1 mm


def check_physics(stdout: str) -> None:
    # theta at 0.5 s of the rubber pendulum released at 20 deg, and its energy less the torque's work
    theta, energy = _numbers(stdout)
    assert abs(theta) <= math.radians(20.0) * 1.001  # no torque: never beyond the release angle
    from fem_pendulum_fmu.physics.fidelity import create
    from fem_pendulum_fmu.physics.scene import compliant

    start = create(compliant(**{"wall.kind": "rigid"})).outputs().total
    # energy-consistent through the impact: measured |E - E0 - W| = 4e-14 J over 0.5 s (E0 = -0.2328 J);
    # the bound leaves room for the Newton tolerance on another machine's arithmetic
    assert abs(energy - start) < 1e-9 * abs(start)


# a word that identifies a block -> the check of its output
CHECKS: dict[str, Callable[[str], None]] = {
    "simulate_fmu(": check_fmpy_api,
    "from fem_pendulum_fmu import compliant, create": check_physics,
}


def test_the_readme_has_python_examples():
    blocks = python_blocks((ROOT / "README.md").read_text())
    assert len(blocks) >= 2
    for block in blocks:
        assert sum(key in block for key in CHECKS) == 1, f"no check (or several) for this README block:\n{block}"


@pytest.mark.slow  # measured under load: the fmpy example 31 s, the physics example 58 s (18 s of CPU)
@pytest.mark.parametrize("index", range(len(python_blocks((ROOT / "README.md").read_text()))))
def test_readme_example_runs(index, fmus, tmp_path):
    block = python_blocks((ROOT / "README.md").read_text())[index]
    (tmp_path / "dist").mkdir()
    (tmp_path / "dist" / "FemPendulum.fmu").symlink_to(fmus[0])
    script = tmp_path / "example.py"
    script.write_text(block)
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"README example {index} failed:\n{block}\n{run.stderr[-3000:]}"
    for key, check in CHECKS.items():
        if key in block:
            check(run.stdout)


SHELL_BLOCK = re.compile(r"^```bash\n(.*?)^```", re.MULTILINE | re.DOTALL)


def test_readme_fmpy_command_runs_to_its_end(fmus, tmp_path):
    """The README's fmpy command line, as written, in a folder laid out as a clean clone after the main
    job (.venv, dist/, examples/): it must exit 0, say nothing of a Discard, and write out.csv up to
    the modelDescription's stop time of 2 s, the pendulum reaching the wall on the way (measured:
    gap_min -2.0e-5 m, 4.5 s wall time)."""
    (block,) = [b for b in SHELL_BLOCK.findall((ROOT / "README.md").read_text()) if "fmpy simulate" in b]
    (tmp_path / "dist").mkdir()
    (tmp_path / "dist" / "FemPendulum.fmu").symlink_to(fmus[0])
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    (tmp_path / ".venv").symlink_to(Path(sys.prefix))
    run = subprocess.run(["bash", "-ec", block], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0 and "[DISCARD]" not in run.stdout, run.stdout[-2000:] + run.stderr[-2000:]
    import csv

    with open(tmp_path / "out.csv") as f:
        rows = list(csv.DictReader(f))
    assert abs(float(rows[-1]["time"]) - 2.0) < 1e-9
    assert min(float(row["gap_min"]) for row in rows) < 0.0
