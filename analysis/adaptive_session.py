"""An adaptive bench session (``contactrig acquire --adaptive``): the steps chosen as the session goes, by
:class:`analysis.sequential.SequentialDesign` (issue 27).

:class:`AdaptiveSteps` is both what the acquisition engine carries out (an iterable of :class:`daq.plan.PlaceWeight`
and :class:`daq.plan.Measure`, produced one placement at a time) and a writer that ingests every block as it is
written. Before each placement it asks the design for its suggestion; the operator (``choose``) takes it or names
another allowed weight, or stops; unattended (``--yes``) the suggestion is followed. It ends when the design stops
(decisive, futile) and says why (the engine puts ``stop_reason`` in the stop record); ``record()`` — every
suggestion, the evidence behind it and what the operator did, and the stop decision — goes into the stop record
(session schema 4) and ``settings()`` into the start record, so that :func:`replay_suggestions` rebuilds the design
from the file and reproduces every suggestion bit for bit. Each suggestion is also its block's own record (schema 5:
:class:`daq.plan.Measure`'s ``adaptive``, written and flushed with the first block it led to), so a killed session
keeps the suggestions of all its blocks and replays them too.

Block numbers: the j-th block (j = 0, 1, …) at the plan's weight i is block i·R + j, R the plan's ``repeats``
raised to the most seatings the budget allows at one weight (:func:`adaptive_plan`); its ``repeat`` is the number of
its seating at that weight (1, 2, …). A block taken on a "repeat at the present seating" suggestion keeps the
seating's number — consecutive blocks with one weight and one ``repeat`` are one seating — and is measured without
lifting the weight (no prompt to place it; the simulated bench keeps the seating's contact factor,
:class:`daq.plan.Measure`'s ``seating_block``); every other block is a new seating (the simulated bench's factor of
that block: series offset j, lack of fit i, re-seating). The design (:meth:`SequentialDesign.ingest` with
``seating``), ``fit`` (:meth:`analysis.measured.MeasuredCurve.from_summary`: a seating's blocks averaged into one
repeat) and :func:`replay_suggestions` read the seatings from the file by that rule.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from analysis.noise_model import NoiseModel
from analysis.sequential import DECISIVE_DELTA, CostModel, Placement, SequentialDesign
from daq.plan import Measure, PlaceWeight, SessionPlan, block_duration_s

__all__ = [
    "AdaptiveSteps",
    "adaptive_plan",
    "adaptive_source",
    "build_design",
    "evidence_line",
    "file_prior",
    "recorded_suggestions",
    "replay_suggestions",
    "session_design",
    "session_evidence",
    "session_state",
    "terminal_chooser",
]

#: Default bench-time budget of an adaptive session [min] (``--budget-min``).
DEFAULT_BUDGET_MIN = 60.0

#: The operator's answer to a suggestion (the placement, the state, the allowed weights [kg]): a weight [kg] to place
#: (the suggested one: take it), or None: stop.
Chooser = Callable[[Placement, Mapping[str, Any], Sequence[float]], float | None]


def _cost(plan: SessionPlan) -> CostModel:
    from daq.plan import OPERATOR_ALLOWANCE_S

    block = block_duration_s(plan.block_settings)
    return CostModel(block_s=float(block) if block else 3.0, place_s=OPERATOR_ALLOWANCE_S)


def adaptive_plan(plan: SessionPlan, budget_min: float) -> SessionPlan:
    """``plan`` with ``repeats`` raised to the most seatings the budget allows at one weight (≤ 1000): the block
    numbers of an adaptive session (module docstring)."""
    cost = _cost(plan)
    cap = int(min(1000, max(plan.session.repeats, math.ceil(60 * budget_min / (cost.block_s + cost.reseat_s)))))
    return dataclasses.replace(plan, session=dataclasses.replace(plan.session, repeats=cap))


#: The prior noise of a session file (``--noise-from``): the model and where it came from (file name, content id).
Prior = tuple[NoiseModel, dict[str, str]]


def file_prior(path: str) -> Prior:
    """The prior noise of ``acquire --adaptive --noise-from SESSION.h5``: what ``design --noise-from`` estimates
    from that file (:func:`analysis.noise_model.session_noise`, no second estimator), its source said as "noise from
    NAME", and the file's name and content id (recorded in the start record's ``adaptive.noise_from``)."""
    from analysis.noise_model import session_noise

    noise, origin = session_noise(path)
    return dataclasses.replace(noise, source=f"noise from {origin['file']}"), origin


def settings_of(
    plan: SessionPlan, budget_min: float, *, simulated: bool, seed: int = 0, prior: Prior | None = None
) -> dict[str, Any]:
    """The design's settings for the start record: budget, threshold, cost model, the prior noise model (``prior``,
    :func:`file_prior`, with ``noise_from`` where it came from; else the simulated bench's with ``--sim``, else Tab.
    1's), the prior film and series (the scene's circuit), the seed. A replay rebuilds the design from these alone
    (the recorded prior, not the other file)."""
    from analysis.circuit import CircuitSettings
    from analysis.noise_model import noise_model, tab1_noise

    if prior is not None:
        noise = prior[0]
    else:
        noise = noise_model(plan.session.sim_noise, plan.session.sim_repeat_sd) if simulated else tab1_noise()
    circuit = CircuitSettings.from_scene(plan.scene)
    origin = {"noise_from": dict(prior[1])} if prior is not None else {}
    return {
        "budget_s": 60.0 * float(budget_min),
        "threshold": DECISIVE_DELTA,
        "cost": dataclasses.asdict(_cost(plan)),
        "noise": noise.as_dict(),
        **origin,
        "film_ohm_m2": circuit.resistivity_ohm_m * circuit.contact_height_m,
        "series_ohm": circuit.series_resistance_ohm,
        "weights_kg": [float(w) for w in plan.session.weights_kg],
        "seed": int(seed),
        "criterion": "expected gain in Δ(Q)AIC (Box–Hill weighting of model pairs) per minute of bench time",
    }


#: model curves of the scenes seen (``watch`` re-reads a session every few seconds; the rig takes seconds to build)
_CURVES: dict[str, Any] = {}


def build_design(scene: Any, settings: Mapping[str, Any]) -> SequentialDesign:
    """The :class:`SequentialDesign` of ``settings`` (:func:`settings_of`, or a start record's ``adaptive``)."""
    from analysis.design import model_curves

    weights = [float(w) for w in settings["weights_kg"]]
    noise = NoiseModel(**settings["noise"])
    key = json.dumps([scene.text, sorted(set(weights))])
    if key not in _CURVES:
        _CURVES.clear()
        _CURVES[key] = model_curves(scene, sorted(set(weights)))
    return SequentialDesign(
        _CURVES[key], weights, CostModel(**settings["cost"]),
        budget_s=float(settings["budget_s"]), noise=noise, film_ohm_m2=float(settings["film_ohm_m2"]),
        series_ohm=float(settings["series_ohm"]), threshold=float(settings["threshold"]), seed=int(settings["seed"]),
    )  # fmt: skip


class AdaptiveSteps:
    """The steps of an adaptive session and the writer that feeds its blocks to the design (module docstring).

    ``choose``: the operator's answer to each suggestion (None: follow every suggestion, ``--yes``); ``say``: where
    a line about the evidence goes after each block (the live display's message); ``paused``: a context in which
    the operator is asked (the live display paused).
    """

    def __init__(self, plan: SessionPlan, design: SequentialDesign, *, choose: Chooser | None = None) -> None:
        self.plan = plan
        self.design = design
        self.choose = choose
        self.say: Callable[[str], None] = lambda text: None
        self.paused: Callable[[], contextlib.AbstractContextManager[Any]] = contextlib.nullcontext
        self.entries: list[dict[str, Any]] = []
        self.stop_reason = ""
        self.decision: dict[str, Any] | None = None
        self.last: dict[str, Any] | None = None
        self.settings: dict[str, Any] = {}
        n = len(plan.session.weights_kg)
        self._taken = [0] * n  # blocks numbered per weight of the plan (block = weight index × R + this)
        self._seated = [0] * n  # seatings per weight (a block's ``repeat``: the number of its seating)
        self._first = [0] * n  # the first block of each weight's present seating
        self._at: int | None = None  # the weight of the present seating

    def plan_lines(self) -> list[str]:
        """What ``acquire`` prints at the start of an adaptive session."""
        d = self.design
        how = self.settings.get("criterion", "expected gain per minute")
        return [
            f"adaptive session: budget {d.budget_s / 60:.0f} min; placements "
            f"{', '.join(f'{w:g}' for w in d.weights_kg)} kg; next placement by {how}",
            f"stops decisive (Δ(Q)AIC ≥ {d.threshold:g} over every separable rival), futile (P(decisive within the "
            f"budget) < 5 %) or by the operator; prior noise: {d.prior.describe()}{_origin(self.settings)}",
        ]

    # -- the engine's steps -------------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[PlaceWeight | Measure]:
        weights = [float(w) for w in self.plan.session.weights_kg]
        cap = self.plan.session.repeats
        while True:
            state = self.design.report()
            self.last = state
            if state["stop"] is not None:
                self.decision = state["stop"]
                self.stop_reason = str(state["stop"]["reason"])
                return
            placement = self.design.suggest()
            chosen = placement.weight_kg
            if self.choose is not None:
                with self.paused():
                    answer = self.choose(placement, state, [float(w) for w in self.design.weights_kg])
                if answer is None:
                    self._log(state, "stopped the session")
                    self.decision = {"status": "operator", "reason": "the operator stopped the session"}
                    self.stop_reason = "operator: stopped at the suggestion " + placement.describe()
                    return
                chosen = float(answer)
            took = math.isclose(chosen, placement.weight_kg, rel_tol=1e-9)
            entry: dict[str, Any] | None = self._log(state, "took the suggestion" if took else
                                                     f"placed {chosen:g} kg instead")  # fmt: skip
            wi = next(j for j, w in enumerate(weights) if math.isclose(w, chosen, rel_tol=1e-9))
            # a repeat at the present seating: the weight stays where it is (no prompt to place it)
            repeat = took and placement.action == "repeat" and self._at == wi
            for _ in range(placement.seatings if took else 1):
                if self._taken[wi] >= cap:
                    self.decision = {"status": "futile", "reason": f"no block left at {chosen:g} kg"}
                    self.stop_reason = f"stop — every block the plan numbers at {chosen:g} kg is taken ({cap})"
                    return
                block = wi * cap + self._taken[wi]
                self._taken[wi] += 1
                if not repeat:
                    self._seated[wi] += 1
                    self._first[wi] = block
                    self._at = wi
                    yield PlaceWeight(weight_index=wi, weight_kg=chosen, repeats_left=1)
                # the suggestion goes with the first block it led to: written and flushed with that block
                yield Measure(block=block, weight_index=wi, weight_kg=chosen, repeat=self._seated[wi], adaptive=entry,
                              seating_block=self._first[wi] if repeat else None)  # fmt: skip
                entry = None

    def _log(self, state: Mapping[str, Any], action: str) -> dict[str, Any]:
        """Keep the suggestion of ``state``, the evidence behind it and the operator's ``action``; returns the
        record (plain JSON data) that goes with the block it leads to."""
        ev = state["evidence"]
        self.entries.append({
            "block": self.design.blocks,
            "suggestion": state["suggestion"],
            "evidence": ev,
            "p_decisive": state["p_decisive"],
            "progress": state["progress"],
            "noise": state["noise"],
            "operator": action,
        })  # fmt: skip
        self.entries[-1] = json.loads(json.dumps(self.entries[-1], allow_nan=False))
        return self.entries[-1]

    # -- the writer: every block to the design -------------------------------------------------------------------
    def start(self, start: dict[str, Any], scene_text: str) -> None:
        pass

    def exchanges(self, exchanges: Any, block: int) -> None:
        pass

    def block(self, rec: Any) -> None:
        value = float(rec.stats.mean)
        if not math.isfinite(value):  # no valid reading (compliance): not a seating the fit could use
            return
        self.design.ingest(float(rec.weight_kg), value, seating=int(rec.repeat))
        self.say(self.evidence_line())

    def stop(self, stop: Any) -> None:
        pass

    # -- what the file and the screen get ---------------------------------------------------------------------------
    def evidence_line(self) -> str:
        """The live line's evidence (:func:`evidence_line`)."""
        return evidence_line(self.design)

    def record(self) -> dict[str, Any]:
        """The stop record's ``adaptive``: every suggestion with its evidence and the operator's action, the stop
        decision, the last state."""
        return json.loads(json.dumps({"entries": self.entries, "decision": self.decision, "final": self.last},
                                     allow_nan=False))  # fmt: skip


def _origin(settings: Mapping[str, Any]) -> str:
    """`` (content id sha256:…)`` of a prior from a session file (``noise_from``), else ""."""
    origin = settings.get("noise_from")
    return f" (content id {origin.get('content_id')})" if isinstance(origin, dict) else ""


def evidence_line(design: SequentialDesign) -> str:
    """``evidence: Hertz leads, ΔQAIC 4.2 of 10 (42 %) · ĉ 3.1 · 12 of 60 min`` — what the live line and ``watch``
    show after each block: the leader, its margin over the nearest separable rival against the decisive threshold
    (the progress to a decision), ĉ and the bench time against the budget."""
    from sims.models import model_label

    d = design
    ev = d.evidence()
    spent = f"{d.spent_s / 60:.0f} of {d.budget_s / 60:.0f} min"
    if d.prior.source.startswith("noise from "):  # a prior from a session file (--noise-from): said on every line
        spent += f" · {d.prior.source}"
    if ev is None:
        return f"evidence: not yet (the fit needs ≥ 2 seatings at ≥ 3 weights) · {spent}"
    margin = "no separable rival" if not math.isfinite(ev.margin) else f"Δ{ev.criterion} {ev.margin:.1f}"
    pct = 0 if not math.isfinite(ev.margin) else min(100, max(0, round(100 * ev.margin / d.threshold)))
    return (f"evidence: {model_label(ev.leader)} leads, {margin} of {d.threshold:g} ({pct} %) · ĉ {ev.c_hat:.2g} "
            f"· {spent}")  # fmt: skip


def session_design(session: Any) -> SequentialDesign | None:
    """The design of an adaptive session (a loaded :class:`daq.session_file.Session`, running or finished) rebuilt
    from its start record and fed its blocks in the order they were taken; None for a fixed-plan session."""
    from contactrig.core.scene import parse_scene

    settings = session.start.get("adaptive") if isinstance(session.start, dict) else None
    if not isinstance(settings, dict):
        return None
    design = build_design(parse_scene(session.scene_text, "recorded scene"), settings)
    rows = session.summary
    for w, r, v in zip(rows["weight_kg"], rows["repeat"], rows["mean_ohm"], strict=True):
        if math.isfinite(float(v)):
            design.ingest(float(w), float(v), seating=int(r))
    return design


def session_state(session: Any) -> dict[str, Any] | None:
    """What a view shows of an adaptive session (the console's JSON): :meth:`SequentialDesign.report` of the
    session so far, with ``evidence_line`` and, once it has ended, its ``stop_record`` (status, reason, the
    recorded decision); None for a fixed-plan session."""
    design = session_design(session)
    if design is None:
        return None
    state = design.report()
    state["evidence_line"] = evidence_line(design)
    stop = session.stop if isinstance(session.stop, dict) else None
    if stop is not None:
        adaptive = stop.get("adaptive")
        decision = adaptive.get("decision") if isinstance(adaptive, dict) else None
        state["stop_record"] = {"status": stop.get("status"), "reason": stop.get("reason"), "decision": decision}
    return state


def session_evidence(session: Any) -> str:
    """``watch``'s line for an adaptive session: :func:`evidence_line` of the design rebuilt from the file, and the
    stop reason once it has ended; "" for a fixed-plan session."""
    design = session_design(session)
    if design is None:
        return ""
    line = evidence_line(design)
    stop = session.stop if isinstance(session.stop, dict) else None
    if stop is not None and isinstance(stop.get("reason"), str):
        line += f" · {stop['reason']}"
    return line


def terminal_chooser(stream: Any = None, read: Callable[[], str] = input) -> Chooser:
    """Ask the operator at the terminal: the suggestion named, Enter takes it, a weight in kg places another (one of
    the allowed), ``q`` stops. A closed stdin stops the session (said in the stop reason)."""
    out = stream if stream is not None else sys.stderr

    def choose(placement: Placement, state: Mapping[str, Any], allowed: Sequence[float]) -> float | None:
        listed = ", ".join(f"{w:g}" for w in allowed)
        while True:
            print(f"Suggested: {placement.describe()}. [Enter] take it, a weight in kg to place another ({listed}), "
                  "q stop: ", end="", file=out, flush=True)  # fmt: skip
            try:
                answer = read().strip().lower()
            except EOFError:
                return None
            if answer in ("", "y", "yes", "g", "go"):
                return placement.weight_kg
            if answer in ("q", "quit", "stop"):
                return None
            try:
                weight = float(answer.removesuffix("kg").strip())
            except ValueError:
                weight = math.nan
            hit = [w for w in allowed if math.isclose(w, weight, rel_tol=1e-6)]
            if hit:
                return hit[0]
            print(f"'{answer}' is not an answer: press Enter, q, or one of {listed} (kg)", file=out, flush=True)

    return choose


def adaptive_source(
    budget_min: float, *, simulated: bool, choose: Chooser | None = None, seed: int = 0, noise_from: str | None = None
) -> Callable[[SessionPlan], AdaptiveSteps]:
    """What ``acquire(adaptive=…)`` takes: given the session's plan, the :class:`AdaptiveSteps` of a design with a
    budget of ``budget_min`` minutes (the plan's block numbers raised, :func:`adaptive_plan`); ``noise_from``: a
    session file whose noise is the prior (:func:`file_prior`), read now, so that a bad file is an error before any
    output is made."""
    from contactrig.core.validation import check_range

    check_range("--budget-min", budget_min, 0.0, 24 * 60.0, lo_open=True, unit="min")
    prior = file_prior(noise_from) if noise_from is not None else None

    def make(plan: SessionPlan) -> AdaptiveSteps:
        wide = adaptive_plan(plan, budget_min)
        settings = settings_of(wide, budget_min, simulated=simulated, seed=seed, prior=prior)
        steps = AdaptiveSteps(wide, build_design(wide.scene, settings), choose=choose)
        steps.settings = settings
        return steps

    return make


def replay_suggestions(path: str) -> tuple[bool, str]:
    """Rebuild the design from an adaptive session's start record, feed it the recorded blocks in order and compare
    every suggestion (and the evidence behind it) with the stop record's: (identical, a sentence)."""
    from contactrig.core.scene import parse_scene
    from daq import load_session

    session = load_session(path)
    settings = session.start.get("adaptive")
    stop = session.stop if isinstance(session.stop, dict) else {}
    recorded = stop.get("adaptive") if isinstance(stop, dict) else None
    if not isinstance(settings, dict) or not (isinstance(recorded, dict) or session.adaptive):
        return False, f"{path} is not an adaptive session (no adaptive records)"
    by_block = recorded_suggestions(session)
    if isinstance(by_block, str):
        return False, f"{path}: {by_block}"
    design = build_design(parse_scene(session.scene_text, f"{path} (recorded scene)"), settings)
    checked = 0
    rows = session.summary  # in the order the blocks were taken (the file's order)
    for w, r, v in [*zip(rows["weight_kg"], rows["repeat"], rows["mean_ohm"], strict=True), (math.nan, 0, math.nan)]:
        entries = by_block.pop(design.blocks, [])
        if entries:
            state = design.report()
            again = json.loads(json.dumps({"suggestion": state["suggestion"], "evidence": state["evidence"],
                                           "p_decisive": state["p_decisive"]}, allow_nan=False))  # fmt: skip
            if any(again != {k: entry.get(k) for k in again} for entry in entries):
                return False, f"the suggestion before block {design.blocks + 1} differs from the recorded one"
            checked += len(entries)
        if math.isfinite(float(v)):
            design.ingest(float(w), float(v), seating=int(r))
    if by_block:
        return False, f"{sum(map(len, by_block.values()))} recorded suggestion(s) fit no block of the file"
    left = "" if session.complete else " (an incomplete session: the suggestions of its blocks)"
    return True, f"{checked} suggestion(s) reproduced bit for bit{left}"


def recorded_suggestions(session: Any) -> dict[int, list[dict[str, Any]]] | str:
    """Every recorded suggestion of an adaptive session by the number of blocks taken before it (several when a block
    in compliance was not counted), in order: the blocks' own records (schema 5: a killed session keeps them) and the
    stop record's (schema 4 and later; also the suggestion the operator stopped at). A block's record that its stop
    record contradicts: a sentence saying so."""
    out: dict[int, list[dict[str, Any]]] = {}
    for row, entry in sorted(session.adaptive.items()):
        if not isinstance(entry, dict) or not isinstance(entry.get("block"), int):
            return f"the record of block row {row} is not a suggestion"
        out.setdefault(entry["block"], []).append(entry)
    stop = session.stop if isinstance(session.stop, dict) else {}
    recorded = stop.get("adaptive")
    entries = recorded.get("entries", []) if isinstance(recorded, dict) else []
    in_stop: dict[int, list[dict[str, Any]]] = {}
    for entry in entries if isinstance(entries, list) else []:
        if not isinstance(entry, dict) or not isinstance(entry.get("block"), int):
            return "a suggestion of the stop record is not one"
        in_stop.setdefault(entry["block"], []).append(entry)
    if not in_stop:  # a killed session (or one whose stop record could not keep them): the blocks' records
        return out
    for block, own in out.items():
        listed = in_stop.get(block, [])
        n = min(len(own), len(listed))
        if own[:n] != listed[:n]:
            return f"the suggestion before block {block + 1} differs in its block's record and the stop record"
        if len(own) > len(listed):
            return f"the suggestion before block {block + 1} is in its block's record, not in the stop record"
    return in_stop
