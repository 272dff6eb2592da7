"""What the report adds beyond the fit (issues #14, #15), press scenes end to end, ``simulate --elastic``, the Holm
label and ``bench --force``. Expectations are independent: the favoured model is recomputed from the comparison's
raw quantities, the resistance model must recover the σ_f and R_s the test built the data from, the press's areas
are told from the rig's by an order of magnitude, the README is read as a file."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from contactrig.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
PRESS = ROOT / "contactrig" / "scenes" / "press.toml"


def _run(argv):
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


def _analysis(curve, areas, scene=None, **kw):
    from analysis.pipeline import analyse
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    scene = scene or load_scene(None)
    sweep = SimpleNamespace(
        models={n: SimpleNamespace(weight_kg=curve.weight_kg, contact_area_m2=a) for n, a in areas.items()},
        warnings=[], provenance={"fingerprint": config_fingerprint(SimConfig.from_scene(scene))},
    )  # fmt: skip
    return analyse(curve, sweep, scene, n_boot=0, **kw)


def test_the_report_shows_which_model_bem_favours_and_its_figure(tmp_path):
    from analysis.pipeline import rank_against_bem, with_report_extras
    from analysis.report import write_report
    from contactrig.core.scene import load_scene
    from sims.ensemble import BEM
    from sims.models import model_label

    cmp = rank_against_bem(load_scene(None), ["hertz", "greenwood_tripp"], pressures_pa=(1e6, 10e6))
    # independent: the smallest RMS of ln(A_model/A_BEM) over the pressures, from the raw quantities
    ref = cmp.quantity(BEM, "area_fraction")
    rms = {m: float(np.sqrt(np.mean(np.log(cmp.quantity(m, "area_fraction") / ref) ** 2))) for m in cmp.models}
    best = min(rms, key=rms.get)
    w = np.array([5.44, 10.526, 16.708, 25.966])
    from analysis.measured import MeasuredCurve

    rng = np.random.default_rng(0)
    curve = MeasuredCurve(w, (3e-3 * (w / 5) ** -0.8)[:, None] * (1 + 0.05 * rng.normal(size=(4, 3))), paired=True)
    a = with_report_extras(_analysis(curve, {"hertz": 1e-7 * (w / 5) ** 0.8}), ranking=cmp, statement=False)
    md = write_report([a], tmp_path / "rep").read_text(encoding="utf-8")
    favoured = re.search(r"BEM favours (.+?) on this surface", md)
    assert favoured is not None and favoured.group(1).startswith(model_label(best))
    assert md.count(" vs BEM over ") == 2  # one verdict line per compared model
    assert any(p.name.endswith("model_ranking.png") for p in (tmp_path / "rep" / "figures").iterdir())
    assert "model_ranking.png" in md and md.index("### Simulated real contact area") < md.index("BEM favours")
    html = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    assert html.count('<img src="data:image/png;base64,') == md.count("![")


def test_report_compares_models_by_default_only_when_the_surfaces_are_the_scenes():
    from analysis.pipeline import compare_models_by_default

    surfaces = {"tables": {"surfaces": {"sha256": "a"}, "rig": {"sha256": "b"}}}
    same = SimpleNamespace(fingerprint={"simulation": surfaces, "differences": [], "allowed": False})
    assert compare_models_by_default(same)[0] is True
    other = SimpleNamespace(
        fingerprint={"simulation": surfaces, "differences": ["[surfaces.liner] sq_m differs: …"], "allowed": True}
    )
    ok, why = compare_models_by_default(other)
    assert ok is False and "surfaces" in why
    rig_only = SimpleNamespace(
        fingerprint={"simulation": surfaces, "differences": ["[rig] clearance_m differs: …"], "allowed": True}
    )
    assert compare_models_by_default(rig_only)[0] is True
    unverifiable = SimpleNamespace(fingerprint={"simulation": {"tables": {}}, "differences": ["…"], "allowed": True})
    assert compare_models_by_default(unverifiable)[0] is False


def test_the_session_resistance_sentence_recovers_the_film_and_series_resistance():
    from analysis.measured import MeasuredCurve
    from analysis.pipeline import resistance_statement
    from analysis.resistance_model import rig_resistance_terms
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig

    scene = load_scene(None)
    w = np.array([5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966])
    terms = rig_resistance_terms(SimConfig.from_scene(scene), "greenwood_tripp", list(w))
    sigma_f, r_s = 2.0e-9, 0.5e-3  # Ω·m², Ω: the truth
    truth = r_s + sigma_f / terms.area_m2 + terms.clean_ohm
    rng = np.random.default_rng(1)
    curve = MeasuredCurve(w, truth[:, None] * (1 + 1e-4 * rng.normal(size=(w.size, 4))), paired=True)
    a = _analysis(curve, {"greenwood_tripp": terms.area_m2}, scene)
    text = resistance_statement(a)
    assert "this session is R = R_s + σ_f/A + clean metal" in text
    got_sigma = float(re.search(r"σ_f = ([0-9.e+-]+) ±", text).group(1))
    got_rs = float(re.search(r"R_s = (-?[0-9.]+) ±", text).group(1))
    assert got_sigma == pytest.approx(sigma_f, rel=0.01) and got_rs == pytest.approx(r_s * 1e3, abs=0.01)
    clean = terms.clean_ohm / truth * 100
    lo, hi = (float(x) for x in re.search(r"is ([0-9.]+)–([0-9.]+) % of the measured", text).groups())
    assert lo == pytest.approx(clean.min(), abs=0.06) and hi == pytest.approx(clean.max(), abs=0.06)


def test_the_tab1_report_states_sigma_f_rs_and_the_clean_metal_fraction(tmp_path):
    from analysis.pipeline import analyse_tab1, with_report_extras
    from analysis.report import write_report

    a = with_report_extras(analyse_tab1(n_boot=0))
    md = write_report([a], tmp_path / "rep").read_text(encoding="utf-8")
    sentence = next(line for line in md.splitlines() if "Tab. 1 is R = R_s + σ_f/A + clean metal" in line)
    assert "σ_f = " in sentence and "R_s = " in sentence and "% of the measured mean resistance" in sentence
    assert "errors: " in sentence and "M4, M5, M6 counted once" in sentence
    share = re.search(r"is ([0-9.]+)–([0-9.]+) % of the measured mean", sentence)
    assert share is not None and 0 < float(share.group(1)) <= float(share.group(2)) < 100


def test_holm_is_labelled_an_upper_bound_everywhere():
    from analysis.fit import regressor_label

    label = "Holm single spot — an upper bound on the clean-metal constriction"
    assert label in regressor_label("holm") and regressor_label("bulk") == "h/A (eq. 23)"
    assert label in (ROOT / "README.md").read_text(encoding="utf-8")
    import analysis.resistance as resistance

    assert label in " ".join((resistance.__doc__ or "").split())


def test_simulate_elastic_prints_the_effect_instead_of_the_roughness_warnings(capsys):
    argv = ["simulate", "--models", "hertz", "--weights", "5.44,25.966"]
    assert _run(argv) == 0
    rigid = capsys.readouterr()
    assert "roughness parameter σ·R_eff/b²" in rigid.err  # the default scene at 25.966 kg (README)
    assert _run([*argv, "--elastic"]) == 0
    elastic = capsys.readouterr()
    effects = [line for line in elastic.out.splitlines() if "bulk elasticity changes the real area" in line]
    assert len(effects) == 2 and "25.966 kg" in effects[1]
    assert "roughness parameter" not in elastic.err
    assert _run([*argv, "--elastic", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["bulk_elasticity"]) == 2 and not any("roughness parameter" in x for x in d["warnings"])


def _press_session(path, weights, sigma):
    """A session of the press scene whose R = σ / A_press(W), areas from a toy list given by the test."""
    from daq.records import StopRecord, now_iso
    from tests.analysis.sessions import write_session

    rng = np.random.default_rng(2)
    blocks = (
        (w, rep, r_true * (1 + 0.01 * rng.normal()) * np.ones(5))
        for rep in range(3)
        for w, r_true in zip(weights, sigma, strict=True)
    )
    stop = lambda n: StopRecord(  # noqa: E731
        status="success", reason="done", stopped=now_iso(), blocks_planned=n, blocks_done=n, readings_done=5 * n
    )
    write_session(path, blocks, start={"started": now_iso(), "operator": "t"},
                  scene_text=PRESS.read_text(encoding="utf-8"), stop=stop)  # fmt: skip
    return path


@pytest.mark.slow
def test_a_press_scene_runs_through_simulate_fit_and_report(tmp_path, capsys):
    from analysis.pipeline import simulate
    from contactrig.core.scene import load_scene

    weights = np.array([1.0, 2.0, 5.0, 10.0, 20.0])
    scene = load_scene(PRESS)
    press, _ = simulate(scene, weights, ["hertz"])
    rig, _ = simulate(load_scene(None), weights[weights >= 5], ["hertz"])
    a_press = np.asarray(press.models["hertz"].contact_area_m2)
    # the press (a sphere on a flat) touches on far less real area than the rig's skirt at equal weight
    assert np.all(a_press[2:] < 0.3 * np.asarray(rig.models["hertz"].contact_area_m2))
    zeta_h = 4.3e-7 * 5e-3
    session = _press_session(tmp_path / "press.h5", weights, zeta_h / a_press)
    assert _run(["simulate", PRESS, "--models", "hertz", "--weights", "1,2,5,10,20", "-o", tmp_path / "sim.h5"]) == 0
    capsys.readouterr()
    assert _run(["fit", session, "--sim", tmp_path / "sim.h5", "--json", "--bootstrap", "0"]) == 0
    d = json.loads(capsys.readouterr().out)
    est = d["models"]["hertz"]["estimate"]
    assert est["scale"] == pytest.approx(4.3e-7, rel=0.03)  # the press's areas, not the rig's (5-20× off)
    assert _run(["fit", session, "--json", "--bootstrap", "0"]) == 0  # simulated now from the recorded press scene
    assert json.loads(capsys.readouterr().out)["models"]["hertz"]["estimate"]["scale"] == pytest.approx(
        4.3e-7, rel=0.03
    )
    rep = tmp_path / "rep"
    assert (
        _run(["report", session, "--sim", tmp_path / "sim.h5", "-o", rep, "--bootstrap", "0", "--no-compare-models"])
        == 0
    )
    md = (rep / "report.md").read_text(encoding="utf-8")
    shown = html.unescape(re.sub(r"\\([!-/:-@\[-`{-~])", r"\1", md))  # what a Markdown renderer shows
    assert "scene: press-sphere-on-flat (" in shown and "describes the piston/liner rig; this is a press scene" in md
    assert (rep / "report.html").is_file()


def test_bench_output_folder_needs_force_to_be_reused(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["bench", "--study", "none", "--no-atlas", "-o", out]
    assert _run(argv) == 0 and (out / "report.md").is_file()
    first = (out / "report.md").read_text()
    capsys.readouterr()
    assert _run(argv) == 2
    assert "report.md exists; use --force" in capsys.readouterr().err
    assert (out / "report.md").read_text() == first
    assert _run([*argv, "--force"]) == 0
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
