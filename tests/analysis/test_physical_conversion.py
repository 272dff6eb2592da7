"""The physical resistance model as a fit conversion (issue 21 §2)."""

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from analysis.fit import compare_models
from analysis.measured import MeasuredCurve

W = np.array([5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966])


def test_stiffness_weighted_width_of_a_uniform_band_is_its_width():
    from analysis.resistance_model import stiffness_weighted_width_m

    radius, theta0 = 0.042, 0.2
    edges = np.linspace(0.0, math.pi, 20_001)
    theta = 0.5 * (edges[1:] + edges[:-1])
    mesh = SimpleNamespace(radius_m=radius, theta_rad=theta, area_m2=np.ones((theta.size, 3)) * np.diff(edges)[:, None])

    class Law:  # stiffness −p′ = 1 inside the band |θ| < θ0, 0 outside
        @staticmethod
        def dpressure_dh(h):
            return -(np.abs(h) < theta0).astype(float)

    loads = SimpleNamespace(law=Law(), gap=lambda h0: np.broadcast_to(theta[:, None], (theta.size, 3)))
    batch = SimpleNamespace(loads=loads, mesh=mesh, min_separation_m=np.array(0.0))
    assert float(stiffness_weighted_width_m(batch)) == pytest.approx(2 * radius * theta0, rel=1e-3)


def test_load_independent_data_are_not_a_contact_area_measurement():
    # a constant 5 mΩ with 1 % noise, like `instruments serve-sim` with a fixed resistance
    rng = np.random.default_rng(4)
    curve = MeasuredCurve(W, 5e-3 * (1 + 0.01 * rng.normal(size=(8, 6))), paired=True)
    areas = {"a": 1e-7 * (W / W[0]) ** 0.8, "b": 1e-7 * (W / W[0]) ** 0.95}
    cmp = compare_models(curve, areas, height_m=5e-3, n_boot=0)
    assert all(f.load_independent for f in cmp.fits.values())
    assert "does not depend on the load: this is not a contact-area measurement" in cmp.statement
    assert "not ranked" in cmp.statement and not cmp.discriminates
    assert "discriminate between" not in cmp.statement


def test_fit_tab1_physical_json_has_the_shares(capsys):
    from contactrig.cli.main import main

    assert (
        main(["fit", "tab1", "--conversion", "physical", "--bootstrap", "0", "--models", "greenwood_tripp", "--json"])
        == 0
    )
    d = json.loads(capsys.readouterr().out)
    fit = d["models"]["greenwood_tripp"]
    assert fit["conversion"] == "physical" and fit["estimate"]["scale_units"] == "ohm*m2"
    assert 1e-9 < fit["estimate"]["scale"] < 4e-9  # σ_f [Ω·m²], the film of Tab. 1
    shares = fit["shares"]
    assert set(shares) == {"series", "film", "barber", "macro", "residual"} and len(shares["film"]) == 8
    total = np.sum([shares[k] for k in shares if k != "residual"], axis=0)
    fitted, measured = np.array(fit["points"]["fitted_ohm"]), np.array(fit["points"]["measured_ohm"])
    assert np.allclose(total, fitted / measured, rtol=1e-9)  # the terms' shares add up to fitted/measured
    assert np.allclose(total + np.array(shares["residual"]), 1.0, rtol=1e-12)  # the residual is the rest
    assert 0.003 < min(shares["barber"]) and max(shares["barber"]) < 0.03


def test_fit_of_a_simulated_session_file_brackets_the_simulated_film_and_series(tmp_path, capsys):
    """End to end: ``acquire --sim`` (default scene, Tab. 1 noise, R_s = 0.2 mΩ) then ``fit --conversion physical``:
    the bench's clean-metal terms are the ones the fit subtracts, so the 95 % t-intervals bracket the simulated σ_f
    and R_s (before, the bench had no clean-metal terms and the physical fit of a simulated session found R_s ≈ −0.23
    mΩ). One seeded session; the coverage over many is tests/analysis/test_simulated_session.py."""
    import re

    from contactrig.cli.main import main
    from contactrig.core.scene import default_scene_text

    text = re.sub(r"(?m)^count = .*$", "count = 8", default_scene_text())
    text = re.sub(r"(?m)^series_resistance_ohm = .*$", "series_resistance_ohm = 2e-4", text)
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    session = tmp_path / "s.h5"
    assert main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", "-o", str(session)]) == 0
    capsys.readouterr()
    argv = ["fit", str(session), "--conversion", "physical", "--bootstrap", "0", "--models", "greenwood_tripp"]
    assert main([*argv, "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)["models"]["greenwood_tripp"]
    t = fit["intervals"]["t"]
    from daq import load_session

    circuit = load_session(session).start["simulation"]["circuit"]
    film = circuit["resistivity_ohm_m"] * circuit["contact_height_m"]  # ζ·h of the scene's [circuit]
    assert circuit["series_resistance_ohm"] == 2e-4
    assert t["scale"][0] <= film <= t["scale"][1], (t["scale"], film)
    assert t["R_series_ohm"][0] <= 2e-4 <= t["R_series_ohm"][1], t["R_series_ohm"]
    assert fit["goodness"]["reduced_chi2"] > 1.5  # Tab. 1's over-dispersion, not iid scatter


def test_fit_physical_of_a_simulated_press_session_brackets_the_simulated_film_and_series(tmp_path, capsys):
    """The press (issue 27): ``fit --conversion physical`` used to refuse it ("describes the piston/liner rig, not a
    press"), though the design and the simulated bench model the press's resistance with the same physical terms
    (Barber's from the press stiffness, Holm's circular spot of the contact radius: specimen_resistance_terms). Now
    the fit subtracts those terms: on a simulated press session (iid re-seating, R_s = 0.2 mΩ) the 95 % t-interval
    brackets the simulated σ_f, and the terms' shares are reported (the intervals' coverage over many sessions:
    tests/analysis/test_simulated_session.py)."""
    import re
    from pathlib import Path

    from contactrig.cli.main import main
    from daq import load_session

    press = Path(__file__).resolve().parents[2] / "contactrig" / "scenes" / "press.toml"
    text = re.sub(r'(?m)^sim_noise = "tab1"', 'sim_noise = "iid"', press.read_text())
    text = re.sub(r"(?m)^series_resistance_ohm = .*$", "series_resistance_ohm = 2e-4", text)
    assert "series_resistance_ohm = 2e-4" in text and 'sim_noise = "iid"' in text
    scene = tmp_path / "press.toml"
    scene.write_text(text)
    session = tmp_path / "p.h5"
    assert main(["acquire", str(scene), "--sim", "--yes", "--quiet", "--sim-speed", "inf", "-o", str(session)]) == 0
    capsys.readouterr()
    argv = ["fit", str(session), "--conversion", "physical", "--bootstrap", "0", "--models", "greenwood_tripp"]
    assert main([*argv, "--json"]) == 0, capsys.readouterr().err
    fit = json.loads(capsys.readouterr().out)["models"]["greenwood_tripp"]
    t = fit["intervals"]["t"]
    circuit = load_session(session).start["simulation"]["circuit"]
    film = circuit["resistivity_ohm_m"] * circuit["contact_height_m"]  # ζ·h of the scene's [circuit]
    assert circuit["series_resistance_ohm"] == 2e-4
    assert t["scale"][0] <= film <= t["scale"][1], (t["scale"], film)
    assert t["R_series_ohm"][0] < t["R_series_ohm"][1]
    assert set(fit["shares"]) >= {"barber", "macro", "film"}
