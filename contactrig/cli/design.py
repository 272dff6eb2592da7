"""``contactrig design``: the experiment that tells the contact models apart (``analysis.design``, issue #15 §3).

Registered by ``contactrig.cli.main``. Nothing heavy is imported until the command runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from contactrig.cli.options import add_json_option, add_max_memory_option, json_units
from contactrig.cli.progress import add_quiet_option, progress_bar

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``design`` to ``subparsers``."""
    p = subparsers.add_parser(
        "design",
        help="find the cheapest bench plan whose fit ranks the true contact model first (Δ(Q)AIC >= 10)",
        description=(
            "Simulates many bench sessions per candidate plan (loads, repeats) for every contact model of the "
            "scene, fits each with every model, and reports the probability of ranking the true model first by "
            "Δ(Q)AIC >= 10 (QAIC when over-dispersed, as in fit); writes the report, the discrimination map and "
            "the chosen plan as a scene."
        ),
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (rig or press; default: the paper scene)")
    p.add_argument("-o", "--output", metavar="DIR", default="contactrig-design", help="output folder (created)")
    p.add_argument("--force", action="store_true", help="replace design.md, discrimination.png and plan.toml")
    p.add_argument("--sessions", type=int, default=400, help="simulated sessions per plan and model (400)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated sessions")
    p.add_argument(
        "--repeat-sd", type=float, default=0.15, help="with --noise-from iid: repeat-to-repeat SD of ln f (0.15)"
    )
    p.add_argument(
        "--noise-from", default="tab1", metavar="tab1|iid|SESSION.h5",
        help="noise model of the simulated sessions: estimated from Tab. 1's independent series (default), from a "
        "session of your own, or iid re-seating of --repeat-sd (the simulated bench; χ²/ν ≈ 1)",
    )  # fmt: skip
    p.add_argument(
        "--what-would-it-take", action="store_true",
        help="also find, per model pair, the smallest reduction of each noise component and the load range that "
        "would tell it apart (a section of design.md, what-would-it-take.png)",
    )  # fmt: skip
    p.add_argument(
        "--wwit-sessions", type=int, default=None, metavar="N",
        help="with --what-would-it-take: simulated sessions per point of its search (100; seed: --seed)",
    )  # fmt: skip
    add_json_option(p, "the statement, the chosen plan and its probabilities")
    add_quiet_option(p)
    add_max_memory_option(p)
    p.set_defaults(handler=_design)


def _noise(source: str, repeat_sd: float) -> Any:
    """The noise model of ``--noise-from``: Tab. 1, iid re-seating, or a session file's own repeats."""
    from analysis.noise_model import NOISE_MODELS, noise_model, session_noise

    if source in NOISE_MODELS:  # "tab1" (default, the simulated bench's too) or "iid"
        return noise_model(source, repeat_sd)
    return session_noise(source)[0]  # lack of fit about a power law, as for Tab. 1


def _design(args: argparse.Namespace) -> int:
    import numpy as np

    from analysis.design import candidate_plans, chosen_plan, design, draw_map, model_curves, plan_scene_text
    from contactrig.core.files import output_folder, refuse_existing, write_text_atomic
    from contactrig.core.scene import load_scene
    from contactrig.core.text import escape_terminal
    from contactrig.core.validation import check_int, check_range
    from daq.plan import SessionPlan
    from sims.budget import check_specimen
    from sims.config import SimConfig

    sessions = check_int("--sessions", args.sessions, 20, 100_000)
    repeat_sd = check_range("--repeat-sd", args.repeat_sd, 0.0, 1.0)
    check_int("--seed", args.seed, 0, 2**63 - 1)  # numpy's generator takes no negative seed
    wwit_sessions = _wwit_sessions(args)
    out = output_folder(args.output)
    wanted = [out / "design.md", out / "discrimination.png", out / "plan.toml"]
    paths = refuse_existing(wanted + ([out / WWIT_FIGURE] if args.what_would_it_take else []), force=args.force)
    from analysis.noise_model import NOISE_MODELS

    if args.noise_from not in NOISE_MODELS and not Path(args.noise_from).is_file():  # before the slow build
        raise FileNotFoundError(f"--noise-from {args.noise_from}: no such session file (or 'tab1', 'iid')")
    scene = load_scene(args.scene)
    config = SimConfig.from_scene(scene)  # the scene parsed once: rig or press, validated
    check_specimen(config, None, [1.0] * 10)  # each model's sweep (10 loads), before the first starts
    block = SessionPlan.from_scene(scene).block_settings
    block_s = block.count * (block.delay_s + block.nplc / block.line_frequency_hz)
    w_min, w_max = (min(config.weights_kg), max(config.weights_kg)) if config.press is not None else (2.0, 26.0)
    curves = model_curves(scene, np.geomspace(w_min, w_max, 10))
    noise = _noise(args.noise_from, repeat_sd)
    with progress_bar("design: plans", quiet=args.quiet) as progress:
        result = design(curves, candidate_plans(w_min, w_max, block_s), n_sessions=sessions, seed=args.seed,
                        repeat_sd=repeat_sd, noise=noise, progress=progress)  # fmt: skip
    plan = chosen_plan(result)
    wwit = None
    if wwit_sessions is not None:
        from analysis.what_would_it_take import draw, for_scene

        with progress_bar("design: what would it take (points)", quiet=args.quiet) as progress:
            wwit = for_scene(scene, noise, block_s, n_sessions=wwit_sessions, seed=args.seed, progress=progress)
        draw(wwit, paths[3], force=args.force)
    scene_text = plan_scene_text(scene.text, plan, discriminating=result.discriminating)
    write_text_atomic(paths[2], scene_text, force=args.force)
    draw_map(result, str(paths[1]), force=args.force)
    text = result.statement()
    index = result.plans.index(plan)
    rows = [
        f"| {escape_terminal(t)} | {escape_terminal(m)} | {100 * result.probability[(t, m)][index]:.0f} % |"
        for t in result.models
        for m in result.models
        if t != m
    ]
    write_text_atomic(
        paths[0],
        f"# Experiment design: {scene.name}\n\n{text}\n\nChosen plan: {len(plan.weights_kg)} loads "
        f"{list(plan.weights_kg)} kg × {plan.repeats} repeats ({plan.cost_s / 60:.0f} min), written to plan.toml"
        f"{'' if result.discriminating else ' (marked NOT A DISCRIMINATING PLAN)'}.\n\n"
        "With this plan, the probability that a session's fit puts the true model ahead of the other by Δ(Q)AIC ≥ 10 "
        f"({sessions} simulated sessions each; Monte-Carlo SE ≤ {50 / np.sqrt(sessions):.1f} %):\n\n"
        "| true model | other | P(Δ(Q)AIC ≥ 10) |\n|---|---|---|\n" + "\n".join(rows) + "\n\n"
        "![discrimination map](discrimination.png)\n" + _wwit_section(wwit),
        force=args.force,
    )
    if args.json:
        import json

        data = _json(result, plan, index, sessions, scene.name, paths)
        if wwit is not None:
            from analysis.what_would_it_take import as_dict

            data["what_would_it_take"] = as_dict(wwit)
            data["files"]["what_would_it_take_figure"] = str(paths[3])
        print(json.dumps(data, indent=1))
        return 0
    print(text)
    if wwit is not None:
        from analysis.what_would_it_take import statement

        for line in statement(wwit).splitlines():
            print(escape_terminal(line))
    print(f"plan: {paths[2]}; report: {paths[0]}" + ("" if wwit is None else f"; figure: {paths[3]}"))
    return 0


#: The figure of ``--what-would-it-take`` in the output folder.
WWIT_FIGURE = "what-would-it-take.png"


def _wwit_sessions(args: argparse.Namespace) -> int | None:
    """``--wwit-sessions`` checked (20…100000; only with ``--what-would-it-take``); None without the study."""
    from contactrig.core.validation import SettingError, check_int

    if not args.what_would_it_take:
        if args.wwit_sessions is not None:
            raise SettingError("--wwit-sessions", args.wwit_sessions, "allowed only with --what-would-it-take")
        return None
    return check_int("--wwit-sessions", 100 if args.wwit_sessions is None else args.wwit_sessions, 20, 100_000)


def _wwit_section(wwit: Any) -> str:
    """design.md's section of ``--what-would-it-take`` ("" without it)."""
    if wwit is None:
        return ""
    from analysis.what_would_it_take import statement, table

    return (f"\n## What would it take\n\n{statement(wwit)}\n\n{table(wwit)}\n\n"
            f"![what would it take]({WWIT_FIGURE})\n")  # fmt: skip


def _json(result: Any, plan: Any, index: int, sessions: int, scene_name: str, paths: list[Path]) -> dict[str, Any]:
    """``design --json`` (schema contactrig/schemas/design.json): probabilities are fractions (0…1)."""
    from analysis.design import DELTA_AIC

    return {
        "units": json_units(probability="1 (a fraction)", delta_aic="1", target="1 (a fraction)"),
        "scene": scene_name,
        "statement": result.statement(),
        "delta_aic": DELTA_AIC,
        "target": float(result.target),
        "sessions": sessions,
        "models": list(result.models),
        "discriminating": bool(result.discriminating),
        "plan": {"weights_kg": [float(w) for w in plan.weights_kg], "repeats": int(plan.repeats),
                 "cost_s": float(plan.cost_s)},
        "probability": [
            {"true_model": t, "other_model": m, "probability": float(result.probability[(t, m)][index])}
            for t in result.models for m in result.models if t != m
        ],
        "cheapest": [
            {"models": [a, b], "plan": None if i is None else {
                "weights_kg": [float(w) for w in result.plans[i].weights_kg], "repeats": int(result.plans[i].repeats),
                "cost_s": float(result.plans[i].cost_s)}}
            for (a, b), i in result.cheapest.items()
        ],
        "files": {"report": str(paths[0]), "map": str(paths[1]), "plan": str(paths[2])},
    }  # fmt: skip
