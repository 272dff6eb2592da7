"""Stability atlas: what each method returns on stiff and extreme cases.

Each :class:`Case` calls one method on one extreme input and declares what a user should get: a finite, correct
answer (``"finite"``), a finite answer with an explicit warning (``"warning"``), or an explicit error
(``"error"``). :func:`run_atlas` runs every case under a time limit and classifies what actually happened; anything
else — NaN, inf, a negative pressure or area, an unexpected exception type, a hang — is ``"FAIL"``. The test suite
runs the atlas (``tests/analysis/test_studies_atlas.py``), so a regression in any method's edge behaviour fails CI.
"""

from __future__ import annotations

import signal
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Case", "Outcome", "run_atlas"]

EXPECTED = ("finite", "warning", "error")


@dataclass(frozen=True)
class Case:
    """``call()`` returns the numbers to check (array-like or dict of them); all must be finite and, when
    ``non_negative``, ≥ 0. ``check`` (optional) asserts correctness of the returned value beyond finiteness.
    ``expect`` is one of finite, warning, error, or ``"finite/warning"`` where a model-validity warning may or may
    not apply (the point of the case is elsewhere)."""

    name: str
    method: str
    description: str
    call: Callable[[], Any]
    expect: str
    non_negative: bool = True
    check: Callable[[Any], None] | None = None


@dataclass(frozen=True)
class Outcome:
    case: Case
    got: str  # finite | warning | error | FAIL
    detail: str
    seconds: float

    @property
    def ok(self) -> bool:
        return self.got in self.case.expect.split("/")

    def as_dict(self) -> dict[str, Any]:
        return {
            "case": self.case.name,
            "method": self.case.method,
            "description": self.case.description,
            "expected": self.case.expect,
            "got": self.got,
            "ok": self.ok,
            "detail": self.detail,
            "seconds": self.seconds,
        }


class _Hang(Exception):
    pass


def _numbers(value: Any) -> list[np.ndarray]:
    if isinstance(value, dict):
        return [np.asarray(v, dtype=float) for v in value.values() if v is not None and not isinstance(v, str)]
    if isinstance(value, (list, tuple)):
        return [np.asarray(v, dtype=float) for v in value]
    return [np.asarray(value, dtype=float)]


def _judge(case: Case, value: Any, caught: list[warnings.WarningMessage]) -> tuple[str, str]:
    """(got, detail) for a call that returned ``value`` while ``caught`` warnings were issued."""
    for arr in _numbers(value):
        if not np.all(np.isfinite(arr)):
            return "FAIL", "non-finite value returned"
        if case.non_negative and np.any(arr < 0):
            return "FAIL", f"negative value {float(arr.min()):.3g}"
    if case.check is not None:
        case.check(value)  # an AssertionError here is a wrong value (see _run)
    relevant = [w for w in caught if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning))]
    if relevant:
        return "warning", str(relevant[0].message)[:200]
    return "finite", _summary(value)


def _run(case: Case, limit_s: float) -> tuple[str, str]:
    """Call ``case`` and judge what happened: (got, detail); exceptions are classified, never raised."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value = case.call()
        return _judge(case, value, caught)
    except _Hang:
        return "FAIL", f"no answer within {limit_s:g} s"
    except AssertionError as exc:
        return "FAIL", f"wrong value: {exc}"
    except (ValueError, RuntimeError, OSError, ArithmeticError) as exc:
        return "error", f"{type(exc).__name__}: {exc}"[:200]
    except Exception as exc:  # anything else is a defect: an unexpected exception type
        return "FAIL", f"unexpected {type(exc).__name__}: {exc}"[:200]


def _alarm(signum: int, frame: Any) -> None:  # pragma: no cover - only on a hang
    raise _Hang


def _classify(case: Case, limit_s: float) -> Outcome:
    """Run ``case`` under a time limit (SIGALRM where the platform has it) and classify the outcome."""
    t0 = time.perf_counter()
    if not hasattr(signal, "SIGALRM"):
        got, detail = _run(case, limit_s)
        return Outcome(case, got, detail, time.perf_counter() - t0)
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, limit_s)
    try:
        got, detail = _run(case, limit_s)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    return Outcome(case, got, detail, time.perf_counter() - t0)


def _summary(value: Any) -> str:
    arrs = _numbers(value)
    flat = np.concatenate([a.ravel() for a in arrs]) if arrs else np.array([])
    if flat.size == 0:
        return "empty"
    if flat.size == 1:
        return f"{float(flat[0]):.4g}"
    return f"{flat.size} values in [{float(flat.min()):.3g}, {float(flat.max()):.3g}]"


#: Time after which a case counts as hung [s]. A guard against hangs, not a time budget: every case is sized to take
#: well under a second on a quiet machine (the BEM database on a 64² surface, ``atlas_cases.ATLAS_SURFACE_N``), so
#: the verdict does not depend on the machine's load.
HANG_LIMIT_S = 120.0


def run_atlas(cases: list[Case] | None = None, *, limit_s: float = HANG_LIMIT_S) -> list[Outcome]:
    """Run ``cases`` (default: every case of :mod:`analysis.studies.atlas_cases`); one :class:`Outcome` each, a case
    still running after ``limit_s`` [s] being a hang (FAIL)."""
    from analysis.studies.atlas_cases import all_cases

    return [_classify(c, limit_s) for c in (cases if cases is not None else all_cases())]
