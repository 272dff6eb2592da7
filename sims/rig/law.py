"""The contact law the rig model needs: nominal pressure and real-area fraction against separation.

A contact law is anything with ``pressure(h)``, ``dpressure_dh(h)``, ``area_fraction_at(h)``, ``h_min`` and ``h_max``
(SI units: m, Pa, Pa/m, dimensionless): :class:`sims.database.ContactCurve` is one, the analytic laws of the tests are
others. The rig never asks which model a law comes from. ``h`` is the separation of the mean planes (seed eq. 1), so
the pressure falls with ``h``; a law may be evaluated below ``h_min`` (outside its tabulated range, extrapolated) —
the rig then warns — and above ``h_max`` (little or no contact).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["ContactLaw", "check_law"]


@runtime_checkable
class ContactLaw(Protocol):
    """Nominal contact pressure p(h) [Pa] and real-area fraction A_r/A_0(h) [-] against mean-plane separation h [m]."""

    @property
    def h_min(self) -> float:
        """Smallest tabulated separation [m]; below it the law is extrapolated."""
        ...

    @property
    def h_max(self) -> float:
        """Largest tabulated separation [m]: the contact onset of an asperity law (p = a = 0 above)."""
        ...

    def pressure(self, h: ArrayLike) -> np.ndarray:
        """Nominal contact pressure [Pa] at separations ``h`` [m] (non-increasing, >= 0)."""
        ...

    def dpressure_dh(self, h: ArrayLike) -> np.ndarray:
        """Slope of :meth:`pressure` [Pa/m] (<= 0)."""
        ...

    def area_fraction_at(self, h: ArrayLike) -> np.ndarray:
        """Real-area fraction A_r/A_0 [-] at separations ``h`` [m], in [0, 1]."""
        ...


def check_law(law: object, name: str = "law") -> ContactLaw:
    """Return ``law`` if it has the :class:`ContactLaw` interface and a usable range, else raise.

    Checked once before a solve: the range ``h_min < h_max`` is finite, the pressure is finite, non-negative and
    non-increasing at a few points of it, and the slope is ``<= 0``.
    """
    if not isinstance(law, ContactLaw):
        raise TypeError(f"{name}: expected a contact law with pressure, dpressure_dh, area_fraction_at, h_min, h_max")
    lo, hi = float(law.h_min), float(law.h_max)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ValueError(f"{name}: range h_min = {lo!r} m, h_max = {hi!r} m is not a finite interval")
    h = np.linspace(lo, hi, 9)
    p = np.asarray(law.pressure(h), dtype=float)
    dp = np.asarray(law.dpressure_dh(h), dtype=float)
    a = np.asarray(law.area_fraction_at(h), dtype=float)
    if p.shape != h.shape or not np.all(np.isfinite(p)) or np.any(p < 0) or np.any(np.diff(p) > 1e-12 * p.max()):
        raise ValueError(f"{name}: pressure(h) must be finite, >= 0 and non-increasing on [h_min, h_max]")
    if not np.all(np.isfinite(dp)) or np.any(dp > 0):
        raise ValueError(f"{name}: dpressure_dh(h) must be finite and <= 0 on [h_min, h_max]")
    if not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
        raise ValueError(f"{name}: area_fraction_at(h) must lie in [0, 1] on [h_min, h_max]")
    return law
