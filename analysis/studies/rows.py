"""Rows of an error-against-run-time study and the registry that runs them."""

from __future__ import annotations

import importlib
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from typing import Any

from contactrig.core.validation import check_choice

__all__ = ["Row", "Stopwatch", "run", "study_names"]

# study name -> module (each module has ``run(quick: bool) -> list[Row]`` and a ``REFERENCE`` string)
_STUDIES = {
    "gaussian_integrals": "analysis.studies.gaussian_integrals",
    "surface": "analysis.studies.surface",
    "mesh": "analysis.studies.mesh",
    "integrator": "analysis.studies.integrator",
    "acquisition": "analysis.studies.acquisition",
}


@dataclass(frozen=True)
class Row:
    """One measurement: ``error`` (relative unless ``extra['error_kind']`` says otherwise) and wall ``seconds``."""

    study: str
    method: str
    setting: str
    error: float
    seconds: float
    extra: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        extra = d.pop("extra")
        d.update(extra)
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


class Stopwatch:
    """Best-of-``repeat`` wall time of a call, in seconds (``time.perf_counter``)."""

    def __init__(self, repeat: int = 3) -> None:
        self.repeat = repeat

    def __call__(self, fn: Callable[[], Any]) -> tuple[Any, float]:
        best = math.inf
        result = None
        for _ in range(self.repeat):
            t0 = time.perf_counter()
            result = fn()
            best = min(best, time.perf_counter() - t0)
        return result, best


def study_names() -> list[str]:
    """Names of the available studies, in report order."""
    return list(_STUDIES)


def reference_of(name: str) -> str:
    """The study's statement of how its error is measured."""
    return importlib.import_module(_STUDIES[name]).REFERENCE


def run(studies: Iterable[str] | None = None, *, quick: bool = False) -> list[Row]:
    """Run the named studies (all when None) and return their rows."""
    names = list(studies) if studies is not None else study_names()
    for name in names:
        check_choice("study", name, _STUDIES)
    rows: list[Row] = []
    for name in names:
        module = importlib.import_module(_STUDIES[name])
        rows.extend(module.run(quick))
    return rows
