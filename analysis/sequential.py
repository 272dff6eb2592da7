"""Sequential design for model discrimination: the bench that measures until it knows (issue 27).

One home for the evidence, the next placement and the stopping rule, behind the grammar bluesky-adaptive settled
on: :meth:`SequentialDesign.ingest` a block, :meth:`~SequentialDesign.suggest` the next placement,
:meth:`~SequentialDesign.report` the state (plain data: what ``acquire``, ``watch`` and the console show). It shares
everything with :mod:`analysis.design` and :mod:`analysis.fit`: the resistance model R = R_s + f·(σ_f/A_m(W) +
R_clean,m(W)) (:func:`analysis.resistance_model.bench_resistance_ohm`), its closed-form weighted fit
(:func:`analysis.resistance_model.fit_film_series`), the noise model (:mod:`analysis.noise_model`) and the fit's
decision rule (:func:`analysis.design.told_apart`). No second statistic.

**Evidence** (after every block): each seating (a weight placed and measured; blocks at one seating averaged) is one
repeat at its weight. The weights with ≥ 2 seatings are fitted with every model, weighted as ``fit``'s "relative"
weighting (σ_i = c·R̄_i/√n_i, c² = Σ(n_i−1)(s_i/R̄_i)²/Σ(n_i−1)), ĉ = the smallest χ²/ν of the physical fits, the
models compared by QAIC (Δχ²/ĉ) when ĉ > 1.5, else by AIC, an unphysical or load-independent fit ranked after the
others (the fit's t-intervals; the repeat covariance taken as the pooled-relative curvature covariance, the same in
expectation for unpaired repeats; χ²-scaled when over-dispersed, :func:`analysis.fit.scaled_errors`).

**Decisive**: the leader ahead of every rival it can be told from by Δ(Q)AIC ≥ ``threshold`` (the fit's 10 by
default; optional stopping inflates the error rate of a fixed-sample rule, so the threshold of a session that
stops when it is reached is calibrated by simulating the whole loop, ``tests/benchmarks/bench_adaptive.py``,
:data:`DECISIVE_DELTA`). A rival that no session within the budget could tell from the leader (its expected
Δ(Q)AIC at the whole budget, spread over the allowed weights, below the threshold both ways) is *equivalent on this
bench*: named with the leader, never counted as beaten.

**The next placement**: among the bench's weights (:attr:`SequentialDesign.weights_kg`: the plan's weights, as the
rig's can be stacked, the press's range) and the actions place a new weight (two seatings: the fit needs ≥ 2 at every
weight), re-seat a weight already on the list (lift and place it again: new contact) or repeat at the present
seating (shrinks only the instrument noise), the one of largest **expected gain in evidence per minute**. The gain
is the Box–Hill-type sum over model pairs weighted by their Akaike weights π_a π_b of the increase of the expected
Δ(Q)AIC both ways (the AIC form of twice the expected log Bayes factor): for truth a with its fitted (R_s, σ_f),
Δ_ab ≈ λ_ab/E[ĉ], λ_ab the χ² of model b's best fit to a's predicted means (the non-centrality) and E[ĉ] =
mean_i (σ_e² + n_i σ_b²)/(σ_a² + σ_e²) the over-dispersion the noise model gives (QAIC when > 1.5). Cost
(:class:`CostModel`): the block time from the plan's duration estimate (:func:`daq.plan.block_duration_s`), placing
or removing a weight (the plan's operator allowance, 60 s), re-seating (5 s, an assumption).

**Predictive probability** of ending decisive if the session goes on as suggested: the suggestions followed on the
expected state until the budget is spent, then ``n_forward`` futures simulated from the current data (truth drawn by
the Akaike weights, its fitted parameters, the lack of fit at weights already measured drawn about its estimate from
the session), each judged at checkpoints by the same rule.

**Stop**: ``decisive``; ``futile`` when P(decisive within the remaining budget) < :data:`FUTILE_P` (5 %), with the
dominant noise component against the largest difference between the leading models that no (R_s, σ_f) absorbs; or
the operator's choice (``acquire``). Futile before the first block when the prior noise makes every pair of models
equivalent on this bench (:meth:`SequentialDesign.hopeless`): the decisive rule needs a separable rival, so then
P(decisive) = 0 whatever the data — a consequence of the rule, not a threshold (Tab. 1's noise on the paper's rig
and on the press).

**Noise components**: the scatter between seatings at one weight (re-seating, with any series offset: an adaptive
session has no series to separate them) from the session once Σ(n_i − 1) ≥ 4, the lack of fit common to every
seating once ≥ 4 weights have ≥ 2 seatings (relative misfit of the best physical fit's means beyond the seating
scatter / n_i); until then the prior's (Tab. 1's, the simulated bench's, or an earlier session's: ``acquire
--noise-from``), said.

**Intervals of an adaptive session**: the placements depend on the data only through earlier blocks, so the
likelihood — the estimates and Δ(Q)AIC of ``fit`` — is that of a fixed design with the same placements (Ford,
Titterington & Wu 1985, Biometrika 72:545); t-intervals keep their level asymptotically when the design settles (Lai &
Wei 1982, Ann. Stat. 10:154), not exactly for few seatings. What optional stopping changes is the error rate of the
stop rule, which is why the threshold is calibrated by simulating the loop. Box & Hill 1967 (Technometrics 9:57):
the discrimination criterion.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.design import DELTA_AIC, ModelCurves, SessionFits, told_apart
from analysis.fit import OVERDISPERSION
from analysis.noise_model import NoiseModel
from analysis.resistance_model import FilmFit, bench_resistance_ohm, fit_film_series

__all__ = [
    "DECISIVE_DELTA",
    "FUTILE_P",
    "CostModel",
    "Evidence",
    "Placement",
    "SequentialDesign",
    "simulate_loop",
]

#: Δ(Q)AIC at which an adaptive session stops decisive. The fit's rule is 10; stopping as soon as it is reached
#: inflates the rate of a wrong model declared decisive, so the value is calibrated by simulating the whole loop
#: (``tests/benchmarks/bench_adaptive.py --calibrate``, seeds apart from the reported ones).
DECISIVE_DELTA = DELTA_AIC
#: Futility: stop when the probability of becoming decisive within the remaining budget is below this.
FUTILE_P = 0.05
#: Noise components, in the words a person reads.
COMPONENT_WORDS = {
    "series_sd": "the per-series offset",
    "reseat_sd": "the re-seating scatter",
    "lack_sd": "the lack of fit common to every series",
}


@dataclass(frozen=True)
class CostModel:
    """Bench time of an action [s]: ``block_s`` one block (the plan's duration estimate), ``place_s`` removing the
    weight on the piston and placing another (the plan's operator allowance), ``reseat_s`` lifting and re-placing
    the same weight (an assumption: 5 s; the design's plans count none, the simulated bench re-seats every block)."""

    block_s: float
    place_s: float = 60.0
    reseat_s: float = 5.0

    def of(self, action: str, seatings: int = 1) -> float:
        """Seconds for ``action`` ("place": a new weight, ``seatings`` blocks with re-seats between; "reseat";
        "repeat": one more block at the present seating)."""
        if action == "place":
            return self.place_s + seatings * self.block_s + (seatings - 1) * self.reseat_s
        if action == "reseat":
            return self.reseat_s + self.block_s
        return self.block_s


@dataclass(frozen=True)
class Placement:
    """A suggestion: ``action`` ("place", "reseat" or "repeat") at ``weight_kg`` [kg], ``seatings`` blocks;
    ``gain`` the expected gain in Δ(Q)AIC, ``cost_s`` [s], ``criterion`` in words, ``why`` a short reason."""

    weight_kg: float
    action: str
    seatings: int
    gain: float
    cost_s: float
    criterion: str
    why: str = ""

    @property
    def gain_per_min(self) -> float:
        return self.gain / (self.cost_s / 60.0) if self.cost_s > 0 else 0.0

    def describe(self) -> str:
        """``re-seat 10 kg (expected gain 1.2 Δ(Q)AIC/min)`` — the prompt's words."""
        verb = {"place": "place", "reseat": "re-seat", "repeat": "repeat at the present seating of"}[self.action]
        times = f" ({self.seatings} seatings)" if self.seatings > 1 else ""
        tail = f": {self.why}" if self.why else f" (expected gain {self.gain_per_min:.2g} Δ(Q)AIC/min)"
        return f"{verb} {self.weight_kg:g} kg{times}{tail}"

    def as_dict(self) -> dict[str, Any]:
        return {"weight_kg": self.weight_kg, "action": self.action, "seatings": self.seatings, "gain": self.gain,
                "cost_s": self.cost_s, "gain_per_min": self.gain_per_min, "criterion": self.criterion,
                "why": self.why, "text": self.describe()}  # fmt: skip


@dataclass(frozen=True)
class Evidence:
    """The fit's verdict on the session so far: ``ranking`` (fit's order), ``delta`` Δ(Q)AIC of each model to the
    best, ``criterion`` "AIC"/"QAIC", ``c_hat``; ``leader``, the ``equivalent`` models (not separable on this bench),
    ``margin`` the smallest Δ to a separable rival (inf when none), ``decisive``; ``fits`` per model (R_s [Ω], σ_f
    [Ω·m²]); ``weights`` used (≥ 2 seatings)."""

    ranking: tuple[str, ...]
    delta: dict[str, float]
    criterion: str
    c_hat: float
    leader: str
    equivalent: tuple[str, ...]
    margin: float
    decisive: bool
    fits: dict[str, tuple[float, float]] = field(repr=False)
    weights: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {"ranking": list(self.ranking), "delta": {k: _num(v) for k, v in self.delta.items()},
                "criterion": self.criterion, "c_hat": _num(self.c_hat), "leader": self.leader,
                "equivalent": list(self.equivalent), "margin": _num(self.margin), "decisive": self.decisive,
                "weights": self.weights,
                "fits": {k: {"series_ohm": v[0], "film_ohm_m2": v[1]} for k, v in self.fits.items()}}  # fmt: skip


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _label(model: str) -> str:
    from sims.models import model_label

    return model_label(model)


# ---- the fit of ragged sessions, vectorised over simulated futures ----------------------------------------------


def _fits(
    values: np.ndarray, curves: ModelCurves, weights_kg: np.ndarray
) -> tuple[dict[str, SessionFits], dict[str, FilmFit], int]:
    """Every model's fit of sessions ``values`` (N, m, R) [Ω] (NaN: no seating; the pattern common to all N, every
    weight ≥ 2 seatings), judged by the fit's rules (module docstring); returns (judged fits, raw fits, ν)."""
    from analysis.fit import _t_quantile, load_independent_slope, scaled_errors, unphysical_limits

    n = np.sum(np.isfinite(values[0]), axis=-1)
    m = n.size
    mean = np.nanmean(values, axis=-1)
    rel2 = np.nanvar(values, axis=-1, ddof=1) / mean**2
    pooled = float(np.sum(n - 1))
    c = np.sqrt(np.sum((n - 1) * rel2, axis=-1) / pooled)
    sigma = c[:, None] * mean / np.sqrt(n)
    dof = m - 2
    judged: dict[str, SessionFits] = {}
    raw: dict[str, FilmFit] = {}
    for model in curves.area_m2:
        a, cl = curves.at(model, weights_kg)
        fit = fit_film_series(mean, sigma, a, cl)
        c_hat = fit.chi2 / max(dof, 1)
        scaled = scaled_errors(c_hat, dof, fit.film_se**2, fit.film_se**2)
        factor = np.where(scaled, np.sqrt(c_hat), 1.0)
        t = np.where(scaled, _t_quantile(0.95, max(dof, 1)), _t_quantile(0.95, pooled))
        se_r, se_s = fit.series_se * factor, fit.film_se * factor
        judged[model] = SessionFits(
            chi2=fit.chi2,
            unphysical=unphysical_limits(fit.series_ohm + t * se_r, fit.film_ohm_m2 + t * se_s),
            load_independent=load_independent_slope(fit.film_ohm_m2 - t * se_s),
        )
        raw[model] = fit
    return judged, raw, dof


def _decisive(
    fits: dict[str, SessionFits], dof: int, threshold: float, groups: dict[str, frozenset[str]]
) -> tuple[np.ndarray, np.ndarray]:
    """Per session: (decisive, index of the leader among the models) — a leader told apart (Δ ≥ ``threshold``, the
    fit's order) from every model outside its group of equivalents ``groups[leader]``; one with no separable rival
    is never decisive."""
    models = list(fits)
    n = fits[models[0]].chi2.shape[0]
    out = np.zeros(n, dtype=bool)
    who = np.full(n, -1)
    for i, lead in enumerate(models):
        rivals = [m for m in models if m not in groups[lead]]
        if not rivals:
            continue
        ok = np.ones(n, dtype=bool)
        for m in rivals:
            ok &= told_apart(fits, lead, m, dof, threshold=threshold)
        who = np.where(ok & ~out, i, who)
        out |= ok
    return out, who


# ---- the state and its interface --------------------------------------------------------------------------------


class SequentialDesign:
    """The sequential state of one session (module docstring): ``ingest`` blocks, ``suggest``, ``report``.

    ``curves`` the models' A(W) and clean terms (:func:`analysis.design.model_curves`, covering ``weights_kg``);
    ``weights_kg`` the placements the bench allows [kg]; ``cost`` the :class:`CostModel`; ``budget_s`` the bench
    time allowed [s]; ``noise`` the prior noise model (Tab. 1's on a real bench, the simulated bench's with
    ``--sim``, an earlier session's with ``--noise-from``); ``film_ohm_m2``, ``series_ohm`` prior σ_f, R_s (the
    scene's circuit); ``threshold`` the decisive Δ(Q)AIC; ``n_forward`` futures of the predictive probability;
    ``seed`` its generator (with the block count: a replay gives the same numbers).
    """

    def __init__(
        self,
        curves: ModelCurves,
        weights_kg: Sequence[float],
        cost: CostModel,
        *,
        budget_s: float,
        noise: NoiseModel,
        film_ohm_m2: float = 2.2e-9,
        series_ohm: float = 0.0,
        threshold: float = DECISIVE_DELTA,
        n_forward: int = 200,
        seed: int = 0,
    ) -> None:
        self.curves = curves
        self.weights_kg = np.array(sorted({float(w) for w in weights_kg}))
        self.models = list(curves.area_m2)
        self.cost = cost
        self.budget_s = float(budget_s)
        self.prior = noise
        self.film, self.series = float(film_ohm_m2), float(series_ohm)
        self.threshold = float(threshold)
        self.n_forward = int(n_forward)
        self.seed = int(seed)
        m = self.weights_kg.size
        self._ac = {k: curves.at(k, self.weights_kg) for k in self.models}
        #: seatings per weight index: each a list of block means [Ω]
        self.seatings: list[list[list[float]]] = [[] for _ in range(m)]
        self.blocks = 0
        self.spent_s = 0.0
        self.current: int | None = None
        self.pending: int | None = None  # a weight placed with one seating: the next suggestion re-seats it
        self._seating: int | None = None  # the recorded number of the present seating (``ingest``'s ``seating``)
        self.groups = self._equivalents()
        self._cache: dict[str, Any] = {}  # evidence, noise of the present blocks (cleared by ingest)

    # -- ingest ---------------------------------------------------------------------------------------------------
    def index_of(self, weight_kg: float) -> int:
        """Index of ``weight_kg`` among :attr:`weights_kg` (a weight the bench does not allow: ValueError)."""
        i = int(np.argmin(np.abs(self.weights_kg - weight_kg)))
        if not math.isclose(self.weights_kg[i], weight_kg, rel_tol=1e-9, abs_tol=1e-12):
            allowed = ", ".join(f"{w:g}" for w in self.weights_kg)
            raise ValueError(f"weight {weight_kg:g} kg is not one of the placements allowed ({allowed} kg)")
        return i

    def ingest(self, weight_kg: float, value_ohm: float, *, reseated: bool = True, seating: int | None = None) -> None:
        """One block's mean [Ω] at ``weight_kg``: a new seating (``reseated``, or a weight other than the present
        one), else one more block at the present seating. ``seating``: the block's seating number as a session file
        records it (its ``repeat``), which decides instead of ``reseated``: the block is at the present seating when
        its weight and number are those of the block ingested before it. Its bench time is counted by the
        :class:`CostModel`."""
        i = self.index_of(weight_kg)
        if seating is not None:
            reseated = i != self.current or seating != self._seating
            self._seating = seating
        if i != self.current:
            self.spent_s += self.cost.place_s + self.cost.block_s
            self.seatings[i].append([float(value_ohm)])
        elif reseated or not self.seatings[i]:
            self.spent_s += self.cost.reseat_s + self.cost.block_s
            self.seatings[i].append([float(value_ohm)])
        else:
            self.spent_s += self.cost.block_s
            self.seatings[i][-1].append(float(value_ohm))
        self.current = i
        self.blocks += 1
        self._cache.clear()
        self.pending = i if len(self.seatings[i]) == 1 else None

    # -- the data as the fit sees them --------------------------------------------------------------------------
    def _matrix(self) -> tuple[np.ndarray, np.ndarray]:
        """(weight indices with ≥ 2 seatings, values (1, m, R) [Ω] with NaN padding)."""
        used = np.array([i for i, s in enumerate(self.seatings) if len(s) >= 2], dtype=int)
        r = max((len(self.seatings[i]) for i in used), default=0)
        v = np.full((1, used.size, r), np.nan)
        for j, i in enumerate(used):
            v[0, j, : len(self.seatings[i])] = [float(np.mean(b)) for b in self.seatings[i]]
        return used, v

    def evidence(self) -> Evidence | None:
        """The fit's verdict on the weights with ≥ 2 seatings (None until ≥ 3 such weights: ν ≥ 1)."""
        if "evidence" not in self._cache:
            self._cache["evidence"] = self._evidence()
        return self._cache["evidence"]

    def _evidence(self) -> Evidence | None:
        used, v = self._matrix()
        if used.size < 3:
            return None
        curves = _subset(self.curves, self._ac, used)
        judged, raw, dof = _fits(v, curves, self.weights_kg[used])
        chi2 = {k: float(judged[k].chi2[0]) / dof for k in self.models}
        physical = [k for k in self.models if not judged[k].unphysical[0]]
        c_hat = min(chi2[k] for k in (physical or self.models))
        scale = c_hat if c_hat > OVERDISPERSION else 1.0
        crit = {k: float(judged[k].chi2[0]) / scale for k in self.models}
        order = sorted(self.models, key=lambda k: (bool(judged[k].unphysical[0]),
                                                   bool(judged[k].load_independent[0]), crit[k]))  # fmt: skip
        best = crit[order[0]]
        lead = order[0]
        rivals = [k for k in self.models if k not in self.groups[lead]]
        margin = min((crit[k] - best for k in rivals), default=math.inf)
        decisive, who = _decisive(judged, dof, self.threshold, self.groups)
        return Evidence(
            ranking=tuple(order),
            delta={k: crit[k] - best for k in self.models},
            criterion="QAIC" if scale > 1 else "AIC",
            c_hat=c_hat,
            leader=lead,
            equivalent=tuple(sorted(self.groups[lead] - {lead})),
            margin=margin,
            decisive=bool(decisive[0]) and self.models[int(who[0])] == lead,
            fits={k: (float(raw[k].series_ohm[0]), float(raw[k].film_ohm_m2[0])) for k in self.models},
            weights=int(used.size),
        )

    def noise(self) -> tuple[NoiseModel, dict[str, str]]:
        """The noise model as the session's data allow (module docstring) and where each component comes from."""
        if "noise" not in self._cache:
            self._cache["noise"] = self._noise()
        return self._cache["noise"]

    def _noise(self) -> tuple[NoiseModel, dict[str, str]]:
        used, v = self._matrix()
        src = {k: "prior" for k in COMPONENT_WORDS}
        series, reseat, lack = self.prior.series_sd, self.prior.reseat_sd, self.prior.lack_sd
        if used.size:
            lv = np.log(np.clip(v[0], 1e-300, None))
            n = np.sum(np.isfinite(lv), axis=1)
            dof = int(np.sum(n - 1))
            if dof >= 4:
                within = float(np.nansum((lv - np.nanmean(lv, axis=1, keepdims=True)) ** 2)) / dof
                series, reseat = 0.0, math.sqrt(within)
                src["reseat_sd"] = "session"
                src["series_sd"] = "session (within the re-seating: an adaptive session has no series)"
                ev = self.evidence()
                if ev is not None and used.size >= 4:
                    a, cl = self._ac[ev.leader]
                    rs, sf = ev.fits[ev.leader]
                    mu = rs + sf / a[used] + cl[used]
                    mean = np.nanmean(v[0], axis=1)
                    rel = float(np.sum(((mean - mu) / mu) ** 2)) / (used.size - 2)
                    lack = math.sqrt(max(0.0, rel - within * float(np.mean(1.0 / n))))
                    src["lack_sd"] = "session"
        where = "session" if "session" in src["reseat_sd"] else self.prior.source
        return NoiseModel(series, reseat, lack, f"{where}; else {self.prior.source}"), src

    # -- expected evidence and the suggestion -------------------------------------------------------------------
    def _params(self, ev: Evidence | None) -> dict[str, tuple[float, float]]:
        """Plug-in (R_s ≥ 0, σ_f > 0) per model: the session's fits, else the prior."""
        if ev is None:
            return {k: (self.series, self.film) for k in self.models}
        return {k: (max(rs, 0.0), sf if sf > 0 else self.film) for k, (rs, sf) in ev.fits.items()}

    def _weights_pi(self, ev: Evidence | None) -> dict[str, float]:
        """Akaike weights π ∝ exp(−Δ/2) (uniform before there is evidence)."""
        if ev is None:
            return {k: 1.0 / len(self.models) for k in self.models}
        w = {k: math.exp(-0.5 * min(ev.delta[k], 700.0)) for k in self.models}
        total = sum(w.values())
        return {k: x / total for k, x in w.items()}

    def expected_delta(self, truth: str, other: str, counts: np.ndarray, params: tuple[float, float],
                       noise: NoiseModel) -> np.ndarray:  # fmt: skip
        """Expected Δ(Q)AIC of ``other`` behind ``truth`` for seatings ``counts`` per weight, shape (..., m): one value
        per row (module docstring); 0 where fewer than 3 weights are measured."""
        n = np.asarray(counts, dtype=float)
        a, cl = self._ac[truth]
        rs, sf = params
        mu = rs + sf / a + cl
        c2 = max(noise.series_sd**2 + noise.reseat_sd**2, 1e-8)
        with np.errstate(divide="ignore"):
            sigma = np.sqrt(c2) * mu / np.sqrt(n)  # inf where not measured: weight 0
        ao, co = self._ac[other]
        lam = fit_film_series(np.broadcast_to(mu, n.shape), sigma, ao, co).chi2
        used = np.count_nonzero(n > 0, axis=-1)
        e_chat = np.sum(np.where(n > 0, (noise.reseat_sd**2 + n * noise.lack_sd**2) / c2, 0.0), axis=-1) / np.maximum(
            used, 1)  # fmt: skip
        out = lam / np.where(e_chat > OVERDISPERSION, e_chat, 1.0)
        return np.where(used >= 3, np.nan_to_num(out), 0.0)

    def _pair_value(self, counts: np.ndarray, params: dict[str, tuple[float, float]], pi: dict[str, float],
                    noise: NoiseModel) -> np.ndarray:  # fmt: skip
        """Σ_{a<b} π_a π_b (Δ_ab + Δ_ba) / Σ π_a π_b over separable pairs (Box–Hill's weighting), per row of
        ``counts`` (..., m): :meth:`expected_delta` of every ordered pair in one vectorised fit."""
        n = np.asarray(counts, dtype=float)
        pairs = [(a, b) for a in self.models for b in self.models if b not in self.groups[a]]
        if not pairs:
            return np.zeros(n.shape[:-1])
        mu = np.array([params[a][0] + params[a][1] / self._ac[a][0] + self._ac[a][1] for a, _ in pairs])
        area = np.array([self._ac[b][0] for _, b in pairs])
        clean = np.array([self._ac[b][1] for _, b in pairs])
        weight = np.array([pi[a] * pi[b] for a, b in pairs])
        c2 = max(noise.series_sd**2 + noise.reseat_sd**2, 1e-8)
        shape = (len(pairs),) + (1,) * (n.ndim - 1) + (n.shape[-1],)
        with np.errstate(divide="ignore"):
            sigma = np.sqrt(c2) * mu.reshape(shape) / np.sqrt(n)  # inf where not measured: weight 0
        full = np.broadcast_shapes(sigma.shape, mu.reshape(shape).shape)
        lam = fit_film_series(np.broadcast_to(mu.reshape(shape), full), sigma, area.reshape(shape),
                              clean.reshape(shape)).chi2  # fmt: skip
        used = np.count_nonzero(n > 0, axis=-1)
        e_chat = np.sum(np.where(n > 0, (noise.reseat_sd**2 + n * noise.lack_sd**2) / c2, 0.0), axis=-1) / np.maximum(
            used, 1)  # fmt: skip
        delta = np.nan_to_num(lam) / np.where(e_chat > OVERDISPERSION, e_chat, 1.0)
        value = np.tensordot(weight, delta, axes=1) / (0.5 * weight.sum())  # both directions of each pair
        return np.where(used >= 3, value, 0.0)

    def _counts(self) -> np.ndarray:
        return np.array([len(s) for s in self.seatings], dtype=int)

    def _best(
        self,
        counts: np.ndarray,
        current: int | None,
        pending: int | None,
        params: dict[str, tuple[float, float]],
        pi: dict[str, float],
        noise: NoiseModel,
        at_seating: int = 1,
    ) -> Placement:
        """The placement of largest expected gain per minute from ``counts`` (the start design and a pending second
        seating first); ``at_seating``: blocks taken at the present seating."""
        crit = "expected gain in Δ(Q)AIC (Box–Hill weighting of model pairs) per minute of bench time"
        w = self.weights_kg
        if pending is not None:
            return Placement(float(w[pending]), "reseat", 1, 0.0, self.cost.of("reseat"), crit,
                             "second seating (the fit needs ≥ 2 at every weight)")  # fmt: skip
        start = [0, w.size - 1, int(np.argmin(np.abs(np.log(w) - 0.5 * np.log(w[0] * w[-1]))))]
        for i in start:
            if counts[i] == 0:
                return Placement(float(w[i]), "place", 2, 0.0, self.cost.of("place", 2), crit,
                                 "start: three loads spanning the range, two seatings each")  # fmt: skip
        m = w.size
        rows = np.vstack([counts, counts + np.diag(np.where(counts == 0, 2, 1))])
        values = self._pair_value(rows, params, pi, noise)
        gains = values[1:] - values[0]
        best: Placement | None = None
        for i in range(m):
            new = counts[i] == 0
            cost = self.cost.of("place", 2) if new else (
                self.cost.of("reseat") if i == current else self.cost.of("place", 1))  # fmt: skip
            cand = Placement(float(w[i]), "place" if new else "reseat", 2 if new else 1, float(gains[i]), cost, crit)
            if best is None or cand.gain_per_min > best.gain_per_min:
                best = cand
        assert best is not None
        if current is not None and counts[current] > 0:
            # one more block at the present seating shrinks only its instrument variance (block noise ≪ re-seating)
            a, cl = self._ac[max(pi, key=pi.__getitem__)]
            rs, sf = params[max(pi, key=pi.__getitem__)]
            mu = rs + sf / a[current] + cl[current]
            gain = self.repeat_share(mu, noise, at_seating) * float(gains[current])
            rep = Placement(float(w[current]), "repeat", 1, gain, self.cost.of("repeat"), crit)
            if rep.gain_per_min > best.gain_per_min:
                best = rep
        return best

    #: variance of one block's mean from the instruments alone [Ω²] (set by the caller when known; 1e-14: the
    #: simulated bench's block SD of 0.1 µΩ)
    _block_var = 1e-14

    def repeat_share(self, mu_ohm: float, noise: NoiseModel, blocks: int = 1) -> float:
        """The evidence one more block at the present seating (``blocks`` blocks there already) brings, as a share of
        a new seating's: the information 1/Var of the seating's mean gained, Var = s + v/n (s the seating's variance
        [Ω²] — series offset and re-seating, shared by its blocks —, v :attr:`_block_var`, n blocks: the one-way
        random-effects variance of a mean), against 1/(s + v) of a new seating:
        (s + v)·(1/(s + v/(n+1)) − 1/(s + v/n)); n = 1: v/(2s + v) — 1 when the instruments dominate, ≈ v/(2s)
        when the seating does (on the rig ~10⁻⁹: a repeat is never worth its block time)."""
        s = (noise.series_sd**2 + noise.reseat_sd**2) * mu_ohm**2
        v, n = self._block_var, max(int(blocks), 1)
        return (s + v) * (1.0 / (s + v / (n + 1)) - 1.0 / (s + v / n))

    def _blocks_at_seating(self) -> int:
        """Blocks taken at the present seating (0 before the first)."""
        if self.current is None or not self.seatings[self.current]:
            return 0
        return len(self.seatings[self.current][-1])

    def suggest(self) -> Placement:
        """The next placement (module docstring)."""
        ev = self.evidence()
        return self._best(self._counts(), self.current, self.pending, self._params(ev), self._weights_pi(ev),
                          self.noise()[0], self._blocks_at_seating())  # fmt: skip

    # -- separability, the forward simulation, the stop rule ----------------------------------------------------
    def _equivalents(self) -> dict[str, frozenset[str]]:
        """Models no session within the budget tells apart: the expected Δ(Q)AIC of the whole budget spread over the
        allowed weights (two seatings per placing, re-seats) below the threshold both ways, with the prior noise."""
        counts = np.full(self.weights_kg.size, self._seatings_in_budget())
        out: dict[str, set[str]] = {k: {k} for k in self.models}
        for i, a in enumerate(self.models):
            for b in self.models[i + 1 :]:
                dab = float(self.expected_delta(a, b, counts, (self.series, self.film), self.prior))
                dba = float(self.expected_delta(b, a, counts, (self.series, self.film), self.prior))
                if min(dab, dba) < self.threshold:
                    out[a].add(b)
                    out[b].add(a)
        return {k: frozenset(v) for k, v in out.items()}

    def _seatings_in_budget(self) -> int:
        """Seatings per allowed weight when the whole budget is spread over them (each placed once) [-], ≥ 2."""
        m, c = self.weights_kg.size, self.cost
        total = (self.budget_s - m * c.place_s + m * c.reseat_s) / (c.block_s + c.reseat_s)
        return max(2, int(total / m))

    def _future(self, ev: Evidence | None, noise: NoiseModel) -> list[int]:
        """Weight index of every future block if the suggestions are followed on the expected state until the
        budget is spent (at most 400 blocks)."""
        counts, current, pending = self._counts(), self.current, self.pending
        params, pi = self._params(ev), self._weights_pi(ev)
        left = self.budget_s - self.spent_s
        out: list[int] = []
        at_seating = self._blocks_at_seating()
        while len(out) < 400:
            p = self._best(counts, current, pending, params, pi, noise, at_seating)
            if p.cost_s > left:
                break
            left -= p.cost_s
            i = self.index_of(p.weight_kg)
            if p.action == "repeat":  # the evidence counts seatings: a repeat adds none
                out.append(-1 - i)
                at_seating += 1
                continue
            at_seating = 1
            # the same placement repeated for a share of the budget: at most ~16 greedy steps per forecast
            times = 1 if p.action == "place" or pending is not None else max(1, int(left / p.cost_s / 16))
            times = min(times, int(left // p.cost_s) + 1)
            left -= (times - 1) * p.cost_s
            out.extend([i] * (p.seatings * times))
            counts[i] += p.seatings * times
            current = i
            pending = i if counts[i] == 1 else None
        return out

    def predictive(self) -> float:
        """P(the session ends decisive within the remaining budget if it goes on as suggested) (module docstring);
        NaN before there is evidence."""
        ev = self.evidence()
        if ev is None:
            return math.nan
        if ev.decisive:
            return 1.0
        noise, _ = self.noise()
        future = [i for i in self._future(ev, noise) if i >= 0]
        if not future:
            return 0.0
        rng = np.random.default_rng([self.seed, 0x5E9, self.blocks])
        pi = self._weights_pi(ev)
        params = self._params(ev)
        n = self.n_forward
        truth = rng.choice(len(self.models), size=n, p=np.array([pi[k] for k in self.models]))
        counts0 = self._counts()
        total = counts0.copy()
        for i in future:
            total[i] += 1
        r = int(total.max())
        m = self.weights_kg.size
        values = np.full((n, m, r), np.nan)
        within = noise.series_sd**2 + noise.reseat_sd**2
        lack2 = noise.lack_sd**2
        mu = np.empty((n, m))
        contact = np.empty((n, m))
        for j, k in enumerate(self.models):
            a, cl = self._ac[k]
            rs, sf = params[k]
            sel = truth == j
            contact[sel] = sf / a + cl
            mu[sel] = rs
        # the lack of fit at each weight: about the session's estimate where measured (shrunk), else the prior's
        b_mean = np.zeros((n, m))
        b_sd = np.full((n, m), math.sqrt(lack2))
        for i, seats in enumerate(self.seatings):
            if not seats:
                continue
            obs = np.array([float(np.mean(s)) for s in seats])
            values[:, i, : obs.size] = obs
            resid = np.log(np.clip((obs[None, :] - mu[:, i : i + 1]) / contact[:, i : i + 1], 1e-12, None)).mean(-1)
            shrink = lack2 / (lack2 + within / obs.size) if lack2 > 0 else 0.0
            b_mean[:, i] = shrink * resid
            b_sd[:, i] = math.sqrt(lack2 * (1.0 - shrink))
        b = b_mean + b_sd * rng.standard_normal((n, m))
        filled = counts0.copy()
        checkpoints = set(np.unique(np.linspace(0, len(future) - 1, min(len(future), 20)).round().astype(int)).tolist())
        decisive = np.zeros(n, dtype=bool)
        for step, i in enumerate(future):
            f = np.exp(b[:, i] + math.sqrt(within) * rng.standard_normal(n) - 0.5 * (within + lack2))
            values[:, i, filled[i]] = mu[:, i] + f * contact[:, i]
            filled[i] += 1
            if step in checkpoints:
                decisive |= self._decisive_of(values, filled)
        return float(np.mean(decisive))

    def _decisive_of(self, values: np.ndarray, filled: np.ndarray) -> np.ndarray:
        used = np.flatnonzero(filled >= 2)
        if used.size < 3:
            return np.zeros(values.shape[0], dtype=bool)
        curves = _subset(self.curves, self._ac, used)
        judged, _, dof = _fits(values[:, used, : int(filled[used].max())], curves, self.weights_kg[used])
        return _decisive(judged, dof, self.threshold, self.groups)[0]

    def stop(self, p_decisive: float | None = None) -> tuple[str, str] | None:
        """("decisive" | "futile", reason) or None to go on; ``p_decisive`` from :meth:`predictive` when known."""
        ev = self.evidence()
        if ev is not None and ev.decisive:
            eq = f" (equivalent on this bench: {', '.join(_label(k) for k in ev.equivalent)})" if ev.equivalent else ""
            second = min((k for k in self.models if k not in self.groups[ev.leader]), key=lambda k: ev.delta[k])
            return "decisive", (
                f"decisive: {_label(ev.leader)}{eq} ahead of every other model, next {_label(second)} by "
                f"Δ{ev.criterion} = {ev.margin:.1f} ≥ {self.threshold:g} (ĉ = {ev.c_hat:.2g}, {self.blocks} blocks, "
                f"{self.spent_s / 60:.0f} min)"
            )
        if self.hopeless():
            return "futile", self.hopeless_reason()
        if self.spent_s >= self.budget_s:
            return (
                "futile",
                f"stop — the budget ({self.budget_s / 60:.0f} min) is spent without a decision: " + self.why()
                + "; what would: " + self.what_would_futile(),
            )  # fmt: skip
        if ev is None:
            return None
        p = self.predictive() if p_decisive is None else p_decisive
        if math.isfinite(p) and p < FUTILE_P:
            return "futile", (
                f"stop — P(decisive within the remaining {max(self.budget_s - self.spent_s, 0) / 60:.0f} min) = "
                f"{100 * p:.0f} % < {100 * FUTILE_P:.0f} %: with this scatter no placement tells these models apart; "
                + self.why()
                + "; what would: "
                + self.what_would_futile()
            )
        return None

    def hopeless(self) -> bool:
        """No model has a rival it could be told from within the budget (every pair equivalent on this bench, with
        the prior noise: :meth:`_equivalents`): the decisive rule can never be met, whatever the data, so
        P(decisive) = 0 before the first block — futile at once, no threshold involved."""
        return all(len(group) == len(self.models) for group in self.groups.values()) and len(self.models) > 1

    def _pair_reach(self) -> tuple[str, str, float]:
        """The most separable pair and its expected Δ(Q)AIC over the whole budget (the smaller of both ways), with
        the prior's noise, film and series (as :meth:`_equivalents`)."""
        counts = np.full(self.weights_kg.size, self._seatings_in_budget())
        params = (self.series, self.film)
        best = ("", "", -math.inf)
        for i, a in enumerate(self.models):
            for b in self.models[i + 1 :]:
                d = min(float(self.expected_delta(a, b, counts, params, self.prior)),
                        float(self.expected_delta(b, a, counts, params, self.prior)))  # fmt: skip
                if d > best[2]:
                    best = (a, b, d)
        return best

    def hopeless_reason(self) -> str:
        """The stop reason of a :meth:`hopeless` session: the prior noise, its source, the most separable pair's
        expected Δ(Q)AIC against the threshold, why and what would."""
        a, b, reach = self._pair_reach()
        when = "before the first block" if self.blocks == 0 else f"after {self.blocks} blocks"
        return (
            f"stop — futile {when}: with the prior noise ({self.prior.source}: series offset "
            f"{100 * self.prior.series_sd:.3g} %, re-seating {100 * self.prior.reseat_sd:.3g} %, lack of fit "
            f"{100 * self.prior.lack_sd:.3g} % of ln R) no pair of models is separable "
            f"within the budget of {self.budget_s / 60:.0f} min (the most separable, {_label(a)} and {_label(b)}, "
            f"reach an expected Δ(Q)AIC of {reach:.2g} of {self.threshold:g} with the whole budget spread over the "
            f"{self.weights_kg.size} allowed loads), so no session can end decisive; " + self.why()
            + "; what would: " + self.what_would_futile()
        )  # fmt: skip

    def difference(self, a: str, b: str) -> float:
        """The largest relative difference between ``a``'s curve and ``b``'s best fit to it over the allowed weights
        (what no R_s, σ_f absorbs) [-], with ``a``'s prior parameters."""
        ac, cc = self._ac[a]
        mu = self.series + self.film / ac + cc
        fit = fit_film_series(mu, mu, *self._ac[b])
        return float(np.max(np.abs(fit.predicted_ohm - mu) / mu))

    def _leading_pair(self) -> tuple[str, str | None]:
        """The leader (the first model before there is evidence) and its nearest rival (None: only one model)."""
        ev = self.evidence()
        if ev is None and len(self.models) > 1:  # before there is evidence: the most separable pair
            a, b, _ = self._pair_reach()
            return a, b
        lead = ev.leader if ev is not None else self.models[0]
        others = [k for k in self.models if k != lead]
        if ev is not None:
            others.sort(key=lambda k: ev.delta[k])
        return lead, (others[0] if others else None)

    def what_would(self) -> str:
        """What would make the leading pair separable within the budget (the expected Δ(Q)AIC of the whole budget
        spread over the allowed weights ≥ the threshold both ways, the prior's film and series): the largest SD of
        each noise component, the others as they are, that does it, and the factor by which all of them together
        would have to shrink. A first answer to "what would it take"; the load range is that of the bench."""
        lead, rival = self._leading_pair()
        if rival is None:
            return "nothing: only one model"
        noise, _ = self.noise()
        counts = np.full(self.weights_kg.size, self._seatings_in_budget())
        params = (self.series, self.film)

        def separable(nm: NoiseModel) -> bool:
            return bool(min(self.expected_delta(lead, rival, counts, params, nm),
                            self.expected_delta(rival, lead, counts, params, nm)) >= self.threshold)  # fmt: skip

        def largest(make: Any) -> float | None:
            return _largest_factor(lambda f: separable(make(f)))

        parts = []
        for comp, words in COMPONENT_WORDS.items():
            sd = getattr(noise, comp)
            f = largest(lambda x, c=comp, v=sd: dataclasses.replace(noise, **{c: x * v})) if sd > 0 else None
            if f is not None and f < 1.0:
                parts.append(f"{words} below {100 * f * sd:.2g} % (now {100 * sd:.2g} %)")
        scale = largest(lambda x: NoiseModel(x * noise.series_sd, x * noise.reseat_sd, x * noise.lack_sd))
        pair = f"{_label(lead)} and {_label(rival)}"
        within = f"within {self.budget_s / 60:.0f} min"
        if scale is None:
            return f"no noise reduction tells {pair} apart {within} on these loads: a wider load range or another bench"
        if scale >= 1.0:
            return f"{pair} are separable {within} with this noise, in expectation"
        alone = "; or ".join(parts) if parts else "no single component reduced alone is enough"
        return f"to tell {pair} apart {within}: {alone}; or every component × {scale:.3g}"

    # ---- hook (branch wwit, issue 27 "what it would take"): the futility message's simulated one-line summary ----
    def what_would_futile(self) -> str:
        """:meth:`what_would`, then the simulated study's one line for the leading pair
        (:func:`analysis.what_would_it_take.futility_summary`: design's own simulation on this bench)."""
        from analysis.what_would_it_take import futility_summary

        return self.what_would() + "; simulated: " + futility_summary(self)

    # ---- end of hook ------------------------------------------------------------------------------------------

    def why(self) -> str:
        """The reason the evidence does (not) move: the dominant noise component against the model difference."""
        noise, src = self.noise()
        lead, rival = self._leading_pair()
        if rival is None:
            return "only one model"
        # what limits the evidence: the lack of fit as it is (no repeat averages it), the others over the seatings
        # per weight the budget allows
        n = self._seatings_in_budget()
        effect = {k: getattr(noise, k) / (1.0 if k == "lack_sd" else math.sqrt(n)) for k in COMPONENT_WORDS}
        comp = max(effect, key=effect.__getitem__)
        size = getattr(noise, comp)
        diff = self.difference(lead, rival)
        rel = "larger" if size > diff else "smaller"
        prior = self.prior.source  # "noise from NAME" (a session file, --noise-from) reads as it is
        where = "from this session" if src[comp].startswith("session") else (
            prior if prior.startswith("noise from ") else f"from {prior}")  # fmt: skip
        return (
            f"{COMPONENT_WORDS[comp]}, {100 * size:.0f} % ({where}), is {rel} than the difference between "
            f"{_label(lead)} and {_label(rival)}, {100 * diff:.1f} %"
        )

    def report(self, *, predictive: bool = True) -> dict[str, Any]:
        """The state as plain data (JSON): evidence, noise components and their sources, the predictive probability,
        the suggestion, the stop decision and its reason, bench time and budget [s]."""
        ev = self.evidence()
        noise, src = self.noise()
        p = self.predictive() if predictive else math.nan
        stop = (self.stop(p if predictive else None) if ev is not None or self.spent_s >= self.budget_s
                or self.hopeless() else None)  # fmt: skip
        progress = 0.0 if ev is None else min(1.0, max(0.0, ev.margin / self.threshold)) if math.isfinite(
            ev.margin) else 0.0  # fmt: skip
        return {
            "blocks": self.blocks,
            "bench_time_s": self.spent_s,
            "budget_s": self.budget_s,
            "threshold": self.threshold,
            "evidence": None if ev is None else ev.as_dict(),
            "progress": progress,
            "noise": {
                k: {"sd": float(getattr(noise, k)), "source": src[k] if src[k] != "prior" else self.prior.source}
                for k in COMPONENT_WORDS
            },
            "p_decisive": _num(p),
            "suggestion": None if stop is not None else self.suggest().as_dict(),
            "stop": None if stop is None else {"status": stop[0], "reason": stop[1]},
            "why": self.why(),
            "what_would": self.what_would(),
        }


def _largest_factor(ok: Any) -> float | None:
    """The largest f in (0, 1] with ``ok(f)`` (monotone: true below some f), by bisection in log f; None when even
    f = 10⁻⁶ is not."""
    if ok(1.0):
        return 1.0
    if not ok(1e-6):
        return None
    lo, hi = 1e-6, 1.0
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _subset(curves: ModelCurves, ac: dict[str, tuple[np.ndarray, np.ndarray]], used: np.ndarray) -> ModelCurves:
    """``curves`` restricted to the allowed weights ``used`` (their A and clean terms precomputed)."""
    return _Fixed(curves.weight_kg, {k: v[0][used] for k, v in ac.items()}, {k: v[1][used] for k, v in ac.items()},
                  curves.geometry)  # fmt: skip


class _Fixed(ModelCurves):
    """Model curves at fixed weights (``at`` returns them, whatever is asked: the caller passes those weights)."""

    def at(self, model: str, weights_kg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.area_m2[model], self.clean_ohm[model]


# ---- the whole loop, simulated ---------------------------------------------------------------------------------


def simulate_loop(
    design: SequentialDesign,
    truth: str,
    rng: np.random.Generator,
    *,
    film_ohm_m2: float,
    series_ohm: float,
    noise: NoiseModel,
    block_sd_ohm: float = 1e-7,
    check_every: int = 4,
) -> tuple[str, str, float, int]:
    """One adaptive session on the simulated bench's physics (``design`` fresh): suggestion → block (ln f = a_k + b_i
    + e_ik, k the seating at weight i, as :func:`analysis.simulated_session.session_factors`; a repeat at the present
    seating keeps its f, only the block noise ``block_sd_ohm`` differs) → evidence → stop.
    Futility is checked every ``check_every`` blocks (the forward simulation is the costly part). Returns (status,
    leader, bench time [s], blocks)."""
    w = design.weights_kg
    m = w.size
    a, cl = design.curves.at(truth, w)
    series = noise.series_sd * rng.standard_normal(64)
    lack = noise.lack_sd * rng.standard_normal(m)
    var = noise.series_sd**2 + noise.reseat_sd**2 + noise.lack_sd**2
    if design.hopeless():  # futile before the first block (the prior makes every pair inseparable)
        return "futile", "", design.spent_s, design.blocks
    f = math.nan
    while True:
        p = design.suggest()
        i = design.index_of(p.weight_kg)
        for _ in range(p.seatings):
            if p.action != "repeat" or not math.isfinite(f):  # a repeat keeps the present seating's contact
                k = len(design.seatings[i])
                f = math.exp(series[k % 64] + lack[i] + noise.reseat_sd * rng.standard_normal() - 0.5 * var)
            value = float(bench_resistance_ohm(series_ohm, film_ohm_m2, a[i : i + 1], cl[i : i + 1], [[f]])[0, 0])
            design.ingest(p.weight_kg, value + block_sd_ohm * rng.standard_normal(), reseated=p.action != "repeat")
            ev = design.evidence()
            if ev is not None and ev.decisive:
                return "decisive", ev.leader, design.spent_s, design.blocks
            if design.spent_s >= design.budget_s:
                return "futile", "" if ev is None else ev.leader, design.spent_s, design.blocks
        if design.blocks % check_every < p.seatings and design.evidence() is not None:
            stop = design.stop()
            if stop is not None:
                ev = design.evidence()
                return stop[0], "" if ev is None else ev.leader, design.spent_s, design.blocks
