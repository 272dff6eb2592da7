"""What would it take to tell the contact models apart (``contactrig design --what-would-it-take``), issue 27.

For every model pair, on the scene's bench: the smallest reduction of each noise component of
:class:`analysis.noise_model.NoiseModel` — the per-series offset σ_a, the re-seating σ_e, the lack of fit common to
every series σ_b (Tab. 1: 9.6 %, 13.2 %, 14.5 % of ln R), each alone with the others as they are, and all three
together — and the load range that would make the pair discriminable in ≥ ``target`` (90 %) of sessions.

**No second statistic**: a point (load range, noise) is judged by :func:`analysis.design.design` itself — the same
simulated sessions (R = R_s + f·(σ_f/A_m(W) + R_clean,m(W)) + ε, f the noise model's log-normal factor), the same
closed-form fit of every model and the same decision rule (Δ(Q)AIC ≥ 10 both ways, QAIC when ĉ > 1.5, unphysical and
load-independent fits ranked last). A pair is *discriminable* at a point when one of the two richest of design's
candidate plans over that load range (:func:`analysis.design.candidate_plans`: the most loads × the most repeats,
over the whole range and over its upper half-decade) reaches ``target``: more loads and more repeats never tell less,
so what these plans cannot, no cheaper candidate can (within the Monte-Carlo error).

**Search**: load ranges [W_min, k·W_max] for k in ``range_factors`` (the scene's lower load kept: a heavier stack on
the rig, a larger press force); noise factors on a coarse grid (:data:`FACTORS`, from 1 = as now down to 0 = the
component removed); per pair, component and range the largest factor reaching the target is found by bisection on
the grid's index (the probability falls as the noise grows), every point evaluated once for all pairs (cached).
Monte-Carlo error of a probability p from N sessions: √(p(1−p)/N), 3 % at p = 0.9 and N = 100. **Seeds**: every
point uses the one generator ``numpy.random.default_rng(seed)`` of :func:`analysis.design.design` — common random
numbers, so the points differ only by the noise scale and the load range and the search is monotone up to the fit's
discrete decisions, not up to the sampling noise.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analysis.design import ModelCurves, Plan, candidate_plans, design, model_curves
from analysis.noise_model import NoiseModel

__all__ = [
    "ALL",
    "FACTORS",
    "RANGE_FACTORS",
    "LoadRange",
    "PairNeed",
    "WhatWouldItTake",
    "draw",
    "for_scene",
    "futility_summary",
    "summary",
    "table",
    "what_would_it_take",
]

#: Noise factors searched (× the present SD of a component; 0: the component removed), largest first.
FACTORS: tuple[float, ...] = (1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.125, 0.09, 0.06, 0.04, 0.025, 0.015, 0.01, 0.005, 0.0)
#: Upper loads searched, × the scene's largest load.
RANGE_FACTORS: tuple[float, ...] = (1.0, 1.5, 2.0, 3.0, 4.0)
#: The key of "every component scaled together".
ALL = "all"
#: Suffix of a component searched with the other components removed (which one limits).
ALONE = "|alone"
#: The noise components and their words (those of :mod:`analysis.sequential`'s messages).
COMPONENTS: dict[str, str] = {
    "series_sd": "the per-series offset",
    "reseat_sd": "the re-seating scatter",
    "lack_sd": "the lack of fit common to every series",
    ALL: "every noise component",
}


def _words(comp: str) -> str:
    base = comp.removesuffix(ALONE)
    return COMPONENTS[base] + (", the others removed" if comp.endswith(ALONE) else "")


def _components(noise: NoiseModel) -> list[str]:
    """Searched: each component present (SD > 0) with the others as now, each with the others removed (when there
    are others), and all together."""
    present = [c for c in COMPONENTS if c != ALL and getattr(noise, c) > 0]
    return present + ([c + ALONE for c in present] if len(present) > 1 else []) + [ALL]


@dataclass(frozen=True)
class _Memo(ModelCurves):
    """Model curves whose interpolation is kept per model and weights (the study asks the same ones many times)."""

    memo: dict[tuple[str, bytes], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False,
                                                                         compare=False)  # fmt: skip

    def at(self, model: str, weights_kg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = (model, np.asarray(weights_kg, dtype=float).tobytes())
        if key not in self.memo:
            self.memo[key] = super().at(model, weights_kg)
        return self.memo[key]


def _memo(curves: ModelCurves) -> ModelCurves:
    if type(curves) is not ModelCurves:  # a subclass with its own ``at``: kept as it is
        return curves
    return _Memo(curves.weight_kg, curves.area_m2, curves.clean_ohm, curves.geometry)


@dataclass(frozen=True)
class LoadRange:
    """One load range [kg]: ``w_min``–``w_max``, the model curves over it and the plans judged on it."""

    w_min: float
    w_max: float
    curves: ModelCurves = field(repr=False)
    plans: tuple[Plan, ...]


@dataclass(frozen=True)
class PairNeed:
    """What one model pair needs. ``now[j]``: the pair's probability (both ways, the better plan) at load range j
    with the present noise; ``largest[c][j]``: the largest factor of :data:`FACTORS` (× the present SD of component
    c, or of all of them for :data:`ALL`) that reaches the target at range j, None when even 0 does not."""

    models: tuple[str, str]
    now: tuple[float, ...]
    largest: dict[str, tuple[float | None, ...]]


@dataclass(frozen=True)
class WhatWouldItTake:
    """The study (module docstring): ``ranges`` searched, ``pairs``' needs, the ``noise`` now, the Monte Carlo's
    ``n_sessions`` per point and ``seed``, ``points`` evaluated."""

    geometry: str
    noise: NoiseModel
    ranges: tuple[LoadRange, ...]
    pairs: tuple[PairNeed, ...]
    n_sessions: int
    seed: int
    target: float
    points: int

    @property
    def mc_error(self) -> float:
        """Monte-Carlo SE of a probability at the target [-]: √(p(1−p)/N)."""
        return math.sqrt(self.target * (1 - self.target) / self.n_sessions)

    @property
    def components(self) -> list[str]:
        """The components searched (:func:`_components`)."""
        return _components(self.noise)

    def pair(self, a: str, b: str) -> PairNeed:
        """The need of the pair {a, b} (either order)."""
        for p in self.pairs:
            if set(p.models) == {a, b}:
                return p
        raise KeyError(f"{a} vs {b}")


def _scaled(noise: NoiseModel, component: str, factor: float) -> NoiseModel:
    if component == ALL:
        return NoiseModel(factor * noise.series_sd, factor * noise.reseat_sd, factor * noise.lack_sd, noise.source)
    if component.endswith(ALONE):
        comp = component.removesuffix(ALONE)
        return dataclasses.replace(NoiseModel(0.0, 0.0, 0.0, noise.source), **{comp: factor * getattr(noise, comp)})
    return dataclasses.replace(noise, **{component: factor * getattr(noise, component)})


def _get(scores: dict[tuple[str, str], float], pair: tuple[str, str]) -> float:
    return scores[pair] if pair in scores else scores[(pair[1], pair[0])]


def _bisect(ok: Callable[[int], bool]) -> float | None:
    """The largest factor of :data:`FACTORS` with ``ok(index)`` (monotone: true from some index on), by bisection on
    the index; None when not even the last (0) is."""
    last = len(FACTORS) - 1
    if ok(0):
        return FACTORS[0]
    if not ok(last):
        return None
    lo, hi = 0, last  # not ok at lo, ok at hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return FACTORS[hi]


def richest_plans(w_min: float, w_max: float, block_s: float) -> tuple[Plan, ...]:
    """The most loads × the most repeats of :func:`analysis.design.candidate_plans` over [w_min, w_max] kg, one per
    load set (whole range, upper half-decade)."""
    plans = candidate_plans(w_min, w_max, block_s)
    n = max(len(p.weights_kg) for p in plans)
    r = max(p.repeats for p in plans)
    return tuple(p for p in plans if len(p.weights_kg) == n and p.repeats == r)


def what_would_it_take(
    ranges: Sequence[LoadRange],
    noise: NoiseModel,
    *,
    n_sessions: int = 100,
    seed: int = 0,
    target: float = 0.9,
    film_ohm_m2: float = 2.2e-9,
    series_ohm: float = 0.0,
    pairs: Sequence[tuple[str, str]] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> WhatWouldItTake:
    """The study over ``ranges`` (the scene's first) for ``pairs`` (default: every pair of the first range's
    models), every point judged by :func:`analysis.design.design` (module docstring); ``progress(done, most)``
    after each point evaluated (most: the whole grid)."""
    from contactrig.core.validation import SettingError, check_int, check_range

    check_int("n_sessions", n_sessions, 2)
    check_range("target", target, 0.0, 1.0, lo_open=True, hi_open=True)
    if not ranges:
        raise SettingError("ranges", "[]", "expected at least one load range")
    models = list(ranges[0].curves.area_m2)
    wanted = list(pairs) if pairs is not None else [(a, b) for i, a in enumerate(models) for b in models[i + 1 :]]
    comps = _components(noise)
    memo = [_memo(r.curves) for r in ranges]
    cache: dict[tuple[int, str, int], dict[tuple[str, str], float]] = {}
    most = len(ranges) * (1 + len(comps) * (len(FACTORS) - 1))

    def score(j: int, comp: str, k: int) -> dict[tuple[str, str], float]:
        key = (j, ALL, 0) if k == 0 else (j, comp, k)  # factor 1: the present noise, whatever the component
        if key not in cache:
            rng = ranges[j]
            scaled = _scaled(noise, comp, FACTORS[k])
            res = design(memo[j], list(rng.plans), film_ohm_m2=film_ohm_m2, series_ohm=series_ohm,
                         n_sessions=n_sessions, target=target, seed=seed, noise=scaled)  # fmt: skip
            cache[key] = {p: float(np.max(s)) for p, s in res.pair_score.items()}
            if progress is not None:
                progress(len(cache), most)
        return cache[key]

    def ok(j: int, comp: str, k: int, *, pair: tuple[str, str]) -> bool:
        return _get(score(j, comp, k), pair) >= target

    needs = []
    for pair in wanted:
        largest: dict[str, tuple[float | None, ...]] = {}
        for comp in comps:
            largest[comp] = tuple(_bisect(functools.partial(ok, j, comp, pair=pair)) for j in range(len(ranges)))
        now = tuple(_get(score(j, ALL, 0), pair) for j in range(len(ranges)))
        needs.append(PairNeed(pair, now, largest))
    return WhatWouldItTake(ranges[0].curves.geometry, noise, tuple(ranges), tuple(needs), n_sessions, seed, target,
                           len(cache))  # fmt: skip


def for_scene(
    scene: Any,
    noise: NoiseModel,
    block_s: float,
    *,
    range_factors: Sequence[float] = RANGE_FACTORS,
    **kw: Any,
) -> WhatWouldItTake:
    """The study on a scene's bench: its load range as ``contactrig design`` takes it (the press's range, the rig's
    2–26 kg) and wider upper loads (``range_factors`` × its largest), each with design's 10-point model grid and its
    richest plans (:func:`richest_plans`, ``block_s`` the block time [s]); ``kw`` to :func:`what_would_it_take`."""
    from contactrig.core.validation import check_range
    from sims.config import SimConfig

    for k in range_factors:
        check_range("range_factors", k, 1.0, 100.0)  # the scene's range and wider ones
    config = SimConfig.from_scene(scene)
    w_min, w_max = (min(config.weights_kg), max(config.weights_kg)) if config.press is not None else (2.0, 26.0)
    ranges = []
    for k in range_factors:
        top = float(f"{k * w_max:.4g}")
        curves = model_curves(scene, np.geomspace(w_min, top, 10))
        ranges.append(LoadRange(w_min, top, curves, richest_plans(w_min, top, block_s)))
    return what_would_it_take(ranges, noise, **kw)


# ---- words -----------------------------------------------------------------------------------------------------
def _label(model: str) -> str:
    from sims.models import model_label

    return model_label(model)


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def _sd(result: WhatWouldItTake, comp: str) -> float:
    return getattr(result.noise, comp.removesuffix(ALONE))


def _option(result: WhatWouldItTake, need: PairNeed, comp: str, j: int) -> str:
    """One change in words: a component from its SD now to the largest SD that reaches the target, at range j."""
    r = result.ranges[j]
    f = need.largest[comp][j]
    assert f is not None
    loads = f"loads {r.w_min:g}–{r.w_max:g} kg"
    if f >= 1.0 and not comp.endswith(ALONE):
        return f"{loads} at the present noise"
    if comp == ALL:
        what = "every noise component removed" if f == 0 else f"every noise component × {f:g}"
    else:
        sd = _sd(result, comp)
        what = f"{_words(comp)} from {_pct(sd)} to {'0' if f == 0 else 'below ' + _pct(f * sd)}"
    return f"{what} with {loads}"


def options(result: WhatWouldItTake, need: PairNeed) -> list[str]:
    """The changes that make ``need``'s pair discriminable, the one that matters most first: at the smallest load
    range where any single component (the others as now) reaches it, each such component by the least reduction
    (largest factor) first; then all components together, at the smallest load range where that reaches it, when
    that range is smaller (or no single component does); empty when nothing on the grid does."""
    singles = [c for c in result.components if c != ALL and not c.endswith(ALONE)]
    found: list[str] = []
    first = len(result.ranges)
    for j in range(len(result.ranges)):
        best = sorted(((need.largest[c][j], c) for c in singles if need.largest[c][j] is not None),
                      key=lambda fc: -float(fc[0] or 0.0))  # fmt: skip
        if best:
            found, first = [_option(result, need, c, j) for _, c in best], j
            break
    together = next((j for j in range(len(result.ranges)) if need.largest[ALL][j] is not None), None)
    if together is not None and together < first:
        found.append(_option(result, need, ALL, together))
    return found


def limiting(result: WhatWouldItTake, need: PairNeed, j: int = 0) -> str | None:
    """What matters most at load range j [words]: the component that must shrink by the largest factor even with the
    others removed; None when there is only one component or they all need the same."""
    alone = [c for c in result.components if c.endswith(ALONE)]
    if not alone:
        return None
    factor = {c: -1.0 if need.largest[c][j] is None else float(need.largest[c][j] or 0.0) for c in alone}
    worst = min(factor, key=factor.__getitem__)
    if all(factor[c] == factor[worst] for c in alone):
        return None

    def told(c: str) -> str:
        sd = _sd(result, c)
        f = factor[c]
        if f < 0:
            return f"{_pct(sd)} → not even removed"
        if f >= 1:
            return f"{_pct(sd)} as now"
        return f"{_pct(sd)} → 0 (removed)" if f == 0 else f"{_pct(sd)} → ≤ {_pct(f * sd)} (÷ {1 / f:.2g})"

    words = {c: COMPONENTS[c.removesuffix(ALONE)] for c in alone}
    rest = ", ".join(f"{words[c]} {told(c)}" for c in alone if c != worst)
    return (f"what matters most: {words[worst]}, {told(worst)} even with the others removed (each alone: {rest}; "
            f"loads to {result.ranges[j].w_max:g} kg)")  # fmt: skip


def summary(result: WhatWouldItTake, pair: tuple[str, str] | None = None) -> str:
    """One line: what would tell ``pair`` (default: the pair nearest to discriminable now) apart in ≥ target of
    sessions — the change that matters most first, then the limiting component."""
    need = result.pair(*pair) if pair is not None else max(result.pairs, key=lambda p: p.now[0])
    a, b = need.models
    head = f"to tell {_label(a)} from {_label(b)} in ≥ {100 * result.target:.0f} % of sessions"
    found = options(result, need)
    most = limiting(result, need)
    tail = "" if most is None else f"; {most}"
    if not found:
        top = result.ranges[-1]
        return (f"{head}: no noise reduction on the grid with loads up to {top.w_max:g} kg does it — another bench or "
                f"other observables{tail}")  # fmt: skip
    return f"{head}: " + "; or ".join(found) + tail


def table(result: WhatWouldItTake) -> str:
    """Markdown table: per pair and component, the largest SD reaching the target at each load range ('—': none)."""
    ranges = result.ranges
    head = "| pair | P now | component (now) | " + " | ".join(f"to {r.w_max:g} kg" for r in ranges) + " |"
    lines = [head, "|" + "---|" * (3 + len(ranges))]
    for need in result.pairs:
        pair = f"{_label(need.models[0])} vs {_label(need.models[1])}"
        for i, comp in enumerate(result.components):
            cells = []
            for f in need.largest[comp]:
                if f is None:
                    cells.append("—")
                elif comp == ALL:
                    cells.append(f"× {f:g}")
                else:
                    cells.append(_pct(f * _sd(result, comp)))
            now = f"{100 * need.now[0]:.0f} %" if i == 0 else ""
            comp_now = "all, × 1 now" if comp == ALL else f"{_words(comp)} ({_pct(_sd(result, comp))})"
            lines.append(f"| {pair if i == 0 else ''} | {now} | {comp_now} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def statement(result: WhatWouldItTake) -> str:
    """The study in words: what a cell means, the Monte Carlo and the seed, then one line per pair."""
    plans = "; ".join(f"{len(p.weights_kg)} loads {p.weights_kg[0]:g}–{p.weights_kg[-1]:g} kg × {p.repeats}"
                      for p in result.ranges[0].plans)  # fmt: skip
    lines = [
        f"What would it take ({result.geometry}): for each pair, the largest SD of each noise component (the others "
        f"as now; '—': not even removing it) at which the pair is told apart in ≥ {100 * result.target:.0f} % of "
        f"simulated sessions, per load range (upper load; lower {result.ranges[0].w_min:g} kg), by design's fit rule "
        f"with its richest plans ({plans} at the scene's range). {result.n_sessions} sessions per point (Monte-Carlo "
        f"SE {100 * result.mc_error:.0f} % at the target), seed {result.seed}, {result.points} points.",
        result.noise.describe() + ".",
    ]
    lines += [f"- {summary(result, p.models)}" for p in result.pairs]
    return "\n".join(lines)


def _range_dict(r: LoadRange) -> dict[str, Any]:
    plans = [{"weights_kg": list(p.weights_kg), "repeats": p.repeats, "cost_s": p.cost_s} for p in r.plans]
    return {"w_min_kg": r.w_min, "w_max_kg": r.w_max, "plans": plans}


def as_dict(result: WhatWouldItTake) -> dict[str, Any]:
    """Plain data (``design --what-would-it-take --json``): SDs and probabilities as fractions."""
    return {
        "geometry": result.geometry,
        "noise": result.noise.as_dict(),
        "target": result.target,
        "sessions_per_point": result.n_sessions,
        "monte_carlo_se": result.mc_error,
        "seed": result.seed,
        "points": result.points,
        "factors": list(FACTORS),
        "load_ranges": [_range_dict(r) for r in result.ranges],
        "pairs": [
            {
                "models": list(p.models),
                "probability_now": list(p.now),
                "largest_factor": {c: list(v) for c, v in p.largest.items()},
                "summary": summary(result, p.models),
            }
            for p in result.pairs
        ],
    }


# ---- the figure --------------------------------------------------------------------------------------------------
def draw(result: WhatWouldItTake, path: str | Path, *, force: bool = False) -> Path:
    """Per pair a panel: upper load [kg] (x) × noise factor (y, × the present SD): for each component the largest
    factor reaching the target (a step line; dotted: with the other components removed), the region below it —
    reachable with the others as now, or all scaled together — shaded; written to ``path``
    atomically (refused if it exists, unless ``force``). matplotlib is imported here."""
    from analysis.figure_style import DIMENSIONLESS
    from analysis.figures import _figure, save_figure_file

    comps = result.components
    n = len(result.pairs)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig, axes = _figure(ncols=cols, nrows=rows, size=(3.0 * cols + 1.0, 2.6 * rows + 0.9), sharex=True, sharey=True)
    x = np.array([r.w_max for r in result.ranges])
    colours = {"series_sd": "tab:blue", "reseat_sd": "tab:orange", "lack_sd": "tab:green", ALL: "0.3"}
    for i, need in enumerate(result.pairs):
        ax = axes[i // cols, i % cols]
        for comp in comps:
            y = np.array([np.nan if f is None else f for f in need.largest[comp]])
            alone = comp.endswith(ALONE)
            if not alone:  # reachable as the bench is, but for this component (or all of them scaled)
                ax.fill_between(x, 0.0, np.nan_to_num(y, nan=0.0), step="mid", color=colours[comp], alpha=0.15,
                                lw=0)  # fmt: skip
            ax.step(x, y, where="mid", color=colours[comp.removesuffix(ALONE)], lw=1.2 if alone else 1.6,
                    ls=":" if alone else "--" if comp == ALL else "-", marker="o", ms=2 if alone else 3,
                    label=_words(comp) if i == 0 else None)  # fmt: skip
        ax.set_title(f"{_label(need.models[0])} vs {_label(need.models[1])}", fontsize=8)
        ax.set_yscale("symlog", linthresh=0.01, linscale=0.3)  # factors span 0.005…1, and 0 (removed)
        ax.set_ylim(0.0, 1.1)
        ax.set_xscale("log")
    for k in range(n, rows * cols):  # empty cells: the panel above shows the load axis
        axes.flat[k].set_visible(False)
        axes.flat[k - cols].xaxis.set_tick_params(labelbottom=True)
        axes.flat[k - cols].set_xlabel("upper load [kg]")
    for ax in axes[-1, : n - (rows - 1) * cols]:
        ax.set_xlabel("upper load [kg]")
    for ax in axes[:, 0]:
        ax.set_ylabel(f"× the present SD {DIMENSIONLESS}")
    fig.suptitle(
        f"{result.geometry}: reachable (shaded) — told apart in ≥ {100 * result.target:.0f} % of sessions", fontsize=9
    )
    fig.legend(loc="outside lower center", ncols=min(len(comps), 4), fontsize=7.5)
    return save_figure_file(fig, path, force=force)


# ---- the futility message of an adaptive session ----------------------------------------------------------------
_FUTILE: dict[tuple[Any, ...], WhatWouldItTake] = {}


def futility_summary(session: Any, *, n_sessions: int = 60, seed: int = 0) -> str:
    """One line for the futility message of :class:`analysis.sequential.SequentialDesign` ``session``: the study
    on its bench's weights only (its curves cover no wider range) for its leading pair, with its prior noise (the
    noise the bench was planned with; a session's own: ``design --noise-from SESSION.h5 --what-would-it-take``) and
    a plan of every allowed weight × the seatings its budget allows; the rival: the nearest one that the session can
    tell from the leader at all (not *equivalent on this bench*, when there is one); cached per bench, prior and
    budget."""
    ev = session.evidence()
    lead = ev.leader if ev is not None else session.models[0]
    rivals = [k for k in session.models if k not in session.groups[lead]] or [k for k in session.models if k != lead]
    if not rivals:
        return "what would: nothing (only one model)"
    if ev is not None:
        rivals.sort(key=lambda k: ev.delta[k])
    w = tuple(float(x) for x in session.weights_kg)
    cost = session.cost
    per_seating = cost.block_s + cost.reseat_s
    repeats = max(2, int((session.budget_s / len(w) - cost.place_s) // per_seating))
    wa = np.array(w)
    shape = b"".join(np.concatenate(session.curves.at(m, wa)).tobytes() for m in session.models)
    key = (tuple(session.models), shape, w, session.prior, repeats, session.film, session.series, n_sessions, seed)
    if key not in _FUTILE:
        plan = Plan(w, repeats, len(w) * (cost.place_s + repeats * per_seating))
        rng = LoadRange(w[0], w[-1], session.curves, (plan,))
        _FUTILE[key] = what_would_it_take([rng], session.prior, n_sessions=n_sessions, seed=seed,
                                          film_ohm_m2=session.film, series_ohm=session.series)  # fmt: skip
    res = _FUTILE[key]
    how = f"simulated, {n_sessions} sessions of {len(w)} loads × {repeats} seatings, {res.noise.source}"
    return f"{summary(res, (lead, rivals[0]))} ({how}; wider load ranges: contactrig design --what-would-it-take)"
