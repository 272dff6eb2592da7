"""Verdicts, ranking, table and figure of analysis.compare_models on comparisons whose ratios are known by
construction, and ``contactrig compare-models`` on a small scene."""

from __future__ import annotations

import re

import numpy as np
import pytest

from analysis import compare_models as cm
from sims.ensemble import CompareSettings, Comparison, TaskResult

P = (0.1e6, 1e6, 10e6)


def _result(k: int, model: str, area, gap, stiff, in_range=(True, True, True)) -> TaskResult:
    arr = np.asarray
    return TaskResult(k, model, arr(P), arr(gap, dtype=float), arr(gap, dtype=float), arr(area, dtype=float),
                      arr(stiff, dtype=float), arr(in_range), {"n_spots": [1, 2, 3]})  # fmt: skip


def _comparison(realisations: int = 1) -> Comparison:
    st = CompareSettings(pressures_pa=P, models=("hertz", "greenwood_tripp"), realisations=realisations)
    out = []
    for k in range(realisations):
        bem_a = np.array([0.01, 0.05, 0.2])
        out.append(_result(k, "bem", bem_a, [2e-6, 1e-6, 0.5e-6], [1e11, 1e12, 1e13]))
        # Hertz: area 0.9, 0.8, 0.7 of BEM (+ a realisation offset), gap +10 %, stiffness 0.9× then 0.5×
        shift = 0.02 * k
        out.append(_result(k, "hertz", bem_a * (np.array([0.9, 0.8, 0.7]) + shift), [2.2e-6, 1.1e-6, 0.55e-6],
                           [0.9e11, 0.7e12, 0.5e13]))  # fmt: skip
        # GT: half the area, and the last pressure beyond its curve
        out.append(_result(k, "greenwood_tripp", bem_a * 0.5, [1e-6, 0.5e-6, 0.25e-6], [1e11, 1e12, 1e13],
                           in_range=(True, True, False)))  # fmt: skip
    return Comparison(st, tuple(out), {"scene_name": "toy"})


def test_verdict_numbers_from_known_ratios():
    v = {x.model: x for x in cm.model_verdicts(_comparison())}
    hz = v["hertz"]
    assert hz.area_dev == pytest.approx(-0.2)
    assert hz.area_sd == pytest.approx(np.std([-0.1, -0.2, -0.3]))
    assert hz.gap_dev == pytest.approx(0.1)
    assert hz.stiffness_lo_hi == pytest.approx((0.9, 0.5))
    assert hz.rms_log_area == pytest.approx(np.sqrt(np.mean(np.log([0.9, 0.8, 0.7]) ** 2)))
    line = hz.line()
    assert line.startswith("Hertz summation: area −20 % ± 8 % vs BEM over 0.1–10 MPa; mean gap +10 %")
    assert "stiffness 0.90–0.50× BEM" in line
    gt = v["greenwood_tripp"]
    assert gt.n_in_range == 2 and gt.p_range_pa == (0.1e6, 1e6) and gt.area_dev == pytest.approx(-0.5)
    assert "1 pressure beyond its curve left out" in gt.line()


def test_favoured_is_the_closest_in_area_and_report_lines():
    cmp = _comparison()
    assert cm.favoured(cmp).startswith("BEM favours Hertz summation on this surface: real area −20 %")
    lines = cm.report_lines(cmp)
    assert len(lines) == 4 and lines[2].startswith("Hertz") and lines[3].startswith("Greenwood")


def test_realisation_band():
    v = {x.model: x for x in cm.model_verdicts(_comparison(realisations=3))}["hertz"]
    assert v.area_band == pytest.approx((-0.2, -0.16))  # per-realisation means: −0.2, −0.18, −0.16
    assert v.area_dev == pytest.approx(-0.18)
    assert "realisations −20 % … −16 %, N = 3" in v.line()


def test_table_and_figure():
    cmp = _comparison(realisations=2)
    table = cm.comparison_table(cmp)
    # BEM block (title, header, a row per pressure), then per quantity: blank, title, header, rows; then the footnote
    assert len(table.splitlines()) == (2 + len(P)) + 3 * (3 + len(P)) + 1
    assert re.search(r"0\.500\*", table)  # GT at 10 MPa, beyond its curve
    assert re.search(r"\n\s+10\s+0\.710\s+0\.500\*", table)  # Hertz A/A_BEM 0.7 + 0.01 (mean of 2 realisations)
    fig = cm.figure_compare_models(cmp)
    assert len(fig.axes) == 4  # area, gap, stiffness against BEM; area against a reference model
    from analysis.figures import get_figure

    spec = get_figure("model_ranking")
    assert spec.draw(object()) is None
    assert spec.draw(type("A", (), {"model_ranking": cmp})()) is not None


def test_table_fits_100_columns_with_every_model_and_json_keeps_full_precision():
    """Issue 20 item 7: the text table fits 100 columns (all registered models and 12 pressures), however many
    models (a further block), and --json carries the unrounded ratios."""
    from sims.models import model_names

    names = tuple(m for m in model_names() if m != "bem") * 2  # more models than one block holds
    pressures = cm.DEFAULT_PRESSURES_PA
    st = CompareSettings(pressures_pa=pressures, models=tuple(dict.fromkeys(names)), realisations=1)
    n = len(pressures)
    arr = np.asarray
    res = [TaskResult(0, "bem", arr(pressures), arr([1e-6] * n), arr([1e-6] * n), arr([0.3] * n),
                      arr([1e12] * n), arr([True] * n), {"n_spots": [1] * n})]  # fmt: skip
    for m in st.models:
        res.append(TaskResult(0, m, arr(pressures), arr([1e-6] * n), arr([1e-6] * n), arr([0.1] * n),
                              arr([1e12] * n), arr([True] * n), {}))  # fmt: skip
    cmp = Comparison(st, tuple(res), {"scene_name": "toy"})
    table = cm.comparison_table(cmp)
    assert max(len(line) for line in table.splitlines()) <= 100
    for m in st.models:
        from sims.models import model_label

        assert model_label(m) in table
    d = cm.comparison_dict(cmp)
    assert d["models"][st.models[0]]["area_ratio"][0] == 0.1 / 0.3  # not the 3 digits of the table
    assert d["units"]["pressure"] == "Pa" and d["settings"]["pressures_pa"] == list(pressures)
    assert d["settings"]["stiffness"] == st.stiffness == "tangent"  # which scheme made BEM's K (the default)


def test_cli_on_a_small_scene(tmp_path, capsys):
    from importlib import resources

    from contactrig.cli.main import main

    text = resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")
    scene = tmp_path / "small.toml"
    scene.write_text(text.replace("n = 512", "n = 64"), encoding="utf-8")
    code = main(["compare-models", str(scene), "--models", "hertz,greenwood_tripp", "--pressures", "1e6,5e6",
                 "--jobs", "1", "--plot", str(tmp_path / "cmp.png")])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert "BEM favours" in out and "Hertz summation: area" in out and "Greenwood–Tripp: area" in out
    assert (tmp_path / "cmp.png").stat().st_size > 0
    assert main(["compare-models", str(scene), "--models", "bem"]) == 2
