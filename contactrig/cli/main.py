"""The ``contactrig`` command: a thin dispatcher over functions a notebook can call.

Each package registers its own subcommands in ``<package>/commands.py`` (``register(subparsers)``); those
modules import nothing heavy at module level, so ``contactrig --help`` starts fast and a command that needs no
instrument never imports pyvisa, and none imports matplotlib until a figure is drawn.

Errors a user can act on (bad settings, unreadable files, instrument faults) print one line and exit 2;
``--debug`` shows the traceback instead. Ctrl-C exits 130.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import NoReturn

from contactrig.core.provenance import software_version

_COMMAND_MODULES = (
    "contactrig.cli.instruments",
    "contactrig.cli.database",
    "contactrig.cli.simulate",
    "contactrig.cli.sessions",
    "contactrig.cli.analysis",
    "contactrig.cli.bench",
)


class _OneLineErrors(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``contactrig acquire: error: …``) and exit 2, like every other error."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (every package's subcommands)."""
    parser = _OneLineErrors(
        prog="contactrig",
        description="Piston/liner contact area by electrical contact resistance: bench, simulation, analysis.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks instead of one-line errors")
    parser.add_argument("--version", action="version", version=f"%(prog)s {software_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_OneLineErrors)
    for name in _COMMAND_MODULES:
        module = importlib.import_module(name)
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``contactrig`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 2
    try:
        return int(handler(args) or 0)
    except KeyboardInterrupt:
        print("contactrig: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # output piped into a reader that stopped early (| head): not an error of ours
        sys.stderr.close()
        return 141
    except (ValueError, OSError, RuntimeError, TimeoutError) as exc:
        if args.debug:
            raise
        print(f"contactrig {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
