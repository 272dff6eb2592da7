"""``contactrig design``: the experiment that tells the contact models apart (``analysis.design``, issue #15 §3).

Registered by ``contactrig.cli.main``. Nothing heavy is imported until the command runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``design`` to ``subparsers``."""
    p = subparsers.add_parser(
        "design",
        help="find the cheapest bench plan whose fit ranks the true contact model first (ΔAIC >= 10)",
        description=(
            "Simulates many bench sessions per candidate plan (loads, repeats) for every contact model of the "
            "scene, fits each with every model, and reports the probability of ranking the true model first by "
            "ΔAIC >= 10; writes the report, the discrimination map and the chosen plan as a scene."
        ),
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (rig or press; default: the paper scene)")
    p.add_argument("-o", "--output", metavar="DIR", default="contactrig-design", help="output folder")
    p.add_argument("--sessions", type=int, default=400, help="simulated sessions per plan and model (400)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated sessions")
    p.add_argument("--repeat-sd", type=float, default=0.15, help="repeat-to-repeat SD of ln f (Tab. 1: 0.15)")
    p.set_defaults(handler=_design)


def _design(args: argparse.Namespace) -> int:
    import numpy as np

    from analysis.design import candidate_plans, chosen_plan, design, draw_map, model_curves, plan_scene_text
    from contactrig.core.scene import load_scene
    from sims.press import PressSettings

    scene = load_scene(args.scene)
    press = PressSettings.from_scene(scene)
    weights = press.weights_kg if press is not None else tuple(scene.table("rig").get("weights_kg", (5.44, 25.966)))
    w_min, w_max = (min(weights), max(weights)) if press is not None else (2.0, 26.0)
    delta = scene.table("delta")
    block_s = float(delta.get("count", 100)) * (float(delta.get("delay_s", 0.002)) + float(delta.get("nplc", 1)) / 50)
    curves = model_curves(scene, np.geomspace(w_min, w_max, 10))
    result = design(
        curves, candidate_plans(w_min, w_max, block_s), n_sessions=args.sessions, seed=args.seed,
        repeat_sd=args.repeat_sd,
    )  # fmt: skip
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    plan = chosen_plan(result)
    (out / "plan.toml").write_text(plan_scene_text(scene.text, plan), encoding="utf-8")
    draw_map(result, str(out / "discrimination.png"))
    text = result.statement()
    (out / "design.md").write_text(
        f"# Experiment design: {scene.name}\n\n{text}\n\nChosen plan: {len(plan.weights_kg)} loads "
        f"{list(plan.weights_kg)} kg × {plan.repeats} repeats ({plan.cost_s / 60:.0f} min), written to plan.toml.\n\n"
        "![discrimination map](discrimination.png)\n",
        encoding="utf-8",
    )
    print(text)
    print(f"plan: {out / 'plan.toml'}; report: {out / 'design.md'}")
    return 0
