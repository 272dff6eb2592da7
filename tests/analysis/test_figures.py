"""Figures contain the expected artists, labels and units (not pixels); files are written in two formats."""

from types import SimpleNamespace

import numpy as np
import pytest

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


def _units(ax):
    return "[" in ax.get_xlabel() and "]" in ax.get_xlabel() and "[" in ax.get_ylabel() and "]" in ax.get_ylabel()


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
    assert _units(ax) and "mm²" in ax.get_ylabel()
    assert np.allclose(ax.get_lines()[0].get_ydata(), AREAS["greenwood_tripp"] * 1e6)


def test_normalised_starts_at_one_for_all_curves():
    sims = {k: normalise_simulated(W, 5e-10 / a) for k, a in AREAS.items()}
    fig = F.figure_normalised(normalise_measured(CURVE), sims)
    ax = fig.axes[0]
    for line in ax.get_lines():
        if len(line.get_ydata()) == W.size:
            assert line.get_ydata()[0] == pytest.approx(1.0)
    assert len(ax.containers) == 1
    assert _units(ax) and "R/R₀" in ax.get_ylabel()


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
    assert all(f"Δ{cmp.criterion}" in t.get_text() or "measured" in t.get_text() for t in top.get_legend().get_texts())
    assert _units(bottom) and "mΩ" in top.get_ylabel()


def test_database_two_panels_with_log_pressure():
    h = np.linspace(0, 3e-6, 20)
    c = SimpleNamespace(separation_m=h, pressure_pa=1e8 * np.exp(-h / 5e-7), area_fraction=0.1 * np.exp(-h / 4e-7))
    fig = F.figure_database({"greenwood_tripp": c, "hertz": c})
    a, b = fig.axes
    assert a.get_yscale() == "log" and len(a.get_lines()) == 2 and len(b.get_lines()) == 2
    assert _units(a) and _units(b) and "µm" in a.get_xlabel()


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
        assert {t.get_text() for t in fig.axes[0].get_legend().get_texts()} == {"Toy A", "Toy styled"}
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


def _analysis(database=None):
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
    return analyse(CURVE, sweep, scene, title="Toy", n_boot=20, database=database)


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
