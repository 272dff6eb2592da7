"""The ``contactrig`` command: a thin dispatcher over functions a notebook can call.

Each package registers its own subcommands in ``<package>/commands.py`` (``register(subparsers)``); those
modules import nothing heavy at module level, so ``contactrig --help`` starts fast and a command that needs no
instrument never imports pyvisa, and none imports matplotlib until a figure is drawn.

One exit-code contract for every command: 0 done, 1 stopped early (Ctrl-C, however often it is pressed, or the
operator's ``q``; also a Ctrl-C during the command's start, taken by :mod:`contactrig` before the heavy
imports), 2 error. Errors a user can act on (bad settings, unreadable files, instrument faults) print one
line, with control characters from files escaped, and exit 2; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType
from typing import NoReturn

_COMMAND_MODULES = (
    "contactrig.cli.scene",
    "contactrig.cli.instruments",
    "contactrig.cli.database",
    "contactrig.cli.simulate",
    "contactrig.cli.sessions",
    "contactrig.cli.analysis",
    "contactrig.cli.bench",
    "contactrig.cli.design",
    "contactrig.cli.compare",
    "contactrig.cli.live",
    "contactrig.cli.surface",
    "contactrig.cli.console",
)


class _OneLineErrors(argparse.ArgumentParser):
    """argparse, but a usage error is one line (``contactrig acquire: error: …``) and exit 2, like every other error."""

    def error(self, message: str) -> NoReturn:
        from contactrig.core.text import bound_error_line, escape_terminal

        self.exit(2, f"{self.prog}: error: {bound_error_line(escape_terminal(message))} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (every package's subcommands)."""
    parser = _OneLineErrors(
        prog="contactrig",
        description="Piston/liner contact area by electrical contact resistance: bench, simulation, analysis.",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks instead of one-line errors")
    from contactrig.core.provenance import software_version  # numpy: after main() has taken charge of Ctrl-C

    parser.add_argument("--version", action="version", version=f"%(prog)s {software_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_OneLineErrors)
    for name in _COMMAND_MODULES:
        module = importlib.import_module(name)
        module.register(sub)
    return parser


_interrupted = False


class _StopOnInterrupt:
    """The SIGINT handler of a command: the first Ctrl-C stops it (KeyboardInterrupt); any further one is ignored,
    so that the clean-up and the exit code of a stopped command (1) cannot be cut short.

    ``stop_requested`` stays True after the first Ctrl-C, also if some library swallowed the KeyboardInterrupt (a
    bare ``except:`` in an import): acquisition installs its own policy while blocks run
    (:class:`daq.engine.Interrupts`), which takes such an earlier Ctrl-C as "stop before the next block"."""

    def __init__(self) -> None:
        self.stop_requested = False

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        self.stop_requested = True
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        raise KeyboardInterrupt


def _one_line(exc: BaseException) -> str:
    """The error as one line of bounded length (a huge offending value is quoted by its start and its length)."""
    from contactrig.core.text import bound_error_line, escape_terminal

    return bound_error_line(escape_terminal(str(exc)))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``contactrig`` console script; returns the exit code."""
    if threading.current_thread() is not threading.main_thread():  # signal handlers belong to the main thread
        return _main(argv)
    from contactrig import EARLY_CTRL_C  # installed at the package's import when this process is the command

    previous = signal.signal(signal.SIGINT, _StopOnInterrupt())
    try:
        code = _stopped_early() if EARLY_CTRL_C.pressed else _main(argv)
    finally:
        if argv is None:  # the process' entry point: a Ctrl-C from now on must not turn the exit code into −2/130
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        else:  # called from Python (tests, notebooks): leave SIGINT as it was
            signal.signal(signal.SIGINT, previous)
    if argv is None and _interrupted:
        # A Ctrl-C that lands while an extension module is being imported can leave CPython's "unhandled
        # KeyboardInterrupt" flag set even though we handled it, and the interpreter then kills itself with SIGINT
        # on the way out (exit −2). Everything is closed by now: leave with the documented code instead.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


def _stopped_early() -> int:
    """A Ctrl-C before the command's handler was in place (:data:`contactrig.EARLY_CTRL_C`): stopped, exit 1."""
    global _interrupted
    _interrupted = True
    print("contactrig: interrupted (Ctrl-C): stopped early", file=sys.stderr)
    return 1


def _main(argv: Sequence[str] | None) -> int:
    args: argparse.Namespace | None = None
    try:
        parser = build_parser()  # imports every command module: a Ctrl-C may land here too
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # usage errors (one line, exit 2), --help/--version (0): returned like any code
            return exc.code if isinstance(exc.code, int) else 2
        handler = getattr(args, "handler", None)
        if handler is None:
            parser.print_help()
            return 2
        from contactrig.core.budget import memory_limit

        with memory_limit(getattr(args, "max_memory", None)):  # --max-memory, on the commands that simulate
            return int(handler(args) or 0)
    except KeyboardInterrupt:
        global _interrupted
        _interrupted = True
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C while saying so changes nothing
        name = f"contactrig {args.command}" if args is not None else "contactrig"
        print(f"{name}: interrupted (Ctrl-C): stopped early", file=sys.stderr)
        return 1
    except BrokenPipeError:
        # output piped into a reader that stopped early (| head): not an error of ours
        sys.stderr.close()
        return 141
    except (ValueError, OSError, RuntimeError, TimeoutError) as exc:
        if args is None or args.debug:
            raise
        print(f"contactrig {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
