"""A ``contactrig`` command whose session reader hangs (a library that loops on a damaged file), for tests that
kill the command while it reads: ``python slow_read.py COMMAND ARGS…``. The reader (``daq.session_reader._load``,
run in the forked child of :mod:`daq.bounded`) sleeps 600 s before it reads, and so does the run index's reader of a
sealed session's records (``daq.session_reader.load_records``, which ``contactrig sessions FOLDER`` uses): without
it that command read the small session in a child too short-lived to be caught (a CI run of 27 Nov 2026)."""

from __future__ import annotations

import sys
import time
from typing import Any

import daq.session_reader as reader
from contactrig.cli.main import main

_real_load, _real_records = reader._load, reader.load_records


def _hanging(*args: Any, **kwargs: Any) -> Any:
    time.sleep(600)
    return _real_load(*args, **kwargs)


def _hanging_records(*args: Any, **kwargs: Any) -> Any:
    time.sleep(600)
    return _real_records(*args, **kwargs)


reader._load = _hanging
reader.load_records = _hanging_records

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
