"""Validation of user-supplied settings: one error type that names the field, the value and what is allowed.

Every setting that reaches a solver or an instrument passes through these checks first. Nothing is clamped:
an out-of-range value is an error, never a quiet change. This module imports only the standard library and
numpy, so every package (``instruments`` included) can use it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from contactrig.core.text import quote, shorten

__all__ = [
    "SCENE_TABLES",
    "SettingError",
    "check_choice",
    "check_finite",
    "check_int",
    "check_keys",
    "check_range",
    "scene_key",
]


# The top-level tables of a scene file (see contactrig.core.scene); a setting path that starts with one of them is
# a scene key and is shown as the user wrote it in the file: ``surfaces.liner.sq_m`` → ``[surfaces.liner] sq_m``.
SCENE_TABLES = (
    *("scene", "materials", "surfaces", "database", "rig", "circuit", "instrument", "delta", "session"),
    "press",  # the press specimen geometry (sims.press, issue #15)
)
_BODY_TABLES = ("materials", "surfaces")


def scene_key(path: str) -> str:
    """How a setting path reads in a scene file: ``"rig.clearance_m"`` → ``"[rig] clearance_m"``.

    Paths that are not scene keys (a function argument such as ``"current"``) are returned unchanged.
    """
    parts = path.split(".")
    if parts[0] not in SCENE_TABLES or len(parts) < 2:
        return path
    if parts[0] in _BODY_TABLES and len(parts) == 2:
        return f"[{path}]"  # a whole body table, e.g. a missing [surfaces.liner]
    n_table = 2 if parts[0] in _BODY_TABLES else 1
    return f"[{'.'.join(parts[:n_table])}] {'.'.join(parts[n_table:])}"


class SettingError(ValueError):
    """A setting is invalid. ``field``, ``value`` and ``allowed`` say which, what and what would do.

    ``field`` is a dotted path; scene keys are shown as in the file (``[surfaces.liner] sq_m``, see :func:`scene_key`).
    """

    def __init__(self, field: str, value: Any, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{shorten(scene_key(field))} = {quote(value)} is not allowed: {allowed}")


def _as_float(field: str, value: Any) -> float:
    if isinstance(value, bool) or (not isinstance(value, (int, float)) and not hasattr(value, "__float__")):
        raise SettingError(field, value, "expected a number")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise SettingError(field, value, "expected a number") from None
    return x


def check_finite(field: str, value: Any) -> float:
    """Return ``value`` as a finite float, or raise :class:`SettingError`."""
    x = _as_float(field, value)
    if not math.isfinite(x):
        raise SettingError(field, value, "expected a finite number")
    return x


def check_range(
    field: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
) -> float:
    """Return ``value`` as a finite float inside [lo, hi] (or the open variants), else raise.

    ``unit`` is only used in the message (e.g. ``"A"``).
    """
    x = check_finite(field, value)
    below = lo is not None and (x <= lo if lo_open else x < lo)
    above = hi is not None and (x >= hi if hi_open else x > hi)
    if below or above:
        raise SettingError(field, value, _describe(lo, hi, lo_open, hi_open, unit))
    return x


def check_int(field: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as an int inside [lo, hi]; floats with a fraction, bools and strings are errors."""
    if isinstance(value, bool):
        raise SettingError(field, value, "expected a whole number")
    if isinstance(value, float):
        if not value.is_integer():
            raise SettingError(field, value, "expected a whole number")
        value = int(value)
    if not isinstance(value, int):
        try:
            import numpy as np

            if isinstance(value, np.integer):
                value = int(value)
            else:
                raise TypeError
        except TypeError:
            raise SettingError(field, value, "expected a whole number") from None
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise SettingError(field, value, _describe(lo, hi, False, False, "").replace("a value", "a whole number"))
    return value


def check_choice(field: str, value: Any, choices: Iterable[Any]) -> Any:
    """Return ``value`` if it is one of ``choices``, else raise naming them."""
    options = list(choices)
    if value not in options:
        raise SettingError(field, value, "expected one of " + ", ".join(repr(c) for c in options))
    return value


def check_keys(section: str, mapping: Mapping[str, Any], allowed: Iterable[str]) -> None:
    """Raise :class:`SettingError` for the first key of ``mapping`` that is not in ``allowed``."""
    known = list(allowed)
    for key in mapping:
        if key not in known:
            name = f"{section}.{key}" if section else key
            raise SettingError(name, mapping[key], "unknown key; known keys are " + ", ".join(known))


def _describe(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool, unit: str) -> str:
    u = f" {unit}" if unit else ""
    if lo is not None and hi is not None:
        left = "(" if lo_open else "["
        right = ")" if hi_open else "]"
        return f"expected a value in {left}{lo:g}, {hi:g}{right}{u}"
    if lo is not None:
        return f"expected a value {'>' if lo_open else '>='} {lo:g}{u}"
    if hi is not None:
        return f"expected a value {'<' if hi_open else '<='} {hi:g}{u}"
    return "expected a finite number"
