"""contactrig's shared layers: ``contactrig.core`` (below every package) and ``contactrig.cli`` (above them all).

This package imports nothing of ours, so ``import contactrig.core.validation`` from ``sims`` or ``instruments`` pulls
in neither the CLI nor any other package. The allowed import directions are in README.md, "Architecture", and are
enforced by ``tests/test_architecture.py``.

Ctrl-C from the first moment: this file is the first of ours that the ``contactrig`` command runs (the console
script imports ``contactrig.cli.main``; ``python -m contactrig`` imports this package first). When the process is that
command, a SIGINT handler that only notes the Ctrl-C (:data:`EARLY_CTRL_C`; builtin ``_signal``, no import) is
installed here, before argparse, numpy or any command module is imported, and :func:`contactrig.cli.main.main` leaves
with exit 1 and one line, as for any Ctrl-C. Imported from Python (tests, notebooks) nothing is installed. What no
code of ours can cover is the interpreter's own start, before Python itself takes SIGINT (the process is ended by
the signal, exit −2), and its ``site`` import (Python's "Fatal Python error: init_import_site").
"""

# No ``from __future__ import annotations`` here: it imports the ``__future__`` module (a file read), a window in
# which a Ctrl-C cut this file before its handler was taken (seen once in CI). Nothing below needs it.
# the builtin behind ``signal`` (typeshed has no stub): importing ``signal``, ``typing`` or ``types`` takes milliseconds
import _signal  # type: ignore[import-not-found]


class _EarlyCtrlC:
    """Whether a Ctrl-C came before ``main`` installed the command's own handler (``pressed``)."""

    pressed = False

    def __call__(self, signum: int, frame: object) -> None:
        self.pressed = True  # no exception here: an import cut in half would print a traceback


#: The early SIGINT handler of the ``contactrig`` command (see the module docstring).
EARLY_CTRL_C = _EarlyCtrlC()

# Taken first, before anything else of this file runs (the window in which a Ctrl-C can still cut our code is a class
# statement long), and given back below when this process turns out not to be the command.
try:
    _PREVIOUS = _signal.getsignal(_signal.SIGINT)
    if _PREVIOUS is _signal.default_int_handler:
        _signal.signal(_signal.SIGINT, EARLY_CTRL_C)
    else:
        _PREVIOUS = None  # someone else's handler: left alone
except ValueError:  # imported outside the main thread: signals are not ours to take
    _PREVIOUS = None

import itertools  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402


def _started_as_command() -> bool:
    """This process is the ``contactrig`` command (its console script, or ``python -m contactrig``), not Python code
    that imports the package."""
    script = os.path.basename(sys.argv[0]).lower() if sys.argv else ""
    if script in ("contactrig", "contactrig.exe", "contactrig-script.py"):
        return True
    orig = list(getattr(sys, "orig_argv", ()))
    return any(a == "-m" and b == "contactrig" for a, b in itertools.pairwise(orig))


if _PREVIOUS is not None and not _started_as_command():
    _signal.signal(_signal.SIGINT, _PREVIOUS)
    if EARLY_CTRL_C.pressed:  # a Ctrl-C while Python code imported us: it is that code's, as it would have been
        EARLY_CTRL_C.pressed = False
        raise KeyboardInterrupt
