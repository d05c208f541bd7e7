"""A function of a module of tests/ called in a fresh interpreter, for tests whose FMU work must not run
in pytest's process (a crash takes only the child down; a fresh process loads the FMU anew).

    python tests/in_child.py MODULE FUNCTION ARGS_JSON

imports MODULE (by its file's name), calls FUNCTION(*ARGS) and prints RESULT and the JSON of what it returned
on one line, flushed before the process ends (a crash at exit cannot lose it).
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
RESULT = "RESULT "  # the line of the child's stdout that carries its result


def command(module: str, function: str, *args: Any) -> list[str]:
    """The command line that runs module.function(*args) in a new interpreter (args: JSON values)."""
    return [sys.executable, str(HERE), module, function, json.dumps(args)]


def result(stdout: str) -> Any:
    """What the function returned, from the child's stdout (its last RESULT line)."""
    lines = [line for line in stdout.splitlines() if line.startswith(RESULT)]
    assert lines, stdout[-3000:]
    return json.loads(lines[-1][len(RESULT) :])


def main(argv: list[str]) -> None:
    module, function, args = argv
    returned = getattr(importlib.import_module(module), function)(*json.loads(args))
    print(RESULT + json.dumps(returned), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
