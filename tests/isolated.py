"""A test body run in a fresh interpreter: the @isolated tests of tests/test_fmu.py and tests/test_faults.py.

    python tests/isolated.py MODULE TEST FMU PID_FMU TMP_PATH

imports MODULE (a test module of tests/, by its file's name) and calls TEST.body((FMU, PID_FMU), TMP_PATH);
the test pytest runs asserts that this process exited with 0. One FMU instance per process, so that what
one test loads cannot help or hurt the next.
"""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve()


def isolated(body):
    """Run the test body in a new Python process (one FMU instance per process)."""
    module = Path(inspect.getfile(body)).stem

    def test(fmus, tmp_path):
        args = [module, body.__name__, str(fmus[0]), str(fmus[1]), str(tmp_path)]
        run = subprocess.run([sys.executable, str(HERE), *args], capture_output=True, text=True)
        assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]

    test.body = body
    test.__name__ = body.__name__
    return test


def main(argv: list[str]) -> None:
    module, name, fmu, pid, tmp_path = argv
    test = getattr(importlib.import_module(module), name)
    test.body((Path(fmu), Path(pid)), Path(tmp_path))


if __name__ == "__main__":
    main(sys.argv[1:])
