"""Design of an experiment that tells the contact models apart (``contactrig design``), issue #15 §3.

For a scene (the piston rig, or a press scene with ``[press]``), every contact model predicts

    R_m(W) = R_s + σ_f / A_m(W) + R_c,m(W) + R_macro,m(W)          (:mod:`analysis.resistance_model`)

with the film σ_f [Ω·m²] and series R_s [Ω] of the fit to seed Tab. 1 (a material/circuit property, the same in any
geometry; R_s ≥ 0), and the clean-metal terms computed (:func:`analysis.resistance_model.specimen_resistance_terms`,
the simulated bench's and the physical fit's one resistance model). A bench session under a plan (loads, repeats) is
simulated as the simulated bench does (``acquire --sim``, :func:`analysis.resistance_model.bench_resistance_ohm`):
each block is ``R_s + f·(σ_f/A + R_clean) + ε`` with f the mean-one log-normal factor of the session's noise model
and ε the instrument noise of one Delta block (``noise_v_rms``/(|I|√count), 2182A at the scene's NPLC). Every
simulated session is fitted with every model by the closed-form weighted least squares of (R_s, σ_f)
(:func:`analysis.resistance_model.fit_film_series`, "relative" weighting), all sessions at once.

**Noise model** (:mod:`analysis.noise_model`, issue 21 §3; the simulated bench's too): iid re-seating alone gives
χ²/ν ≈ 1, Tab. 1 gives 3 (M1–M3) to 11 (all six columns): a plan promised at 97 % would not hold that rate on the
real rig. By default the simulated sessions carry Tab. 1's structure, ln f_ik = a_k + b_i + e_ik: per-series offset
SD 9.6 %, per-weight re-seating 13.2 %, lack of fit common to every series 14.5 % (:func:`tab1_noise`), or the
estimates from a user's own session (``design --noise-from SESSION.h5``), or iid re-seating (``--noise-from iid``).

**Decision rule — the same as** :mod:`analysis.fit` (:func:`told_apart`): ĉ = the smallest χ²/ν over the physical
fits of each simulated session; when ĉ > 1.5 the models are compared by QAIC (Δχ²/ĉ), else by AIC (Δχ²); a fit that
is unphysical (R_s significantly < 0, σ_f significantly ≤ 0) or load-independent is ranked after the others whatever
its (Q)AIC, with the fit's t-intervals (its one error rule, per session: :class:`SessionFits`). For a pair (t, m) the
probability of discrimination is P(t ranked first by Δ ≥ 10 | t true), and the pair is told apart by a plan when
both directions reach ``target`` (90 %). The scene must give both bodies' resistivities (the clean-metal terms need
them): a ``SettingError`` says so.
Cost of a plan: loads × (placing time + repeats × block time)
[s]. The cheapest plan reaching the target for a pair is reported, or "none". Monte-Carlo error of a probability
p from N sessions: √(p(1−p)/N).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.interpolate import PchipInterpolator

from analysis.fit import OVERDISPERSION  # ĉ above which models are compared by QAIC: the fit's rule, one constant
from analysis.noise_model import NoiseModel, estimate_noise, tab1_noise
from analysis.resistance_model import (
    bench_resistance_ohm,
    fit_film_series,
    relative_sigma_ohm,
    specimen_resistance_terms,
)

__all__ = [
    "DesignResult",
    "ModelCurves",
    "NoiseModel",
    "Plan",
    "SessionFits",
    "design",
    "estimate_noise",
    "model_curves",
    "plan_scene_text",
    "simulate_plan",
    "tab1_noise",
    "told_apart",
]

DELTA_AIC = 10.0


@dataclass(frozen=True)
class ModelCurves:
    """Predicted A(W) [m²] and clean-metal R(W) [Ω] per model on a weight grid [kg]; interpolated log-log."""

    weight_kg: np.ndarray
    area_m2: dict[str, np.ndarray]
    clean_ohm: dict[str, np.ndarray]
    geometry: str

    def at(self, model: str, weights_kg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A, R_clean) of ``model`` at ``weights_kg`` (within the grid)."""
        lw = np.log(self.weight_kg)
        x = np.log(np.asarray(weights_kg, dtype=float))
        a = np.exp(PchipInterpolator(lw, np.log(self.area_m2[model]))(x))
        c = np.exp(PchipInterpolator(lw, np.log(self.clean_ohm[model]))(x))
        return a, c


def model_curves(
    scene: Any, weights_kg: Sequence[float] | np.ndarray, models: Sequence[str] | None = None
) -> ModelCurves:
    """A(W) and the clean-metal terms of every model for a rig or press scene at ``weights_kg`` [kg]
    (:func:`analysis.resistance_model.specimen_resistance_terms`)."""
    from sims.config import SimConfig

    config = SimConfig.from_scene(scene)
    names = list(models) if models is not None else list(config.database.models)
    # the one resistance model (the simulated bench's and the physical fit's); no resistivities: a SettingError
    terms = specimen_resistance_terms(config, names, list(np.asarray(weights_kg, dtype=float)))
    return ModelCurves(
        np.asarray(weights_kg, dtype=float),
        {n: t.area_m2 for n, t in terms.items()},
        {n: t.clean_ohm for n, t in terms.items()},
        "press" if config.press is not None else "rig",
    )


@dataclass(frozen=True)
class Plan:
    """A candidate session: ``weights_kg`` [kg], ``repeats`` per weight, ``cost_s`` [s]."""

    weights_kg: tuple[float, ...]
    repeats: int
    cost_s: float


@dataclass(frozen=True)
class DesignResult:
    """Discrimination probability per plan and model pair, and the cheapest plan per pair.

    ``probability[(t, m)]`` array over ``plans``: P(χ²_m − χ²_t ≥ 10 | t true); ``pair_score[(a, b)]`` the smaller
    of the two directions; ``cheapest[(a, b)]`` index into ``plans`` or None; ``n_sessions`` per plan and model.
    """

    plans: list[Plan]
    models: list[str]
    probability: dict[tuple[str, str], np.ndarray] = field(repr=False)
    pair_score: dict[tuple[str, str], np.ndarray] = field(repr=False)
    cheapest: dict[tuple[str, str], int | None]
    n_sessions: int
    target: float
    geometry: str
    film_ohm_m2: float
    series_ohm: float
    noise: NoiseModel | None = None

    @property
    def discriminating(self) -> bool:
        """True when at least one model pair is told apart by some plan."""
        return any(v is not None for v in self.cheapest.values())

    def statement(self) -> str:
        """Plain sentences: which pairs any plan tells apart, with the cheapest plan and its probability; when no
        plan reaches the target for any pair, that comes first."""
        told = {k: v for k, v in self.cheapest.items() if v is not None}
        lines = []
        if not told:
            lines.append(
                f"NO PLAN REACHES THE TARGET: none of the {len(self.plans)} candidate plans tells any pair of models "
                f"apart in ≥ {100 * self.target:.0f} % of simulated sessions. The plan written is the best "
                "non-discriminating one, not a plan that discriminates."
            )
        lines.append(
            f"{self.geometry}: {len(told)} of {len(self.cheapest)} model pairs can be told apart (Δ(Q)AIC ≥ "
            f"{DELTA_AIC:g} in ≥ {100 * self.target:.0f} % of {self.n_sessions} simulated sessions, both ways; QAIC "
            f"when a session's ĉ > {OVERDISPERSION:g}, as in `fit`)."
        )
        if self.noise is not None:
            lines.append(self.noise.describe() + ".")
        for (a, b), i in self.cheapest.items():
            if i is None:
                best = float(self.pair_score[(a, b)].max())
                lines.append(f"- {a} vs {b}: no plan reaches it (best {100 * best:.0f} %).")
                continue
            p = self.plans[i]
            err = math.sqrt(max(self.pair_score[(a, b)][i] * (1 - self.pair_score[(a, b)][i]), 1e-12) / self.n_sessions)
            lines.append(
                f"- {a} vs {b}: {len(p.weights_kg)} loads {p.weights_kg[0]:g}–{p.weights_kg[-1]:g} kg × {p.repeats} "
                f"repeats ({p.cost_s / 60:.0f} min): {100 * self.pair_score[(a, b)][i]:.0f} ± {100 * err:.0f} %."
            )
        return "\n".join(lines)


@dataclass(frozen=True)
class SessionFits:
    """One model's fits of many simulated sessions, judged by :mod:`analysis.fit`'s rules: ``chi2`` [-],
    ``unphysical`` (R_s significantly < 0 or σ_f significantly ≤ 0, :func:`analysis.fit.unphysical_limits`) and
    ``load_independent`` (σ_f's t-interval reaches 0, :func:`analysis.fit.load_independent_slope`) per session, the
    t-intervals from the fit's one error rule (paired-series covariance, or χ²-scaled when over-dispersed and larger,
    per parameter: :func:`analysis.fit.scaled_errors`) at the 95 % level."""

    chi2: np.ndarray
    unphysical: np.ndarray
    load_independent: np.ndarray


def _session_fits(values: np.ndarray, sigma: np.ndarray, area: np.ndarray, clean: np.ndarray) -> SessionFits:
    """The fits of sessions ``values`` (n, m, r) [Ω] with weights from ``sigma`` (n, m): the mean curve, and each
    series alone (the weighted estimator is linear, so the fit is the mean of the series' fits and the paired-series
    covariance their scatter / r, as in :func:`analysis.fit._parameter_covariance`)."""
    from analysis.fit import _t_quantile, load_independent_slope, scaled_errors, unphysical_limits

    _, m, r = values.shape
    fit = fit_film_series(values.mean(-1), sigma, area, clean)
    per = fit_film_series(np.swapaxes(values, -1, -2), sigma[:, None, :], area, clean)  # (n, r) per series
    rep_r, rep_s = per.series_ohm.var(-1, ddof=1) / r, per.film_ohm_m2.var(-1, ddof=1) / r
    dof = m - 2
    # ĉ needs ν > 0: a plan of two weights leaves no degrees of freedom, and its errors come from the repeats alone.
    c_hat = fit.chi2 / dof if dof > 0 else np.full_like(np.asarray(fit.chi2, dtype=float), np.nan)
    scaled_r = scaled_errors(c_hat, dof, fit.series_se**2, rep_r)  # per parameter, as fit's rule
    scaled_s = scaled_errors(c_hat, dof, fit.film_se**2, rep_s)
    se_r = np.where(scaled_r, fit.series_se * np.sqrt(c_hat), np.sqrt(rep_r))
    se_s = np.where(scaled_s, fit.film_se * np.sqrt(c_hat), np.sqrt(rep_s))
    t_r = np.where(scaled_r, _t_quantile(0.95, dof), _t_quantile(0.95, r - 1))
    t_s = np.where(scaled_s, _t_quantile(0.95, dof), _t_quantile(0.95, r - 1))
    return SessionFits(
        chi2=fit.chi2,
        unphysical=unphysical_limits(fit.series_ohm + t_r * se_r, fit.film_ohm_m2 + t_s * se_s),
        load_independent=load_independent_slope(fit.film_ohm_m2 - t_s * se_s),
    )


def simulate_plan(
    curves: ModelCurves,
    plan: Plan,
    truth: str,
    film: float,
    series: float,
    rng: np.random.Generator,
    n_sessions: int,
    repeat_sd: float,
    block_sd_ohm: float,
    noise: NoiseModel | None = None,
) -> dict[str, SessionFits]:
    """Every model's fits of ``n_sessions`` simulated sessions of ``plan`` with model ``truth`` true (``noise``:
    the session's scatter; None: iid re-seating of SD ``repeat_sd``)."""
    w = np.asarray(plan.weights_kg)
    a_t, c_t = curves.at(truth, w)
    f = (noise or NoiseModel.iid(repeat_sd)).factors(rng, (n_sessions, w.size, plan.repeats))
    values = bench_resistance_ohm(series, film, a_t, c_t, f) + block_sd_ohm * rng.standard_normal(f.shape)
    sigma = relative_sigma_ohm(values)
    return {m: _session_fits(values, sigma, *curves.at(m, w)) for m in curves.area_m2}


def told_apart(
    fits: dict[str, SessionFits], truth: str, other: str, dof: int, *, threshold: float = DELTA_AIC
) -> np.ndarray:
    """Per session: does the fit put ``truth`` ahead of ``other`` by Δ(Q)AIC ≥ ``threshold`` (:data:`DELTA_AIC`), as
    :func:`analysis.fit.compare_models` ranks — ĉ = the smallest χ²/ν of the physical fits (of all when none is
    physical), QAIC when ĉ > 1.5; a physical fit ranked before an unphysical one, a load-dependent one before a
    load-independent one, whatever their (Q)AIC."""
    chi2 = np.vstack([f.chi2 for f in fits.values()]) / max(dof, 1)
    physical = ~np.vstack([f.unphysical for f in fits.values()])
    c_phys = np.min(np.where(physical, chi2, np.inf), axis=0)
    c_hat = np.where(np.isfinite(c_phys), c_phys, np.min(chi2, axis=0))
    scale = np.where(c_hat > OVERDISPERSION, c_hat, 1.0)  # QAIC when over-dispersed, as in fit
    t, o = fits[truth], fits[other]
    same = t.unphysical == o.unphysical
    first = (t.unphysical < o.unphysical) | (same & (t.load_independent <= o.load_independent))
    return np.asarray(((o.chi2 - t.chi2) / scale >= threshold) & first)


def candidate_plans(
    w_min: float,
    w_max: float,
    block_s: float,
    place_s: float = 60.0,
    loads: Sequence[int] = (4, 8, 16),
    repeats: Sequence[int] = (3, 6, 12, 24, 48),
) -> list[Plan]:
    """Plans over [w_min, w_max] kg (log-spaced loads, full range and upper half-decade), sorted by cost."""
    plans = []
    for lo in (w_min, math.sqrt(w_min * w_max)):
        for n in loads:
            weights = tuple(float(f"{x:.4g}") for x in np.geomspace(lo, w_max, n))
            for r in repeats:
                plans.append(Plan(weights, r, n * (place_s + r * block_s)))
    return sorted(plans, key=lambda p: p.cost_s)


def design(
    curves: ModelCurves,
    plans: Sequence[Plan],
    *,
    film_ohm_m2: float = 2.2e-9,
    series_ohm: float = 0.0,
    n_sessions: int = 400,
    repeat_sd: float = 0.15,
    block_sd_ohm: float = 1e-7,
    target: float = 0.9,
    seed: int = 0,
    noise: NoiseModel | None = None,
    progress: Any = None,
) -> DesignResult:
    """Probability of discrimination for every plan and model pair (module docstring), vectorised per plan;
    ``progress(done, total)`` after each plan (the command draws it; nothing is printed here)."""
    rng = np.random.default_rng(seed)
    models = list(curves.area_m2)
    prob = {(t, m): np.zeros(len(plans)) for t in models for m in models if t != m}
    for i, plan in enumerate(plans):
        dof = max(len(plan.weights_kg) - 2, 1)
        for t in models:
            fits = simulate_plan(
                curves, plan, t, film_ohm_m2, series_ohm, rng, n_sessions, repeat_sd, block_sd_ohm, noise
            )
            for m in models:
                if m != t:
                    prob[(t, m)][i] = float(np.mean(told_apart(fits, t, m, dof)))
        if progress is not None:
            progress(i + 1, len(plans))
    pair_score: dict[tuple[str, str], np.ndarray] = {}
    cheapest: dict[tuple[str, str], int | None] = {}
    for j, a in enumerate(models):
        for b in models[j + 1 :]:
            score = np.minimum(prob[(a, b)], prob[(b, a)])
            pair_score[(a, b)] = score
            ok = np.flatnonzero(score >= target)
            cheapest[(a, b)] = int(ok[np.argmin([plans[int(k)].cost_s for k in ok])]) if ok.size else None
    return DesignResult(
        list(plans), models, prob, pair_score, cheapest, n_sessions, target, curves.geometry, film_ohm_m2, series_ohm,
        noise,
    )  # fmt: skip


def chosen_plan(result: DesignResult) -> Plan:
    """The plan to run: the cheapest one that tells apart every pair that any plan can; else the best on average."""
    reachable = [k for k, v in result.cheapest.items() if v is not None]
    if reachable:
        ok = np.all([result.pair_score[k] >= result.target for k in reachable], axis=0)
        idx = np.flatnonzero(ok)
        if idx.size:
            return result.plans[int(idx[np.argmin([result.plans[i].cost_s for i in idx])])]
    mean = np.mean(list(result.pair_score.values()), axis=0)
    return result.plans[int(np.argmax(mean))]


#: First line of a plan.toml written when no plan reaches the target (a reader of the plan alone must see it).
NOT_DISCRIMINATING = (
    "# NOT A DISCRIMINATING PLAN: contactrig design found no plan that tells any pair of contact models apart at the\n"
    "# target rate; this is the best non-discriminating plan (see design.md).\n"
)


def plan_scene_text(scene_text: str, plan: Plan, *, discriminating: bool = True) -> str:
    """The scene text with ``[session] repeats`` and ``weights_kg`` set to ``plan`` (other lines untouched); headed
    by :data:`NOT_DISCRIMINATING` when ``discriminating`` is false."""
    if not discriminating:
        return NOT_DISCRIMINATING + plan_scene_text(scene_text, plan)
    found = re.search(r"^\[session\]", scene_text, flags=re.M)
    if found is None:
        return (
            scene_text
            + f"\n[session]\nrepeats = {plan.repeats}\nweights_kg = [{', '.join(f'{w:g}' for w in plan.weights_kg)}]\n"
        )
    start = found.start()
    nxt = re.search(r"^\[", scene_text[start + 1 :], flags=re.M)
    end = len(scene_text) if nxt is None else start + 1 + nxt.start()
    body = scene_text[start:end]
    body = re.sub(r"^weights_kg\s*=.*\n", "", body, flags=re.M)
    weights = ", ".join(f"{w:g}" for w in plan.weights_kg)
    body = re.sub(
        r"^repeats\s*=\s*\d+",
        f"repeats = {plan.repeats}   # chosen by contactrig design\n"
        f"weights_kg = [{weights}]   # chosen by contactrig design",
        body,
        count=1,
        flags=re.M,
    )
    return scene_text[:start] + body + scene_text[end:]


def draw_map(result: DesignResult, path: str, *, force: bool = False) -> None:
    """Discrimination map: probability per plan (rows, by cost) and model pair (columns); saved to ``path``
    (drawn by :func:`analysis.figures.figure_discrimination`)."""
    from analysis.figures import write_discrimination_figure

    write_discrimination_figure(result, path, force=force)  # atomic; an existing file only with force
