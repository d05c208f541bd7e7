"""MkDocs hook: the command-line reference shows the help the installed `fem-pendulum` prints.

docs/reference/cli.md holds a line `<!-- fem-pendulum-help COMMAND -->` for each subcommand (and one
without a command for `fem-pendulum --help`). At build time each becomes that help text, so the page
follows the code; a marker naming a command that no longer exists fails the build.
"""

from __future__ import annotations

import argparse
import os
import re
from typing import Any

MARKER = re.compile(r"^<!-- fem-pendulum-help(?: (\S+))? -->$", re.MULTILINE)
WIDTH = "100"  # columns of the help text, whatever the terminal the build runs in


def help_text(command: str | None) -> str:
    """`fem-pendulum [COMMAND] --help`, as argparse formats it."""
    from fem_pendulum_fmu.cli import parser

    top = parser()
    if command is None:
        return top.format_help()
    (verbs,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    if command not in verbs.choices:
        raise ValueError(f"docs/reference/cli.md: fem-pendulum has no command {command!r}")
    return verbs.choices[command].format_help()


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    """Replace every marker of the page by its help text in a code block."""
    if MARKER.search(markdown) is None:
        return markdown
    saved = {name: os.environ.get(name) for name in ("COLUMNS", "NO_COLOR")}
    os.environ.update(COLUMNS=WIDTH, NO_COLOR="1")
    try:
        return MARKER.sub(lambda m: "```text\n" + help_text(m.group(1)).rstrip() + "\n```", markdown)
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
