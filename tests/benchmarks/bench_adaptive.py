"""The whole sequential loop against the fixed plan `contactrig design` picks (issue 27, "Calibrated, not promised").

For the paper's rig and the press scene, under Tab. 1's noise and iid re-seating (15 %), and for every contact model as
the truth, ``--sessions`` adaptive sessions are simulated (:func:`analysis.sequential.simulate_loop`: suggestion →
simulated block with the simulated bench's noise structure → evidence → stop), beside the fixed plan
(:func:`analysis.design.chosen_plan` from 200 sessions per candidate plan, then ≥ 500 sessions of it simulated by
:func:`analysis.design.simulate_plan`, judged once at its end by the fit's rule Δ(Q)AIC ≥ 10). Reported per
condition: the rate of a wrong model declared decisive (a leader that is not the truth nor equivalent to it on this
bench), the decisive rate, the futile rate and the mean bench time
(the same :class:`analysis.sequential.CostModel` for both: placing 60 s, re-seating 5 s, the plan's block time).

``--calibrate``: the decisive threshold of the adaptive loop (optional stopping inflates the fixed-sample rule's
error) on seeds apart from the reported ones (offset 1 000 000): the smallest threshold of ``--grid`` whose
wrong-decisive rate is ≤ 5 % in every condition; then run again with ``--threshold`` set to it.

Run:  python tests/benchmarks/bench_adaptive.py [--sessions 500] [--scenes rig,press] [--noise tab1,iid]
          [--budget-min 60] [--workers 2] [--threshold 10] [--calibrate --grid 10,15,20]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

SCENES = {"rig": None, "press": str(Path(__file__).resolve().parents[2] / "contactrig" / "scenes" / "press.toml")}
CALIBRATION_SEEDS = 1_000_000


def _setup(scene_name: str, noise_name: str) -> dict:
    """Curves at the bench's weights, the cost model, the prior film/series and the noise of one condition."""
    from analysis.circuit import CircuitSettings
    from analysis.design import model_curves
    from analysis.noise_model import noise_model
    from analysis.sequential import CostModel
    from contactrig.core.scene import load_scene
    from daq.plan import OPERATOR_ALLOWANCE_S, SessionPlan, block_duration_s

    scene = load_scene(SCENES[scene_name])
    plan = SessionPlan.from_scene(scene)
    weights = sorted(float(w) for w in plan.session.weights_kg)
    circuit = CircuitSettings.from_scene(scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        curves = model_curves(scene, weights)
    return {
        "scene": scene,
        "weights": weights,
        "curves": curves,
        "cost": CostModel(block_s=float(block_duration_s(plan.block_settings)), place_s=OPERATOR_ALLOWANCE_S),
        "film": circuit.resistivity_ohm_m * circuit.contact_height_m,
        "series": circuit.series_resistance_ohm,
        "noise": noise_model(noise_name, 0.15),
    }


def _design(setup: dict, budget_min: float, threshold: float, n_forward: int = 100) -> object:
    from analysis.sequential import SequentialDesign

    return SequentialDesign(setup["curves"], setup["weights"], setup["cost"], budget_s=60 * budget_min,
                            noise=setup["noise"], film_ohm_m2=setup["film"], series_ohm=setup["series"],
                            threshold=threshold, n_forward=n_forward)  # fmt: skip


_SETUPS: dict[tuple[str, str], dict] = {}


def _adaptive_one(args: tuple) -> tuple[str, str, float, int, bool]:
    """One adaptive session: (status, leader, bench time [s], blocks, wrong)."""
    from analysis.sequential import simulate_loop

    scene_name, noise_name, truth, seed, budget_min, threshold, n_forward, check_every = args
    key = (scene_name, noise_name)
    if key not in _SETUPS:
        _SETUPS[key] = _setup(scene_name, noise_name)
    setup = _SETUPS[key]
    design = _design(setup, budget_min, threshold, n_forward)
    rng = np.random.default_rng([seed, 27])
    status, leader, spent, blocks = simulate_loop(
        design,
        truth,
        rng,
        film_ohm_m2=setup["film"],
        series_ohm=setup["series"],
        noise=setup["noise"],
        check_every=check_every,
    )
    wrong = status == "decisive" and truth not in design.groups[leader]
    return status, leader, spent, blocks, wrong


def _fixed(setup: dict, sessions: int, budget_min: float, seed: int) -> dict[str, dict[str, float]]:
    """The plan `contactrig design` picks (its candidates, this noise), simulated per truth and judged once."""
    from analysis.design import candidate_plans, chosen_plan, design, simulate_plan
    from analysis.sequential import _decisive  # the same verdict: leader ahead of every separable rival

    curves, cost, w = setup["curves"], setup["cost"], setup["weights"]
    plans = candidate_plans(min(w), max(w), cost.block_s)
    result = design(curves, plans, film_ohm_m2=setup["film"], series_ohm=setup["series"], n_sessions=200,
                    noise=setup["noise"], seed=seed)  # fmt: skip
    plan = chosen_plan(result)
    groups = _design(setup, budget_min, 10.0).groups
    n, r = len(plan.weights_kg), plan.repeats
    time_s = n * cost.place_s + n * r * cost.block_s + n * (r - 1) * cost.reseat_s
    out = {}
    rng = np.random.default_rng([seed, 15])
    for truth in curves.area_m2:
        fits = simulate_plan(curves, plan, truth, setup["film"], setup["series"], rng, max(sessions, 500), 0.15, 1e-7,
                             setup["noise"])  # fmt: skip
        decisive, who = _decisive(fits, max(n - 2, 1), 10.0, groups)
        models = list(curves.area_m2)
        wrong = np.array([d and truth not in groups[models[int(k)]] for d, k in zip(decisive, who, strict=True)])
        out[truth] = {"decisive": float(np.mean(decisive)), "wrong": float(np.mean(wrong)), "time_s": time_s,
                      "plan": f"{n} loads × {r}"}  # fmt: skip
    return out


def _rate(x: float, n: int) -> str:
    return f"{100 * x:.1f} ± {100 * math.sqrt(max(x * (1 - x), 1e-12) / n):.1f} %"


def run(args: argparse.Namespace, threshold: float, seed0: int, pool: ProcessPoolExecutor,
        per_session: list[dict] | None = None) -> list[dict]:
    """The table's rows; with ``args.json``, every session's outcome is appended to ``per_session``."""
    rows = []
    per_session = [] if per_session is None else per_session
    for scene_name in args.scenes.split(","):
        for noise_name in args.noise.split(","):
            t0 = time.perf_counter()
            setup = _setup(scene_name, noise_name)
            models = list(setup["curves"].area_m2)
            fixed = _fixed(setup, args.sessions, args.budget_min, seed0) if not args.no_fixed else {}
            budget_min = args.budget_min
            if args.budget_of_fixed:
                # the loop's budget a fraction of the fixed plan's bench time (the same plan for every truth)
                budget_min = args.budget_of_fixed * next(iter(fixed.values()))["time_s"] / 60
                print(f"# {scene_name}/{noise_name}: budget {budget_min:.2f} min = {args.budget_of_fixed:g} × the "
                      "fixed plan's time", file=sys.stderr, flush=True)  # fmt: skip
            # session i of every model before session i + 1 of any: an interim table (--progress-every) has the same
            # sessions for every model, so a run cut short still reports a complete, smaller run
            jobs = [(scene_name, noise_name, t, seed0 + i, budget_min, threshold, args.forward, args.check_every)
                    for i in range(args.sessions) for t in models]  # fmt: skip
            results = []
            for k, r in enumerate(pool.map(_adaptive_one, jobs, chunksize=4)):  # in order, as they come
                results.append(r)
                done = (k + 1) // len(models)
                if args.progress_every and (k + 1) % len(models) == 0 and done % args.progress_every == 0:
                    interim = _rows(scene_name, noise_name, models, results, done, fixed)
                    print(f"# {scene_name}/{noise_name}: {done} sessions per model after "
                          f"{time.perf_counter() - t0:.0f} s\n{table(interim, threshold)}", file=sys.stderr, flush=True)
            rows += _rows(scene_name, noise_name, models, results, args.sessions, fixed)
            if args.json:
                per_session += [{"scene": scene_name, "noise": noise_name, "truth": job[2], "seed": job[3],
                                 "budget_min": budget_min, "status": r[0], "leader": r[1], "bench_s": r[2],
                                 "blocks": r[3], "wrong": bool(r[4])} for job, r in zip(jobs, results, strict=True)]
            print(f"# {scene_name}/{noise_name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return rows


def _rows(scene_name: str, noise_name: str, models: list[str], results: list, sessions: int, fixed: dict) -> list:
    """One row per true model from the first ``sessions`` sessions of each (``results`` in job order)."""
    rows = []
    for j, truth in enumerate(models):
        res = results[j : sessions * len(models) : len(models)]
        n = len(res)
        dec = np.mean([s == "decisive" for s, *_ in res])
        fut = np.mean([s == "futile" for s, *_ in res])
        wrong = np.mean([x[4] for x in res])
        mean_t = np.mean([x[2] for x in res]) / 60
        f = fixed.get(truth, {})
        reach_s, reach_wrong = time_to_rate([(s == "decisive", t, w) for s, _, t, _, w in res],
                                            f.get("decisive", math.nan))  # fmt: skip
        rows.append({"scene": scene_name, "noise": noise_name, "truth": truth, "n": n, "decisive": dec,
                     "futile": fut, "wrong": wrong, "time_min": mean_t,
                     "fixed_decisive": f.get("decisive", math.nan), "fixed_wrong": f.get("wrong", math.nan),
                     "fixed_time_min": f.get("time_s", math.nan) / 60, "fixed_plan": f.get("plan", ""),
                     "reach_min": reach_s / 60, "reach_wrong": reach_wrong})  # fmt: skip
    return rows


def time_to_rate(sessions: list[tuple[bool, float, bool]], rate: float) -> tuple[float, float]:
    """The bench time [s] by which the adaptive sessions have declared decisive as often as ``rate`` (the fixed
    plan's decisive rate), and their wrong-decisive rate by then: ``sessions`` are (decisive, bench time at the stop,
    wrong). The k-th earliest decisive stop, k = ⌈rate · n⌉; NaN when fewer than k sessions ended decisive (or
    ``rate`` is NaN or 0: nothing to reach).

    Read with care: a session given a budget of that time would have been checked for futility against it, so the
    figure is the time at which the loop run with the reported budget passes the fixed plan's rate, not the rate of
    a loop given that time as its budget (``--budget-of-fixed`` measures that directly)."""
    n = len(sessions)
    if n == 0 or not rate > 0.0:
        return math.nan, math.nan
    k = math.ceil(rate * n - 1e-9)
    stops = sorted((t, w) for d, t, w in sessions if d)
    if len(stops) < k:
        return math.nan, math.nan
    t_k = stops[k - 1][0]
    return t_k, sum(w for t, w in stops if t <= t_k) / n


def table(rows: list[dict], threshold: float) -> str:
    head = ("| bench | noise | true model | adaptive: wrong decisive | decisive | futile | mean time | "
            "reaches the fixed rate at (wrong by then) | fixed plan | fixed: wrong | decisive | time |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|")  # fmt: skip
    lines = [head]
    for r in rows:
        reach = (f"{r['reach_min']:.1f} min = {100 * r['reach_min'] / r['fixed_time_min']:.0f} % "
                 f"({100 * r['reach_wrong']:.1f} %)" if math.isfinite(r["reach_min"]) else "—")  # fmt: skip
        lines.append(
            f"| {r['scene']} | {r['noise']} | {r['truth']} | {_rate(r['wrong'], r['n'])} | "
            f"{_rate(r['decisive'], r['n'])} | {100 * r['futile']:.0f} % | {r['time_min']:.1f} min | {reach} | "
            f"{r['fixed_plan']} | "
            f"{100 * r['fixed_wrong']:.1f} % | {100 * r['fixed_decisive']:.1f} % | {r['fixed_time_min']:.0f} min |"
        )
    return (
        "\n".join(lines) + f"\n\n(adaptive decisive threshold Δ(Q)AIC ≥ {threshold:g}; {rows[0]['n']} sessions per row)"
    )


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sessions", type=int, default=500, help="sessions per true model and condition (500)")
    p.add_argument("--scenes", default="rig,press")
    p.add_argument("--noise", default="tab1,iid")
    p.add_argument("--budget-min", type=float, default=60.0)
    p.add_argument("--threshold", type=float, default=None, help="decisive Δ(Q)AIC (default: the module's)")
    p.add_argument("--calibrate", action="store_true", help="choose the threshold on separate seeds first")
    p.add_argument("--grid", default="10,15,20,30")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--forward", type=int, default=100, help="futures of the predictive probability (100)")
    p.add_argument("--check-every", type=int, default=4, help="blocks between futility checks (4)")
    p.add_argument("--no-fixed", action="store_true", help="leave out the fixed plan (faster)")
    p.add_argument("--progress-every", type=int, default=0, help="print the table so far every N sessions per model")
    p.add_argument("--budget-of-fixed", type=float, default=0.0,
                   help="the loop's budget: this fraction of the fixed plan's time (e.g. 0.7)")
    p.add_argument("--seed-offset", type=int, default=0,
                   help="first seed of the reported sessions (0; a fresh set to check a rule out of sample)")
    p.add_argument("--json", type=Path, default=None, help="write the rows and every session's outcome to this file")
    args = p.parse_args()
    if args.budget_of_fixed and (args.no_fixed or args.calibrate):
        p.error("--budget-of-fixed needs the fixed plan: not with --no-fixed or --calibrate")
    if args.budget_of_fixed < 0:
        p.error(f"--budget-of-fixed: {args.budget_of_fixed:g} is not a fraction > 0")
    from analysis.sequential import DECISIVE_DELTA

    threshold = DECISIVE_DELTA if args.threshold is None else args.threshold
    with ProcessPoolExecutor(args.workers) as pool:
        if args.calibrate:
            for t in [float(x) for x in args.grid.split(",")]:
                rows = run(argparse.Namespace(**{**vars(args), "no_fixed": True}), t, CALIBRATION_SEEDS, pool)
                worst = max(r["wrong"] for r in rows)
                print(f"calibration: threshold {t:g}: worst wrong-decisive rate {100 * worst:.1f} %", flush=True)
                if worst <= 0.05:
                    threshold = t
                    break
            else:
                print("calibration: no threshold of the grid keeps the wrong-decisive rate ≤ 5 %", flush=True)
        per_session: list[dict] = []
        rows = run(args, threshold, args.seed_offset, pool, per_session)
    print(table(rows, threshold))
    if args.json:
        import json

        args.json.write_text(json.dumps({"command": " ".join(sys.argv), "threshold": threshold, "rows": rows,
                                         "sessions": per_session}, indent=1, default=float) + "\n")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
