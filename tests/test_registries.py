"""The registries are the only place a contact model or a figure is named (issue #10).

A toy contact model and a toy figure are registered *inside this test* — no other file is edited — and must flow
through every stage: the database builds the model, the CLI help and the stability atlas list it, the rig solves
its equilibrium, the fit ranks it, and the report shows its label and draws the figure.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis import figures
from analysis.figures import FigureSpec
from contactrig.core.scene import load_scene
from sims import models
from sims.config import SimConfig
from sims.database import BuildContext, ContactCurve, build_database

TOY = "toy_exponential"
TOY_LABEL = "Toy exponential law"
P0_PA = 2.0e6  # pressure at h = 0
A0 = 5.0e-3  # real-area fraction at h = 0


def _toy_build(ctx: BuildContext) -> ContactCurve:
    """p = P0 e^(−h/σ), A/A0 = A0 e^(−h/σ): log-linear, so the database's log-space interpolation is exact."""
    sigma = ctx.sigma_m
    h = np.linspace(-2.0 * sigma, 6.0 * sigma, ctx.settings.n_separations)
    return ContactCurve(TOY, h, P0_PA * np.exp(-h / sigma), A0 * np.exp(-h / sigma), {"sigma_m": sigma})


def _toy_figure(analysis):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    ax = fig.subplots()
    ax.plot(analysis.curve.weight_kg, analysis.areas_m2[TOY] * 1e6, "o-")
    ax.set(xlabel="weight [kg]", ylabel="toy area [mm²]")
    return fig


@pytest.fixture
def toy_registered():
    models.register(models.ContactModel(TOY, TOY_LABEL, build=_toy_build, needs_surface=False))
    figures.register(
        FigureSpec("toy_area", "Toy area against weight", draw=_toy_figure, caption="The toy model's real area.")
    )
    try:
        yield
    finally:
        models.unregister(TOY)
        figures.unregister("toy_area")
    assert TOY not in models.model_names()


def test_toy_model_and_figure_flow_through_every_stage(toy_registered, tmp_path):
    from analysis.pipeline import analyse_tab1
    from analysis.report import write_report
    from analysis.studies.atlas_cases import database_cases
    from contactrig.cli.options import models_help
    from sims.rig import sweep

    # registry → CLI help and the stability atlas, with no list to edit
    assert TOY in models_help()
    assert any(case.method == f"database.{TOY}" for case in database_cases())
    # a notebook's model is built on request, not by default
    config = SimConfig.from_scene(load_scene())
    assert TOY not in config.database.models

    # database: the toy curve, exact between the nodes (log-linear law, independent closed form)
    db = build_database(config, ["greenwood_tripp", TOY])
    assert list(db) == ["greenwood_tripp", TOY]
    curve = db[TOY]
    sigma = curve.parameters["sigma_m"]
    h = np.linspace(curve.h_min, curve.h_max, 1001)
    np.testing.assert_allclose(curve.pressure(h), P0_PA * np.exp(-h / sigma), rtol=1e-9)
    np.testing.assert_allclose(curve.dpressure_dh(h), -P0_PA / sigma * np.exp(-h / sigma), rtol=1e-7)

    # rig: one equilibrium per weight; the heavier the piston, the larger the real area
    weights = [5.44, 10.0, 25.966]
    result = sweep(config, models=["greenwood_tripp", TOY], weights_kg=weights, database=db)
    area = np.asarray(result.models[TOY].contact_area_m2)
    assert area.shape == (3,) and np.all(area > 0) and np.all(np.diff(area) > 0)
    force = np.asarray(result.models[TOY].force_n)
    np.testing.assert_allclose(force, np.asarray(weights) * 9.80665, rtol=1e-6)

    # fit and report: the toy model is ranked, labelled from the registry, and its figure is drawn
    analysis = analyse_tab1(result, series=["M1", "M2", "M3"], n_boot=0)
    fit = analysis.comparison.fits[TOY]
    assert np.isfinite(fit.estimate.scale) and fit.estimate.scale > 0
    report = write_report([analysis], tmp_path / "report")
    text = report.read_text(encoding="utf-8")
    assert TOY_LABEL in text
    assert "Toy area against weight" in text
    drawn = sorted((tmp_path / "report" / "figures").glob("*toy_area*"))
    assert drawn and all(p.stat().st_size > 0 for p in drawn)


def test_an_unknown_model_names_the_registered_ones():
    from contactrig.core.validation import SettingError

    config = SimConfig.from_scene(load_scene())
    with pytest.raises(SettingError) as err:
        build_database(config, ["hertzz"])
    message = str(err.value)
    assert "hertzz" in message
    for key in models.model_names():
        assert key in message
