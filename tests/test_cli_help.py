"""Every option of every `fem-pendulum` subcommand has help text, and its help shows the defaults
worth showing (cli.py DefaultsHelp)."""

from __future__ import annotations

import argparse

from fem_pendulum_fmu.cli import parser


def subcommands() -> dict[str, argparse.ArgumentParser]:
    top = parser()
    (sub,) = [a for a in top._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(sub.choices)


def test_every_option_has_help_text():
    missing = [
        f"{name} {action.option_strings[0]}"
        for name, verb in subcommands().items()
        for action in verb._actions
        if action.option_strings and not action.help
    ]
    assert missing == []


def test_help_shows_defaults_but_not_empty_ones():
    text = subcommands()["run"].format_help()
    assert "(default: 2.0)" in text and "(default: 0.001)" in text and "(default: out/run)" in text
    assert "(default: None)" not in text and "(default: [])" not in text and "(default: False)" not in text
