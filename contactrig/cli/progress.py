"""Progress of long commands on stderr: the one mechanism (issue 20 item 3).

Library functions never print: a function whose work can take more than about two seconds accepts
``progress: Callable[[int, int], None] | None`` and calls it as ``progress(done, total)`` (counts of its own steps:
tasks, plans, models). The command turns that callback into a tqdm bar on stderr with :func:`progress_bar`; the bar
is silent when stderr is not a terminal (a pipe, a log file, a test) or with ``--quiet`` (:func:`add_quiet_option`),
so stdout stays the result alone.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

__all__ = ["ProgressCallback", "add_quiet_option", "progress_bar", "shows_progress"]

#: ``progress(done, total)``: ``done`` of ``total`` steps finished.
ProgressCallback = Callable[[int, int], None]


def add_quiet_option(parser: argparse.ArgumentParser) -> None:
    """The one ``--quiet`` option (``args.quiet``): no progress bar on stderr."""
    parser.add_argument("--quiet", action="store_true", help="no progress bar on stderr (none is drawn off a terminal)")


def shows_progress(quiet: bool, stream: TextIO | None = None) -> bool:
    """Whether a bar is drawn: not ``quiet`` and ``stream`` (default stderr) is a terminal."""
    stream = sys.stderr if stream is None else stream
    if quiet:
        return False
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # a closed or foreign stream: no bar
        return False


@contextmanager
def progress_bar(label: str, *, quiet: bool = False, stream: TextIO | None = None) -> Iterator[ProgressCallback]:
    """A ``progress(done, total)`` callback drawing a tqdm bar labelled ``label`` on ``stream`` (default stderr);
    a callback that does nothing when :func:`shows_progress` says no. The bar is closed on leaving."""
    stream = sys.stderr if stream is None else stream
    if not shows_progress(quiet, stream):
        yield _nothing
        return
    import shutil

    from tqdm import tqdm

    width = shutil.get_terminal_size((100, 24)).columns or 100  # a pseudo-terminal may report 0 columns
    bar: Any = tqdm(total=None, desc=label, file=stream, leave=False, ncols=min(width, 100), unit="step")

    def update(done: int, total: int) -> None:
        if bar.total != total:
            bar.total = total
        bar.n = done
        bar.refresh()

    try:
        yield update
    finally:
        bar.close()


def _nothing(done: int, total: int) -> None:
    """No bar."""
