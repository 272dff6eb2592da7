"""A ``contactrig`` command on a slow disk, for tests that kill it while it writes: ``python slow_io.py COMMAND
ARGS…``. Every rename, link and unlink waits ``CONTACTRIG_TEST_RENAME_DELAY_S`` seconds (default 0.2) first, so the
moments between the writes of a set of files are long enough to be hit by a kill; SVG ids are made reproducible
(``svg.hashsalt``), so two runs on the same data give the same bytes."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

DELAY_S = float(os.environ.get("CONTACTRIG_TEST_RENAME_DELAY_S", "0.2"))


def _slowed(real: Any) -> Any:
    def call(*args: Any, **kwargs: Any) -> Any:
        time.sleep(DELAY_S)
        return real(*args, **kwargs)

    return call


for _name in ("replace", "rename", "link", "unlink"):
    setattr(os, _name, _slowed(getattr(os, _name)))

if __name__ == "__main__":
    import matplotlib

    matplotlib.rcParams["svg.hashsalt"] = "contactrig-kill-test"
    from contactrig.cli.main import main

    sys.exit(main(sys.argv[1:]))
