"""Bench sessions: resistance blocks per added weight, logged to HDF5, resumed, replayed, imported.

``from daq import load_session`` reads a session file (see :mod:`daq.session_file`). The package imports
nothing heavy until a name is used, so the ``contactrig`` dispatcher stays fast.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Session", "load_session"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from daq import session_file

        return getattr(session_file, name)
    raise AttributeError(f"module 'daq' has no attribute {name!r}")
