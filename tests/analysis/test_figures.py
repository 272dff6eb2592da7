"""Figures contain the expected artists, labels and units (not pixels); files are written in two formats; every
figure of the registry and of every command that draws passes the reviewer's checks (analysis.figure_check)."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis import figures as F
from analysis.fit import compare_models
from analysis.measured import MeasuredCurve
from analysis.normalisation import normalise_measured, normalise_simulated
from contactrig.core.validation import SettingError
from sims.models import ContactModel, model_label, model_names, models
from sims.models import register as register_model
from sims.models import unregister as unregister_model

W = np.array([5.0, 10.0, 15.0, 20.0])
RNG = np.random.default_rng(0)
CURVE = MeasuredCurve(W, (8e-3 / (W / 5.0) ** 0.8)[:, None] * (1 + 0.05 * RNG.normal(size=(4, 3))), paired=True)
AREAS = {"greenwood_tripp": 1e-7 * (W / 5) ** 0.8, "hertz": 1e-7 * (W / 5) ** (2 / 3)}


def _units(ax, bottom=None):
    """Units on the y axis of ``ax`` and on the x axis of ``bottom`` (the panel that carries a shared x label)."""
    x = (bottom or ax).get_xlabel()
    return "[" in x and "]" in x and "[" in ax.get_ylabel() and "]" in ax.get_ylabel()


def _legend_texts(fig):
    """Every legend entry of ``fig``, line breaks read as spaces."""
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes)]
    return [" ".join(t.get_text().split()) for leg in legends if leg is not None for t in leg.get_texts()]


def _visible_axes(fig):
    return [ax for ax in fig.axes if ax.get_visible()]


def test_measured_has_every_repeat_and_mean_with_sem():
    fig = F.figure_measured(CURVE)
    ax = fig.axes[0]
    repeat_lines = [ln for ln in ax.get_lines() if (ln.get_gid() or "").startswith("repeat-")]
    assert len(repeat_lines) == 3
    assert len(ax.containers) == 1  # the errorbar of mean ± 1 SEM
    mean_line = ax.containers[0].lines[0]
    assert np.allclose(mean_line.get_ydata(), CURVE.mean_ohm * 1e3)
    assert _units(ax) and "mΩ" in ax.get_ylabel() and "kg" in ax.get_xlabel()
    assert any("± 1 SEM" in t.get_text() for t in ax.get_legend().get_texts())
    (bars,) = ax.containers[0].lines[2]
    half = np.array([abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()])
    v = CURVE.values_ohm * 1e3
    np.testing.assert_allclose(half, v.std(axis=1, ddof=1) / np.sqrt(v.shape[1]), rtol=1e-9)


def test_simulated_area_one_line_per_model_with_names():
    fig = F.figure_simulated_area({k: (W, a) for k, a in AREAS.items()})
    ax = fig.axes[0]
    assert len(ax.get_lines()) == 2
    assert {t.get_text() for t in ax.get_legend().get_texts()} == {"Greenwood–Tripp", "Hertz"}
    assert _units(ax, fig.axes[1]) and "mm²" in ax.get_ylabel()
    (gt,) = [ln for ln in ax.get_lines() if ln.get_label() == "Greenwood–Tripp"]
    assert np.allclose(gt.get_ydata(), AREAS["greenwood_tripp"] * 1e6)
    assert not any("coincide" in t for t in _legend_texts(fig))  # 0.8 and 2/3 power laws differ by far more


def test_normalised_starts_at_one_for_all_curves():
    sims = {k: normalise_simulated(W, 5e-10 / a) for k, a in AREAS.items()}
    fig = F.figure_normalised(normalise_measured(CURVE), sims)
    ax = fig.axes[0]
    for line in ax.get_lines():
        if len(line.get_ydata()) == W.size:
            assert line.get_ydata()[0] == pytest.approx(1.0)
    assert len(ax.containers) == 1
    assert _units(ax, fig.axes[1]) and "R/R₀" in ax.get_ylabel()


def test_normalised_error_bars_are_one_standard_error():
    measured = normalise_measured(CURVE)
    fig = F.figure_normalised(measured, {})
    (bars,) = fig.axes[0].containers[0].lines[2]  # ErrorbarContainer: (data line, caps, bar collections)
    half = np.array([abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()])
    # independent: first-order SE of a ratio of paired means, SD over series of (R_ik − r_i R_0k)/R̄_0 over √n
    v = CURVE.values_ohm
    mean = v.mean(axis=1)
    influence = (v - (mean / mean[0])[:, None] * v[0][None, :]) / mean[0]
    np.testing.assert_allclose(half, influence.std(axis=1, ddof=1) / np.sqrt(v.shape[1]), rtol=1e-9, atol=1e-15)
    assert "± 1 SEM" in fig.axes[0].containers[0].get_label()


def test_fit_figure_has_fits_and_residual_bars():
    cmp = compare_models(CURVE, AREAS, height_m=5e-3, n_boot=50)
    fig = F.figure_fit(cmp)
    top, bottom = fig.axes[:2]
    fitted = [ln for ln in top.get_lines() if f"Δ{cmp.criterion}" in str(ln.get_label())]
    assert len(fitted) == 2
    assert {model_label(n) for n in AREAS} == {str(ln.get_label()).split(":")[0] for ln in fitted}
    assert len(bottom.patches) == 2 * W.size
    assert all(f"Δ{cmp.criterion}" in t or "measured" in t or "coincide" in t for t in _legend_texts(fig))
    assert _units(bottom) and "mΩ" in top.get_ylabel()


def test_database_two_panels_with_log_pressure():
    h = np.linspace(0, 3e-6, 20)
    c = SimpleNamespace(separation_m=h, pressure_pa=1e8 * np.exp(-h / 5e-7), area_fraction=0.1 * np.exp(-h / 4e-7))
    fig = F.figure_database({"greenwood_tripp": c, "hertz": c})
    a, b, da, db = fig.axes
    assert a.get_yscale() == "log" and len(a.get_lines()) == 3 and len(b.get_lines()) == 2  # + the note
    assert _units(a, da) and _units(b, db) and "µm" in da.get_xlabel()
    names = ", ".join(model_label(m) for m in F.registry_order(["greenwood_tripp", "hertz"]))
    assert f"coincide within 0 % (identical): {names}" in _legend_texts(fig)


def test_error_vs_time_is_log_log_and_counts_undrawable_rows():
    rows = [
        {"study": "gi", "method": "pbdv", "setting": "n=1", "error": 1e-3, "seconds": 1e-3},
        {"study": "gi", "method": "pbdv", "setting": "n=2", "error": 1e-6, "seconds": 1e-2},
        {"study": "gi", "method": "table", "setting": "x", "error": 0.0, "seconds": 1e-4},
        SimpleNamespace(study="mesh", method="uniform", setting="64", error=2e-2, seconds=0.5),
    ]
    fig = F.figure_error_vs_time(rows)
    axes = _visible_axes(fig)
    assert len(axes) == 2
    ax = axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert "1 row" in ax.get_title()
    assert _units(ax)
    assert len(ax.get_lines()) == 1
    with pytest.raises(SettingError, match="rows"):
        F.figure_error_vs_time(rows, study="nothing")


def test_save_writes_png_and_svg(tmp_path):
    paths = F.save_figure(F.figure_measured(CURVE), tmp_path, "fig9")
    assert [p.suffix for p in paths] == [".png", ".svg"]
    assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "<svg" in paths[1].read_text()
    with pytest.raises(SettingError, match="format"):
        F.save_figure(F.figure_measured(CURVE), tmp_path, "x", formats=("bmp",))


def test_a_model_looks_the_same_in_every_figure_and_models_differ():
    known = list(model_names())
    assert len(known) >= 5
    assert len({F.model_style(n)["color"] for n in known}) == len(known)
    assert len({(F.model_style(n)["linestyle"], F.model_style(n)["marker"]) for n in known}) == len(known)
    area = F.figure_simulated_area({k: (W, a) for k, a in AREAS.items()}).axes[0].get_lines()
    cmp = compare_models(CURVE, AREAS, height_m=5e-3, n_boot=0)
    fit_lines = [ln for ln in F.figure_fit(cmp).axes[0].get_lines() if f"Δ{cmp.criterion}" in str(ln.get_label())]
    by_label = {str(ln.get_label()).split(":")[0]: ln.get_color() for ln in fit_lines}
    for ln in area:
        assert by_label[ln.get_label()] == ln.get_color()
    assert model_label("jackson_green") == "Jackson–Green"
    assert model_label("my_model") == "my model"


def _toy_model(key, label, style=None):
    return ContactModel(key=key, label=label, build=lambda ctx: None, style=style or {})


def test_labels_and_styles_come_from_the_model_registry_and_unstyled_models_cycle():
    register_model(_toy_model("toy_styled", "Toy styled", {"color": "#123456", "linestyle": "--", "marker": "*"}))
    register_model(_toy_model("toy_plain_a", "Toy A"))
    register_model(_toy_model("toy_plain_b", "Toy B"))
    try:
        s = F.model_style("toy_styled")
        assert (s["color"], s["linestyle"], s["marker"], s["label"]) == ("#123456", "--", "*", "Toy styled")
        a, b = F.model_style("toy_plain_a"), F.model_style("toy_plain_b")
        assert a["label"] == "Toy A" and b["label"] == "Toy B"
        styled = {m.style["color"] for m in models() if "color" in m.style}
        assert a["color"] != b["color"] and not {a["color"], b["color"]} & styled
        assert (a["linestyle"], a["marker"]) != (b["linestyle"], b["marker"])
        assert F.model_style("toy_plain_a") == a  # stable: the same in every figure
        fig = F.figure_simulated_area({"toy_plain_a": (W, AREAS["hertz"]), "toy_styled": (W, AREAS["hertz"])})
        assert set(_legend_texts(fig)) == {"Toy A", "Toy styled", "coincide within 0 % (identical): Toy styled, Toy A"}
        assert F.registry_order(["toy_styled", "not_registered", "toy_plain_a"]) == [
            "toy_styled", "toy_plain_a", "not_registered"]  # fmt: skip
    finally:
        for key in ("toy_styled", "toy_plain_a", "toy_plain_b"):
            unregister_model(key)
    # a key nobody registered: readable label, a colour from the cycle
    u = F.model_style("not_registered")
    assert u["label"] == "not registered" and u["color"].startswith("#")


def test_fig2_for_a_database_written_to_one_file(tmp_path):
    h = np.linspace(0, 3e-6, 20)
    c = SimpleNamespace(separation_m=h, pressure_pa=1e8 * np.exp(-h / 5e-7), area_fraction=0.1 * np.exp(-h / 4e-7))
    path = F.write_database_figure({"greenwood_tripp": c, "hertz": c}, tmp_path / "fig2.pdf")
    assert path == tmp_path / "fig2.pdf" and path.read_bytes()[:4] == b"%PDF"
    with pytest.raises(SettingError, match="format"):
        F.write_database_figure({"hertz": c}, tmp_path / "fig2.bmp")


def _analysis(database=None, conversion="bulk"):
    from analysis.pipeline import analyse
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    scene = load_scene(None)
    sweep = SimpleNamespace(
        models={k: SimpleNamespace(weight_kg=W, contact_area_m2=a) for k, a in AREAS.items()},
        warnings=[],
        provenance={"fingerprint": config_fingerprint(SimConfig.from_scene(scene))},
    )
    return analyse(CURVE, sweep, scene, title="Toy", n_boot=20, database=database, conversion=conversion)


def test_figure_registry_drives_the_figures_and_the_report(tmp_path):
    from analysis.report import write_report

    keys = [s.key for s in F.figure_specs()]
    assert {"fig02_database", "fig09_measured", "fig11_area", "fig12_normalised", "fit_residuals"} <= set(keys)
    with pytest.raises(ValueError, match="registered already"):
        F.register(F.FigureSpec("fig09_measured", "again", lambda a: None))
    with pytest.raises(KeyError, match="fig09_measured"):
        F.get_figure("nope")

    def draw(a):
        fig = F.figure_measured(a.curve, title="toy figure")
        return fig

    spec = F.register(F.FigureSpec("toy_fig", "A toy figure", draw, caption="Toy caption.", filename="toy"))
    try:
        a = _analysis()
        written = F.write_figures(a, tmp_path / "figs", formats=("png",))
        # every registered figure this analysis has data for, in registration order; no database: no Fig. 2
        assert list(written)[-1] == "toy_fig" and "fig02_database" not in written
        assert {"fig09_measured", "fig11_area", "fig12_normalised", "fit_residuals"} <= set(written)
        assert list(written) == [k for k in [*keys, "toy_fig"] if k in written]
        assert written["toy_fig"] == [tmp_path / "figs" / "toy.png"]
        report = write_report([a], tmp_path / "rep")
        text = report.read_text()
        assert "### Further figures" in text and "![A toy figure](figures/toy-toy.png)" in text
        assert "Toy caption." in text
        assert text.index("![Measured resistance") < text.index("### Simulated real contact area")
        assert text.index("### Fit and model comparison") < text.index("![Fit and residuals")
        for line in text.splitlines():
            if line.startswith("!["):
                assert (tmp_path / "rep" / line.split("](")[1].split(")")[0]).is_file()
    finally:
        F.unregister(spec.key)
    assert "toy_fig" not in [s.key for s in F.figure_specs()]


# ---- coinciding models --------------------------------------------------------------------------------------------
def test_coinciding_models_are_grouped_with_their_largest_relative_difference():
    base = 1e-7 * (W / 5) ** 0.8
    areas = {"jackson_green": base * 1.003, "hertz": base, "greenwood_tripp": base * 0.9, "lagemann": base * 1.001}
    (group,) = F.coinciding(areas)
    # registry order (as the registry holds it: an import of sims.asperity before the first look-up puts Hertz
    # first); Greenwood–Tripp is 10 % away
    assert group[0] == tuple(F.registry_order(["jackson_green", "lagemann", "hertz"]))
    assert group[1] == pytest.approx(0.003 / 1.003, rel=1e-12)  # |a − b| / max(|a|, |b|) of Hertz vs Jackson–Green
    pair = tuple(F.registry_order(["lagemann", "hertz"]))
    assert F.coinciding(areas, tol=0.001) == [(pair, pytest.approx(0.001 / 1.001, rel=1e-9))]
    assert F.max_relative_difference([0.0, 1.0], [0.0, np.nan]) == np.inf  # no comparable point: never coincide

    fig = F.figure_simulated_area({k: (W, a) for k, a in areas.items()})
    bottom = fig.axes[1]
    notes = [t for t in _legend_texts(fig) if "coincide" in t]
    assert notes == ["coincide within 0.3 %: " + ", ".join(model_label(m) for m in group[0])]
    # the differences panel: 100·(A/A_Hertz − 1) per model, the reference the first of the group
    by_colour = {ln.get_color(): ln.get_ydata() for ln in bottom.get_lines()}
    reference = group[0][0]
    for key, factor in (("jackson_green", 1.003), ("greenwood_tripp", 0.9), ("lagemann", 1.001), ("hertz", 1.0)):
        expected = 100.0 * (factor / {"hertz": 1.0, "lagemann": 1.001, "jackson_green": 1.003}[reference] - 1.0)
        np.testing.assert_allclose(by_colour[F.model_style(key)["color"]], expected, rtol=1e-9, atol=1e-12)
    assert model_label(reference) in bottom.get_title() and bottom.get_yscale() == "symlog"
    assert "[%]" in bottom.get_ylabel()
    assert [t for t in _legend_texts(fig) if "coincide" not in t] == [
        model_label(m) for m in F.registry_order(areas)]  # fmt: skip  registry order, not the given one
    assert F.registry_order(areas) != list(areas)


def test_repeats_take_a_qualitative_palette_with_markers_in_order():
    from analysis.figure_style import REPEAT_COLOURS, repeat_style

    curve = MeasuredCurve(W, np.outer(8e-3 / (W / 5.0), np.linspace(0.9, 1.1, 8)), paired=True)
    fig = F.figure_measured(curve)
    lines = [ln for ln in fig.axes[0].get_lines() if (ln.get_gid() or "").startswith("repeat-")]
    styles = [(ln.get_color(), ln.get_marker()) for ln in lines]
    assert len(set(styles)) == 8 and len({c for c, _ in styles}) == len(REPEAT_COLOURS)
    assert [t for t in _legend_texts(fig) if t.startswith("M")] == [f"M{k}" for k in range(1, 9)]
    assert len({(s["color"], s["marker"]) for s in map(repeat_style, range(56))}) == 56


# ---- the reviewer's checks ---------------------------------------------------------------------------------------
def _plain_figure(**text):
    fig, axes = F._figure(size=(4.0, 3.0))
    ax = axes[0, 0]
    ax.plot(W, W, label=text.get("label", "_x"))
    ax.set(xlabel=text.get("xlabel", "weight W [kg]"), ylabel=text.get("ylabel", "resistance R [mΩ]"))
    ax.set_title(text.get("title", "A clean figure"))
    return fig, ax


def test_the_checker_passes_a_clean_figure_and_names_each_fault():
    from analysis.figure_check import FigureCheckError, check_figure, figure_problems

    fig, ax = _plain_figure()
    assert figure_problems(fig) == []
    check_figure(fig)

    fig, ax = _plain_figure()
    ax.text(10, 10, "tiny", fontsize=6)
    assert figure_problems(fig) == ["text 'tiny' is 6 pt (< 7 pt)"]

    fig, ax = _plain_figure(title="a title far too long to fit on a four-inch canvas at ten points, going on and on")
    assert any("leaves the canvas" in p for p in figure_problems(fig))

    fig, ax = _plain_figure()
    ax.text(0.5, 0.5, "first", transform=ax.transAxes)
    ax.text(0.5, 0.5, "second", transform=ax.transAxes)
    assert figure_problems(fig) == ["text 'first' overlaps 'second'"]

    fig, ax = _plain_figure(ylabel="resistance R (mΩ)")
    assert figure_problems(fig) == ["axes 'A clean figure' y: label 'resistance R (mΩ)' has no unit in [ ]"]
    fig, ax = _plain_figure(xlabel="")
    assert figure_problems(fig) == ["axes 'A clean figure' x: no axis label"]
    fig, ax = _plain_figure(xlabel="model pair")
    ax.set_xticks([5, 20], ["Hertz", "Lagemann"])  # named categories: a label, no unit
    assert figure_problems(fig) == []

    fig, ax = _plain_figure(label="Hertz")
    assert figure_problems(fig) == ["'Hertz' is drawn but in no legend"]
    ax.legend()
    assert figure_problems(fig) == []
    assert figure_problems(fig, models=["hertz", "lagemann"]) == ["model 'Lagemann' is shown but not in the legend"]
    assert figure_problems(fig, models=[]) == ["legend names 'Hertz', which is not shown"]

    fig, ax = _plain_figure(title="Fit R = R_s + s·x (1 realisation(s))")
    assert figure_problems(fig) == [
        "text 'Fit R = R_s + s·x (1 realisation(s))' has a literal underscore (a raw key, or a subscript without "
        "mathtext)",
        "text 'Fit R = R_s + s·x (1 realisation(s))' says '(s)': give the number its own singular or plural",
    ]
    fig, ax = _plain_figure(title="Fit R = R$_s$ + s·x")
    assert figure_problems(fig) == []
    with pytest.raises(FigureCheckError, match="figure X: text 'tiny'"):
        ax.text(10, 10, "tiny", fontsize=6)
        check_figure(fig, what="figure X")


def _toy_comparison():
    from sims.ensemble import CompareSettings, Comparison, TaskResult

    p = np.array([0.1e6, 1e6, 10e6])
    bem = np.array([0.01, 0.05, 0.2])
    out = [TaskResult(0, "bem", p, np.full(3, 1e-6), np.full(3, 1e-6), bem, np.full(3, 1e12), np.ones(3, bool), {})]
    for model, f in (("greenwood_tripp", 0.7), ("hertz", 0.9), ("lagemann", 0.9 * 1.0005)):
        out.append(TaskResult(0, model, p, np.full(3, 0.9e-6), np.full(3, 0.9e-6), bem * f, np.full(3, 0.8e12),
                              np.ones(3, bool), {}))  # fmt: skip
    st = CompareSettings(pressures_pa=tuple(p), models=("lagemann", "hertz", "greenwood_tripp"), realisations=1)
    return Comparison(st, tuple(out), {"scene_name": "toy"})


def _full_analysis(conversion="bulk"):
    """A toy analysis with every figure's data: fits, a contact database and a model ranking."""
    import dataclasses

    h = np.linspace(0, 3e-6, 30)
    db = {n: SimpleNamespace(separation_m=h, pressure_pa=1e8 * np.exp(-h / s), area_fraction=0.1 * np.exp(-h / s))
          for n, s in (("greenwood_tripp", 5e-7), ("hertz", 4e-7))}  # fmt: skip
    return dataclasses.replace(_analysis(database=db, conversion=conversion), model_ranking=_toy_comparison())


def test_every_registered_figure_passes_the_reviewer_checks():
    """Registry-driven: a figure registered tomorrow is drawn and checked here without a new test."""
    from analysis.figure_check import check_figure

    # A figure may belong to one conversion only (the physical one has no toy database: its band width needs a law).
    analyses = [_full_analysis(), _analysis(conversion="physical")]
    for spec in F.figure_specs():
        figs = [fig for fig in (spec.draw(a) for a in analyses) if fig is not None]
        assert figs, f"{spec.key} drew nothing for a full analysis of any conversion: {spec.missing}"
        for fig in figs:
            check_figure(fig, what=spec.key)


def test_the_discrimination_map_names_models_and_labels_its_colour_bar():
    from analysis.design import DesignResult, Plan
    from analysis.figure_check import check_figure

    plans = [Plan((2.0, 5.0, 26.0), r, 60.0 * r) for r in (3, 6, 12)]
    pairs = {("greenwood_tripp", "hertz"): np.array([0.2, 0.6, 0.95]), ("hertz", "lagemann"): np.zeros(3)}
    cheapest = {("greenwood_tripp", "hertz"): 2, ("hertz", "lagemann"): None}
    result = DesignResult(plans, ["greenwood_tripp", "hertz", "lagemann"], {}, pairs, cheapest, 100, 0.9, "rig", 2e-9,
                          0.0)  # fmt: skip
    fig = F.figure_discrimination(result)
    check_figure(fig, what="discrimination")
    ax, bar = fig.axes
    assert [t.get_text() for t in ax.get_xticklabels()] == ["Greenwood–Tripp\nvs Hertz", "Hertz\nvs Lagemann"]
    assert "P(ΔAIC ≥ 10" in bar.get_ylabel() and "[–]" in bar.get_ylabel()
    assert ax.get_xlabel() and ax.get_ylabel()
    (star,) = [ln for ln in ax.get_lines() if ln.get_marker() == "*"]
    assert list(star.get_xdata()) == [0] and list(star.get_ydata()) == [2]  # cheapest plan reaching 0.9


def test_error_vs_time_passes_the_checks():
    from analysis.figure_check import check_figure

    rows = [{"study": "gaussian_integrals", "method": m, "setting": f"n={n}", "error": f * 10.0**-n,
             "seconds": f * 1e-3 * n} for m, f in (("pbdv", 1.0), ("table", 30.0)) for n in (1, 3, 6)]  # fmt: skip
    check_figure(F.figure_error_vs_time(rows), what="error vs time")


@pytest.fixture
def checked_savefig(monkeypatch):
    """Every figure any code saves while the test runs is checked first; returns the list of what was checked."""
    from matplotlib.figure import Figure

    from analysis.figure_check import check_figure

    seen = []
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        check_figure(self, what=str(fname))
        seen.append(str(fname))
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return seen


def test_every_command_that_draws_passes_the_checks(tmp_path, checked_savefig, capsys):
    """``figures``, ``database --plot``, ``compare-models --plot``, ``design`` and ``watch --png`` on small inputs:
    each saved figure is checked (the demo's figures are the registry's, checked above)."""
    from contactrig.cli.main import main
    from tests.analysis.test_commands import _incomplete_session, _sweep_file
    from tests.sims.test_contact_database import SMALL

    session = _incomplete_session(tmp_path / "s.h5")
    sim = _sweep_file(tmp_path / "sim.h5")
    assert main(["figures", str(session), "--sim", str(sim), "-o", str(tmp_path / "f"), "--bootstrap", "0"]) == 0
    scene = tmp_path / "small.toml"
    scene.write_text(SMALL)
    assert main(["database", str(scene), "-o", str(tmp_path / "d.h5"), "--plot", str(tmp_path / "fig2.png")]) == 0
    assert main(["compare-models", str(scene), "--models", "hertz,lagemann,greenwood_tripp", "--pressures",
                 "1e6,5e6", "--jobs", "1", "--plot", str(tmp_path / "cmp.png")]) == 0  # fmt: skip
    assert main(["design", "-o", str(tmp_path / "design"), "--sessions", "20"]) == 0
    assert main(["watch", str(session), "--png", str(tmp_path / "live.png"), "--once"]) == 0
    capsys.readouterr()
    drawn = " ".join(checked_savefig)
    for name in ("fig09_measured", "fit_residuals", "fig2.png", "cmp.png", "discrimination.png", "live.png"):
        assert name in drawn


def test_the_live_view_draws_mean_and_one_sem_and_passes_the_checks():
    from analysis.figure_check import check_figure
    from analysis.watch import BlockRow, LiveState, _new_figure, draw_state

    means = {5.0: [1.0e-3, 1.2e-3, 1.1e-3], 10.0: [0.6e-3, 0.7e-3, 0.9e-3]}
    rows = tuple(
        BlockRow(3 * i + k, w, k + 1, v, 100, 1 if k == 2 else 0, False, 1000.0 + 10 * (3 * i + k))
        for i, (w, vs) in enumerate(means.items())
        for k, v in enumerate(vs)
    )
    t = np.arange(8.0)
    state = LiveState("s.h5", "running", rows, blocks_planned=9, current_time_s=t, current_ohm=1e-3 + 1e-6 * t,
                      current_valid=t != 3)  # fmt: skip
    fig = _new_figure()
    draw_state(fig, state, now=1070.0)
    check_figure(fig, what="live view")
    left = fig.axes[0]
    (mean,) = left.containers
    assert mean.get_label() == "mean ± 1 SEM"
    (bars,) = mean.lines[2]
    half = [abs(seg[1, 1] - seg[0, 1]) / 2 for seg in bars.get_segments()]
    # independent: sample SD over the three repeats / √3, in the axis' unit
    k = {"[µΩ]": 1e6, "[mΩ]": 1e3, "[Ω]": 1.0}[left.get_ylabel().split()[-1]]
    expected = [k * np.std(vs, ddof=1) / np.sqrt(3) for vs in means.values()]
    np.testing.assert_allclose(half, expected, rtol=1e-9)
    assert [t.get_text() for t in left.get_legend().get_texts()] == ["M1", "M2", "M3", "mean ± 1 SEM"]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=6),
    st.lists(st.floats(1e-300, 1e6), min_size=5, max_size=5),
)
def test_relative_difference_and_groups_on_extreme_values(values, scales):
    a = np.array(values)
    d = F.max_relative_difference(a, a[::-1])
    assert d == F.max_relative_difference(a[::-1], a)  # symmetric
    assert d == np.inf or 0.0 <= d <= 2.0  # |a − b| ≤ 2·max(|a|, |b|)
    if np.isfinite(a).any() and np.any(np.abs(a[np.isfinite(a)]) > 0):
        assert F.max_relative_difference(a, a) == 0.0
    keys = list(model_names())[:5]
    series = {k: s * np.linspace(1.0, 2.0, 4) for k, s in zip(keys, scales, strict=True)}
    groups = F.coinciding(series)
    members = [m for g, _ in groups for m in g]
    assert len(members) == len(set(members))  # disjoint
    for group, worst in groups:
        assert list(group) == F.registry_order(group) and len(group) >= 2
        assert all(any(F.max_relative_difference(series[m], series[o]) <= F.COINCIDE_REL for o in group if o != m)
                   for m in group)  # fmt: skip
        assert worst == max(F.max_relative_difference(series[m], series[o]) for m in group for o in group if o != m)
