"""The ``contactrig`` command tree, walked from the real parser: the tests over every subcommand (option
vocabulary, ``--json`` schemas) share this one walk."""

from __future__ import annotations

import argparse


def subcommand_parsers(parser: argparse.ArgumentParser, prefix: str = "") -> dict[str, argparse.ArgumentParser]:
    """Every subcommand's parser by its full name (``"instruments delta"``), sub-subcommands included."""
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out[f"{prefix}{name}"] = sub
                out.update(subcommand_parsers(sub, f"{prefix}{name} "))
    return out
