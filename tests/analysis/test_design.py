"""Experiment design (analysis.design): the Monte Carlo's limits and the written plan scene."""

from __future__ import annotations

import numpy as np

from analysis.design import ModelCurves, Plan, design, plan_scene_text
from contactrig.core.scene import default_scene_text, parse_scene


def _curves(exponent_b: float) -> ModelCurves:
    w = np.geomspace(1.0, 100.0, 6)
    return ModelCurves(
        weight_kg=w,
        area_m2={"a": 1e-8 * w, "b": 1e-8 * w**exponent_b},
        clean_ohm={"a": 1e-6 / w, "b": 1e-6 / w},
        geometry="test",
    )


def test_identical_models_are_never_told_apart_and_distinct_ones_always() -> None:
    """Same A(W): Δχ² = 0 exactly (never ≥ 10). A ∝ W against A ∝ W^0.3 over two decades: always told apart."""
    plan = Plan(tuple(np.geomspace(1.0, 100.0, 8)), 6, 1.0)
    same = design(_curves(1.0), [plan], n_sessions=200, film_ohm_m2=2e-9)
    assert same.pair_score[("a", "b")][0] == 0.0 and same.cheapest[("a", "b")] is None
    far = design(_curves(0.3), [plan], n_sessions=200, film_ohm_m2=2e-9)
    assert far.pair_score[("a", "b")][0] == 1.0 and far.cheapest[("a", "b")] == 0


def test_plan_scene_is_a_valid_scene_with_the_plan() -> None:
    plan = Plan((2.0, 10.0, 26.0), 12, 1.0)
    scene = parse_scene(plan_scene_text(default_scene_text(), plan))
    session = scene.table("session")
    assert session["repeats"] == 12 and session["weights_kg"] == [2.0, 10.0, 26.0]
