"""A ``contactrig`` command whose session reader hangs (a library that loops on a damaged file), for tests that
kill the command while it reads: ``python slow_read.py COMMAND ARGS…``. The reader (``daq.session_reader._load``,
run in the forked child of :mod:`daq.bounded`) sleeps 600 s before it reads."""

from __future__ import annotations

import sys
import time
from typing import Any

import daq.session_reader as reader
from contactrig.cli.main import main

_real = reader._load


def _hanging(*args: Any) -> Any:
    time.sleep(600)
    return _real(*args)


reader._load = _hanging

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
