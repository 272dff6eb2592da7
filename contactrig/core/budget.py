"""The memory (and time) of the work a scene asks for, estimated before the work starts; refused when it cannot fit.

A scene's allowed ranges still admit work no machine can do (``[rig] mesh = "uniform"`` with ``n_theta = 1000000``
and ``n_axial = 100000``: 745 GiB). So every simulation entry point estimates its work first and refuses it, naming
the scene keys that decide it and the estimate, when it exceeds the bound:

* **Stages.** The work is split into stages — surface generation, the contact database (per model), the rig's mesh,
  the press's rings, the boundary-element reference — each with one registered :class:`Stage` whose ``estimate``
  returns an :class:`Estimate` (peak memory above the process's own, in bytes, and where it can, the time, s). The
  physics-side estimators live in ``sims.budget``, which registers them when imported (every simulation entry point
  imports it; this layer imports nothing of ``sims``); a test measures each against the peak resident memory of a
  child process.
* **The bound**: :func:`memory_limit` (``--max-memory``), else the memory the machine has available now
  (``MemAvailable`` of ``/proc/meminfo``); with neither (not Linux), nothing is refused.
* **The check**: :func:`check` raises :class:`BudgetError` (a ValueError: one line, exit 2) for the largest estimate
  over the bound. Stages run one after another, so the work's peak is its largest stage's.

Standard library only (and :mod:`contactrig.core.registry`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from contactrig.core.registry import Registry

__all__ = [
    "STAGES",
    "BudgetError",
    "Estimate",
    "Stage",
    "available_memory_bytes",
    "check",
    "estimate",
    "format_bytes",
    "memory_limit",
    "parse_size",
    "set_process_limit",
]


@dataclass(frozen=True)
class Estimate:
    """The cost of one stage: ``what`` it is (``"rig mesh of greenwood_tripp"``), the scene ``keys`` and values that
    decide it (``"[rig] n_theta = 1000000, …"``), ``peak_bytes`` its peak memory above the process's own [bytes] and
    ``seconds`` its time [s] (NaN where it cannot be estimated)."""

    what: str
    keys: str
    peak_bytes: float
    seconds: float = math.nan


@dataclass(frozen=True)
class Stage:
    """A registered estimator: ``estimate(*args, **kwargs) -> Estimate`` for the stage ``key``."""

    key: str
    estimate: Callable[..., Estimate]
    description: str = ""


#: The stage estimators by key; ``sims.budget`` registers the built-in ones.
STAGES: Registry[Stage] = Registry("work stage")


def estimate(stage: str, *args: Any, **kwargs: Any) -> Estimate:
    """The estimate of the registered stage ``stage`` for the given work."""
    return STAGES.get(stage).estimate(*args, **kwargs)


class BudgetError(ValueError):
    """The work a scene asks for exceeds the memory bound. ``estimate`` is the stage, ``limit_bytes`` the bound."""

    def __init__(self, est: Estimate, limit_bytes: float, source: str) -> None:
        self.estimate = est
        self.limit_bytes = limit_bytes
        took = f" and ~{_duration(est.seconds)}" if math.isfinite(est.seconds) else ""
        super().__init__(
            f"{est.keys}: the {est.what} needs about {format_bytes(est.peak_bytes)} of memory{took}, more than "
            f"the {format_bytes(limit_bytes)} {source}; lower these values, or set the bound with --max-memory"
        )


# ---------------------------------------------------------------------------------------------------------------
# The bound.

_LIMIT: ContextVar[float | None] = ContextVar("contactrig_memory_limit", default=None)


def set_process_limit(nbytes: float | None) -> None:
    """The bound of this whole process (a worker's initializer: ``math.inf`` when its parent checked the work of
    every worker together already, so that a worker is not refused for what its siblings hold)."""
    _LIMIT.set(nbytes)


@contextmanager
def memory_limit(nbytes: float | None) -> Iterator[None]:
    """Within the block, the memory bound is ``nbytes`` (``--max-memory``); None keeps the machine's."""
    token = _LIMIT.set(nbytes if nbytes is not None else _LIMIT.get())
    try:
        yield
    finally:
        _LIMIT.reset(token)


def available_memory_bytes(meminfo: str | Path = "/proc/meminfo") -> int | None:
    """``MemAvailable`` of ``meminfo`` [bytes]: what can be allocated now without swapping; None when unknown."""
    try:
        text = Path(meminfo).read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
    m = re.search(r"^MemAvailable:\s+(\d+)\s*kB", text, re.MULTILINE)
    return int(m.group(1)) * 1024 if m else None


def _bound() -> tuple[float, str]:
    explicit = _LIMIT.get()
    if explicit is not None:
        return float(explicit), "allowed by --max-memory"
    available = available_memory_bytes()
    if available is None:
        return math.inf, "available"
    return float(available), "available on this machine (MemAvailable)"


def check(estimates: Iterable[Estimate]) -> Estimate | None:
    """Refuse (:class:`BudgetError`) the largest of ``estimates`` when it exceeds the bound; returns it."""
    largest = max(estimates, key=lambda e: e.peak_bytes, default=None)
    if largest is None:
        return None
    limit, source = _bound()
    if largest.peak_bytes > limit:
        raise BudgetError(largest, limit, source)
    return largest


# ---------------------------------------------------------------------------------------------------------------
# Sizes.

_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def parse_size(text: str) -> int:
    """``"2G"``, ``"512M"``, ``"1.5GiB"``, ``"4096"`` (bytes) → bytes (binary units: 1K = 1024). A ValueError
    naming what is allowed otherwise."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([kKmMgGtT]?)(?:i?[bB])?\s*", str(text))
    value = float(m.group(1)) * _UNITS[m.group(2).lower()] if m else math.nan
    if not (math.isfinite(value) and value >= 1):
        raise ValueError(f"--max-memory = {text!r}: expected a size such as 2G, 512M or 1.5GiB (at least 1 byte)")
    return int(value)


def format_bytes(n: float) -> str:
    """``n`` bytes as ``"3.3 GiB"``, ``"745 GiB"``, ``"12 MiB"``."""
    if not math.isfinite(n):
        return "unbounded memory"
    for unit, size in (("PiB", 1 << 50), ("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} bytes"


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.0f} h"
    return f"{seconds / 86400:.3g} days"
