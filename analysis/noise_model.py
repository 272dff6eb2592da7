"""The scatter of a bench session: one noise model for the design (:mod:`analysis.design`) and the simulated bench
(:mod:`analysis.simulated_session`), issue 21 §3.

On the real rig the contact is re-made for every block (weight lifted and re-placed, oxide and contamination films
differ), so the contact part of the resistance carries a mean-one log-normal factor f. Tab. 1 shows three
components of ln f, which a session's fit sees differently (weights i, series/repeats k)::

    ln f_ik = a_k + b_i + e_ik − (σ_a² + σ_b² + σ_e²)/2          (mean one)

* ``series_sd`` σ_a: a per-series offset, common to every weight of one series (a series is one pass over the
  weights; the fit absorbs most of it into the film, it widens the paired-series errors);
* ``lack_sd`` σ_b: a per-weight deviation common to every series — a lack of fit that no model follows and that the
  repeat scatter cannot show (it makes χ²/ν ≫ 1);
* ``reseat_sd`` σ_e: per weight and repeat, independent re-seating.

Expected over-dispersion of a fit to r series over m weights with the "relative" weighting of :mod:`analysis.fit`
(σ_i² = c²R̄_i²/r, c² the scatter across series at one weight, ≈ σ_a² + σ_e²; the means scatter about the true curve
by σ_b² + σ_e²/r, a common σ_a absorbed in the film)::

    E[ĉ] ≈ (σ_e² + r·σ_b²) / (σ_a² + σ_e²),   ĉ = χ²/ν, ν = m − 2             (:meth:`NoiseModel.expected_c_hat`)

**Estimates from Tab. 1** (:func:`tab1_noise`, the default of ``contactrig design`` and of ``acquire --sim``): the
independent series M1–M3 (M4 is their mean and M5, M6 offset copies of M4: :mod:`analysis.series_dependence`), a
two-way analysis of ln R (8 weights × 3 series): re-seating σ_e = 0.132 (residual mean square, 14 dof), series offset
σ_a = 0.096 (column mean square beyond the residual), lack of fit σ_b = 0.145 (relative misfit of the mean curve to a
power law R = c·W^β beyond σ_e²/3, 6 dof). E[ĉ] ≈ 3.0 for Tab. 1's r = 3 (its M1–M3 physical fit gives 3.1), ≈ 5.4
for six repeats. ``iid``: re-seating only (the old simulator; χ²/ν ≈ 1).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["NOISE_MODELS", "NoiseModel", "estimate_noise", "noise_model", "session_noise", "tab1_noise"]


@dataclass(frozen=True)
class NoiseModel:
    """Relative scatter of a session [-], as SDs of ln R: ``series_sd`` per-series offset, ``reseat_sd`` per weight
    and repeat, ``lack_sd`` per weight common to every series (a lack of fit no model follows); ``source`` where the
    estimates come from. ``NoiseModel.iid(sd)``: re-seating only."""

    series_sd: float
    reseat_sd: float
    lack_sd: float
    source: str = ""

    @classmethod
    def iid(cls, sd: float) -> NoiseModel:
        """Independent re-seating of SD ``sd`` only (χ²/ν ≈ 1)."""
        return cls(0.0, sd, 0.0, f"iid re-seating, SD {sd:g}")

    def factors(self, rng: np.random.Generator, shape: tuple[int, int, int]) -> np.ndarray:
        """Mean-one log-normal factors of shape (sessions, weights, repeats) [-].

        Drawn in a fixed order — re-seating (sessions, weights, repeats) first, then the series offsets (sessions,
        1, repeats), then the lack of fit (sessions, weights, 1) — so one session's re-seating draws, in block order
        (weight index × repeats + repeat), are the first draws of ``rng`` whatever the other components.
        """
        n, m, r = shape
        log = self.reseat_sd * rng.standard_normal((n, m, r))
        log = log + self.series_sd * rng.standard_normal((n, 1, r))
        log = log + self.lack_sd * rng.standard_normal((n, m, 1))
        var = self.series_sd**2 + self.lack_sd**2 + self.reseat_sd**2
        return np.asarray(np.exp(log - 0.5 * var))

    def expected_c_hat(self, repeats: int) -> float:
        """E[χ²/ν] of a session of ``repeats`` series fitted by its true model (module docstring) [-]."""
        within = self.series_sd**2 + self.reseat_sd**2
        if within == 0:
            return math.inf if self.lack_sd > 0 else math.nan
        return (self.reseat_sd**2 + repeats * self.lack_sd**2) / within

    def as_dict(self) -> dict[str, Any]:
        """The parameters as plain data (recorded with a simulated session)."""
        return {"series_sd": self.series_sd, "reseat_sd": self.reseat_sd, "lack_sd": self.lack_sd,
                "source": self.source}  # fmt: skip

    def describe(self) -> str:
        """The estimates in words."""
        return (
            f"noise model ({self.source}): per-series offset SD {100 * self.series_sd:.1f} %, re-seating SD "
            f"{100 * self.reseat_sd:.1f} %, lack of fit common to every series SD {100 * self.lack_sd:.1f} % (of ln R)"
        )


def estimate_noise(curve: Any, curves: Any = None, source: str = "") -> NoiseModel:
    """The :class:`NoiseModel` of a measured curve (complete, paired; copies of other series left out first,
    :func:`analysis.fit.independent_series`): two-way analysis of ln R (weights × series) gives the re-seating
    (residual mean square) and the series offsets (column mean square beyond it); the lack of fit is the relative
    misfit of the mean curve beyond re-seating/r, about a power law (``curves`` None) or about the best of the models
    of ``curves`` (an :class:`analysis.design.ModelCurves`: their A and clean terms)."""
    from analysis.fit import independent_series
    from contactrig.core.validation import SettingError

    curve, _ = independent_series(curve)
    v = np.asarray(curve.values_ohm, dtype=float)
    m, r = v.shape
    if r < 2 or m < 4 or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise SettingError("noise", f"{m} weights × {r} series", "expected ≥ 4 weights × ≥ 2 complete series > 0 Ω")
    lv = np.log(v)
    rows, cols, grand = lv.mean(axis=1), lv.mean(axis=0), float(lv.mean())
    resid = lv - rows[:, None] - cols[None, :] + grand
    reseat2 = float(np.sum(resid**2)) / ((m - 1) * (r - 1))
    ms_col = m * float(np.sum((cols - grand) ** 2)) / (r - 1)
    series2 = max(0.0, (ms_col - reseat2) / m)
    rel = _best_relative_misfit(curve.weight_kg, v.mean(axis=1), curves)
    lack2 = max(0.0, rel - reseat2 / r)
    return NoiseModel(math.sqrt(series2), math.sqrt(reseat2), math.sqrt(lack2), source or curve.source)


def _best_relative_misfit(weight_kg: np.ndarray, mean: np.ndarray, curves: Any) -> float:
    """Smallest Σ((R̄ − fit)/fit)²/(m − 2) over the models (relative lack of fit of the mean curve) [-]; a straight
    line in log–log (a power law) without ``curves``."""
    from analysis.resistance_model import fit_film_series

    m = mean.size
    if curves is None:
        coef = np.polyfit(np.log(weight_kg), np.log(mean), 1)
        return float(np.sum((np.log(mean) - np.polyval(coef, np.log(weight_kg))) ** 2)) / (m - 2)
    best = math.inf
    for name in curves.area_m2:
        a, c = curves.at(name, weight_kg)
        fit = fit_film_series(mean, mean, a, c)  # equal relative weights
        best = min(best, float(np.sum(((mean - fit.predicted_ohm) / fit.predicted_ohm) ** 2)) / (m - 2))
    return best


def session_noise(path: str, option: str = "--noise-from") -> tuple[NoiseModel, dict[str, str]]:
    """The noise model of a session file of one's own bench (``design --noise-from SESSION.h5``, and the prior of
    ``acquire --adaptive --noise-from SESSION.h5``): :func:`estimate_noise` of its repeats (lack of fit about a power
    law, as for Tab. 1; source: ``path``), and where it came from — ``file`` (the name), ``content_id``
    (:func:`daq.run_index.content_id`: a copy or a renamed file has the same). A missing, foreign or damaged file, or
    too few complete repeats to estimate from: :class:`~contactrig.core.validation.SettingError` naming ``option``
    and ``path``."""
    from pathlib import Path

    from analysis.measured import MeasuredCurve
    from contactrig.core.validation import SettingError
    from daq import load_session
    from daq.run_index import content_id

    allowed = "expected a contactrig session file with ≥ 4 weights × ≥ 2 complete repeats"
    try:
        session = load_session(path)
        noise = estimate_noise(MeasuredCurve.from_session(session, source=path), None, path)
    except (OSError, ValueError) as exc:
        raise SettingError(option, path, f"{allowed} ({exc})") from None
    return noise, {"file": Path(path).name, "content_id": content_id(session.start)}


@functools.cache
def tab1_noise() -> NoiseModel:
    """The noise model estimated from the seed paper's Tab. 1 (module docstring): the default of the design and of
    the simulated bench, one estimate (lack of fit about a power law, so it does not depend on a scene's models)."""
    from analysis.measured import load_tab1

    return estimate_noise(load_tab1(), None, "seed paper Tab. 1, independent series M1–M3")


#: The named noise models (``[session] sim_noise``, ``design --noise-from``): name → builder taking the iid SD.
NOISE_MODELS: dict[str, Callable[[float], NoiseModel]] = {
    "tab1": lambda repeat_sd: tab1_noise(),
    "iid": NoiseModel.iid,
}


def noise_model(name: str, repeat_sd: float) -> NoiseModel:
    """The named noise model (:data:`NOISE_MODELS`); ``repeat_sd`` the SD of ln f of ``"iid"``."""
    from contactrig.core.validation import check_choice

    return NOISE_MODELS[check_choice("noise", name, NOISE_MODELS)](repeat_sd)
