"""The controller test files of examples/ run under pytest as a user runs them: the fixture
`pendulum_loop` comes from the installed package's pytest plugin (entry point pytest11), the passing
file passes, and the failing one fails with the message docs/guide/controller_testing.md shows."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


def run_pytest(example: str, fmus, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    """pytest on one example file, in a copy of examples/ (no conftest, no -p: the plugin loads itself)."""
    folder = tmp_path / "examples"
    folder.mkdir()
    (folder / example).write_text((EXAMPLES / example).read_text())
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(folder / example),
           "--pendulum-fmu", str(fmus[0]), "--rootdir", str(tmp_path)]  # fmt: skip
    return subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)


@pytest.mark.slow
def test_the_users_controller_tests_pass(fmus, tmp_path):
    run = run_pytest("test_my_controller.py", fmus, tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    assert re.search(r"\b2 passed\b", run.stdout), run.stdout


@pytest.mark.slow
def test_the_aggressive_controller_fails_with_the_message_the_docs_show(fmus, tmp_path):
    run = run_pytest("test_aggressive_controller.py", fmus, tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    said = [line[2:].strip() for line in run.stdout.splitlines() if line.startswith("E ")]
    assert said[0].endswith("LoopCheckFailed: 3 of 3 loop checks failed:"), said
    checks = said[1:4]
    assert [line.split(" = ")[0] for line in checks] == ["rms_error", "max_contact_force", "impacts"], checks
    assert all("above the bound" in line for line in checks), checks
    assert "def assert_loop" not in run.stdout  # pytest hides the library's frames
    docs = (ROOT / "docs" / "guide" / "controller_testing.md").read_text()
    for line in checks:
        assert line in docs, line
