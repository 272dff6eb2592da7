"""Parent process of ``test_child_process.py``: runs :func:`contactrig.core.child_process.run_in_child` until the test
kills it.

Usage: ``python child_parent.py MODE [OPTIONS]``. MODE: ``hang`` (the child sleeps 600 s: a library that loops)
or ``large`` (the child sleeps 1 s, then answers 32 MB: more than a pipe holds). OPTIONS, a comma list: ``no-pdeathsig``
(the kernel's signal switched off), ``no-watch`` (the thread watching the parent switched off), ``fast-alarm`` (the
parent's deadline 1 s and the child's grace 1 s: its own deadline fires 2 s after the start; otherwise 600 + 10 s).
"""

from __future__ import annotations

import sys
import time

from contactrig.core import child_process as cp


def hang() -> bytes:
    time.sleep(600)
    return b""


def large() -> bytes:
    time.sleep(1.0)
    return b"x" * (32 << 20)


def main() -> None:
    mode = sys.argv[1]
    options = sys.argv[2].split(",") if len(sys.argv) > 2 else []
    if "no-pdeathsig" in options:
        cp._PR_SET_PDEATHSIG = 0  # not a prctl option: the call fails (EINVAL) and sets nothing
    if "no-watch" in options:
        cp._watch_parent = lambda sentinel: None
    timeout = 600.0
    if "fast-alarm" in options:
        cp.GRACE_S, timeout = 1, 1.0
    cp.run_in_child(hang if mode == "hang" else large, (), timeout=timeout)


if __name__ == "__main__":
    main()
