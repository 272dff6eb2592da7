"""Load sweep, settings and the sweep file: contract names, validation, round trip, database integration."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.optimize import brentq

from contactrig.core.scene import load_scene, parse_scene
from contactrig.core.validation import SettingError
from daq.sweep_file import load_sweep, save_sweep
from sims.config import SimConfig
from sims.rig import ModelSweep, RigSettings, SweepResult, equilibrium, sweep
from sims.rig.settings import PAPER_WEIGHTS_KG, STANDARD_GRAVITY
from tests.sims.test_rig_laws import ExponentialLaw, GreenwoodTrippLaw, WinklerLaw

LAWS = {"exp": ExponentialLaw(), "gt": GreenwoodTrippLaw()}


def _cfg(scene) -> SimConfig:
    """The typed configuration every entry point of ``sims`` takes."""
    return SimConfig.from_scene(scene)


def _quad_equilibrium(curve, s: RigSettings, weight_kg: float, h_lo: float, h_hi: float) -> tuple[float, float]:
    """Minimum gap and real area from adaptive quadrature of the exact-gap integrals up to the curve's contact edge
    (found here by Brent's method on the offset-circle gap; the curve is ~0 beyond it)."""
    R_l, c, L, R_p = s.liner_radius_m, s.clearance_m, s.skirt_length_m, s.piston_radius_m

    def gap(t, h0):
        e = c - h0
        return R_l - e * math.cos(t) - math.sqrt(R_p**2 - (e * math.sin(t)) ** 2)

    def edge(h0):
        return brentq(lambda t: gap(t, h0) - curve.h_max, 0.0, 1.0, xtol=1e-15)

    def force(h0):
        integrand = lambda t: float(curve.pressure(gap(t, h0))) * math.cos(t)  # noqa: E731
        return 2 * R_p * L * quad(integrand, 0, edge(h0), limit=400, epsrel=1e-9)[0]

    h_ref = brentq(lambda h: force(h) - s.load_n(weight_kg), h_lo, h_hi, xtol=1e-17)
    area = quad(lambda t: float(curve.area_fraction_at(gap(t, h_ref))), 0, edge(h_ref), limit=400)[0]
    return h_ref, 2 * R_p * L * area


@pytest.fixture(scope="module")
def scene():
    return load_scene()


@pytest.fixture(scope="module")
def gt_sweep(scene):
    return sweep(_cfg(scene), models=["greenwood_tripp"])


def test_default_scene_settings_are_the_papers(scene):
    from importlib.resources import files

    s = RigSettings.from_scene(scene)
    # The seed paper's Tab. 1, as shipped with daq (an independent transcription of the paper).
    lines = files("daq").joinpath("data/tab1.csv").read_text().splitlines()[1:]
    tab1 = [float(line.split(",")[0]) for line in lines if line.strip()]
    assert list(s.weights_kg) == pytest.approx(tab1, abs=5e-5) and list(PAPER_WEIGHTS_KG) == list(s.weights_kg)
    assert s.piston_mass_kg == 0.0
    # "255 N (26 kg)": the heaviest Tab. 1 weight times g.
    assert s.load_n(max(s.weights_kg)) == pytest.approx(255.0, abs=0.5)


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("bore_m", 0.04, r"\[rig\] bore_m"),
        ("clearance_m", -1e-6, r"\[rig\] clearance_m"),
        ("clearance_m", 0.01, r"\[rig\] clearance_m"),
        ("liner_radius_m", "big", r"\[rig\] liner_radius_m"),
        ("mesh", "adaptive", r"\[rig\] mesh"),
        ("gap", "approx", r"\[rig\] gap"),
        ("n_theta", 1.5, r"\[rig\] n_theta"),
        ("weights_kg", [], r"\[rig\] weights_kg"),
        ("weights_kg", [1.0, math.nan], r"\[rig\] weights_kg\[1\]"),
        ("weights_kg", [-2.0], r"\[rig\] weights_kg\[0\]"),
        ("damping_n_s_per_m", -1.0, r"\[rig\] damping_n_s_per_m"),
        ("mesh_tol", 0.0, r"\[rig\] mesh_tol"),
    ],
)
def test_bad_rig_settings_name_the_key(key, value, match):
    with pytest.raises(SettingError, match=match):
        RigSettings.from_table({key: value})


def test_scene_with_unknown_rig_key_is_rejected_before_anything_is_built():
    text = load_scene().text.replace("[rig]\n", "[rig]\nbore_diameter_m = 0.084\n", 1)
    with pytest.raises(SettingError, match=r"\[rig\] bore_diameter_m"):
        sweep(_cfg(parse_scene(text)))


def test_sweep_with_given_laws_matches_single_equilibria():
    s = RigSettings(n_theta=8)
    weights = [20.0, 0.0, 5.0]
    result = sweep(settings=s, laws=LAWS, weights_kg=weights)
    assert isinstance(result, SweepResult) and set(result.models) == {"exp", "gt"}
    for name, law in LAWS.items():
        m = result.models[name]
        assert isinstance(m, ModelSweep)
        assert m.weight_kg.tolist() == weights  # given order kept
        for i, w in enumerate(weights):
            eq = equilibrium(law, s, w)
            assert m.contact_area_m2[i] == pytest.approx(eq.contact_area_m2, rel=1e-3, abs=1e-15)
            assert m.force_n[i] == pytest.approx(w * STANDARD_GRAVITY, rel=1e-9, abs=1e-12)
        assert m.contact_area_m2[1] == 0.0
        assert m.contact_area_m2[0] > m.contact_area_m2[2] > 0


def test_models_restricts_the_given_laws_and_unknown_names_fail():
    result = sweep(laws=LAWS, models=["gt"], weights_kg=[1.0])
    assert list(result.models) == ["gt"]
    with pytest.raises(ValueError, match="nope"):
        sweep(laws=LAWS, models=["nope"], weights_kg=[1.0])


def test_greenwood_tripp_sweep_from_the_database_against_quadrature(scene, gt_sweep):
    from sims.database import build_database

    m = gt_sweep.models["greenwood_tripp"]
    assert list(gt_sweep.models) == ["greenwood_tripp"]
    assert gt_sweep.provenance["database"]["models"] == ["greenwood_tripp"]  # only the asked-for model was built
    assert m.weight_kg.tolist() == list(PAPER_WEIGHTS_KG)
    assert np.all(np.diff(m.contact_area_m2) > 0) and np.all(np.diff(m.min_separation_m) < 0)
    assert np.all(m.converged)
    # Independent check of the heaviest weight: adaptive quadrature of the exact-gap integrals on the same curve
    # (Greenwood–Tripp's tail beyond its h_max = 6σ carries ~1e-8 of the load and area).
    curve = build_database(_cfg(scene), models=["greenwood_tripp"])["greenwood_tripp"]
    h_ref, a_ref = _quad_equilibrium(curve, RigSettings.from_scene(scene), PAPER_WEIGHTS_KG[-1], 0.0, 2e-6)
    assert m.min_separation_m[-1] == pytest.approx(h_ref, rel=1e-4)
    assert m.contact_area_m2[-1] == pytest.approx(a_ref, rel=1e-3)


def test_provenance_and_warnings(gt_sweep, scene):
    prov = gt_sweep.provenance
    assert prov["scene_text"] == scene.text
    assert prov["software_version"]
    assert prov["rig_settings"]["clearance_m"] == pytest.approx(40e-6)
    assert prov["database"]["greenwood_tripp"]["sigma_m"] > 0
    assert prov["line_contact_check"]["status"] == "converged"
    # The elastic bulk deflection the rigid-body model neglects, at the heaviest weight: a fraction of σ here.
    assert 0 < prov["bulk_deflection"]["greenwood_tripp"]["relative_to_sigma"] < 1
    # The roughness parameter check: α = πσE*/(4P′) for the heaviest weight is below the threshold in this scene.
    sigma, e_star = prov["roughness_m"], prov["composite_modulus_pa"]
    alpha = math.pi * sigma * e_star / (4 * RigSettings().load_n(25.966) / 0.045)
    assert (alpha < 5) == any("roughness parameter" in w and "25.966" in w for w in gt_sweep.warnings)


def test_save_and_load_round_trip(gt_sweep, tmp_path):
    path = save_sweep(gt_sweep, tmp_path / "sim.h5")
    back = load_sweep(path)
    for name, m in gt_sweep.models.items():
        for attr in ModelSweep.UNITS:
            assert np.array_equal(getattr(back.models[name], attr), getattr(m, attr)), attr
    assert back.warnings == gt_sweep.warnings
    assert back.provenance["scene_text"] == gt_sweep.provenance["scene_text"]
    with h5py.File(path) as f:
        assert f["models/greenwood_tripp/contact_area_m2"].attrs["units"] == "m^2"
        assert f.attrs["format"] == "contactrig-sweep"
        assert f["scene_text"][()].decode() == gt_sweep.provenance["scene_text"]
    assert not (tmp_path / "sim.h5.partial").exists()


def test_load_sweep_rejects_other_files(tmp_path):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    with pytest.raises(ValueError, match="not a contactrig sweep"):
        load_sweep(other)
    (tmp_path / "text.h5").write_text("hello")
    with pytest.raises(ValueError, match="not a readable HDF5"):
        load_sweep(tmp_path / "text.h5")
    with pytest.raises(FileNotFoundError):
        load_sweep(tmp_path / "missing.h5")


def test_zero_clearance_sweep_is_finite():
    s = RigSettings(clearance_m=0.0, n_theta=8)
    result = sweep(settings=s, laws={"winkler": WinklerLaw(h_c=0.2e-6, h_max=0.2e-6)}, weights_kg=[0.0, 10.0, 1e3])
    m = result.models["winkler"]
    assert np.all(np.isfinite(m.contact_area_m2)) and np.all(np.isfinite(m.min_separation_m))
    # With an exact fit and a law in contact at zero gap, the unloaded piston already touches all round (pre-load of
    # the fit); the load then pushes the minimum gap down and is carried exactly.
    assert m.contact_area_m2[0] > 0 and np.all(m.contact_area_m2 >= 0)
    assert np.all(np.diff(m.min_separation_m) < 0)
    assert np.allclose(m.force_n, np.array([0.0, 10.0, 1e3]) * STANDARD_GRAVITY, rtol=1e-9, atol=1e-9)
    assert np.all(m.force_n >= 0)
    assert any("pre-loaded fit" in n and n.startswith("winkler") for n in result.provenance["notes"])


def test_models_agree_when_elastic_and_differ_deep_in_the_plastic_regime(scene):
    # The paper's observation: at the Tab. 1 loads the asperities stay elastic and the models agree.
    hard = sweep(_cfg(scene), models=["hertz", "pasaribu_schipper"], weights_kg=[25.966])
    hz, ps = hard.models["hertz"].contact_area_m2, hard.models["pasaribu_schipper"].contact_area_m2
    assert abs(ps[0] - hz[0]) / hz[0] < 0.01
    # A soft piston alloy (H = 0.15 GPa) and a heavy load push the asperities far past yield: the plastic area
    # (2πRδ, seed eq. 20) is twice the elastic one (πRδ, eq. 15) at equal interference, and a plastic summit carries
    # less (H instead of the elastic pressure), so for the same load Pasaribu–Schipper's area exceeds Hertz's by more.
    text = scene.text.replace("H_pa = 1.2e9", "H_pa = 0.15e9")
    assert text != scene.text
    soft = sweep(_cfg(parse_scene(text)), models=["hertz", "pasaribu_schipper"], weights_kg=[3000.0])
    hz, ps = soft.models["hertz"].contact_area_m2, soft.models["pasaribu_schipper"].contact_area_m2
    assert ps[0] > 1.5 * hz[0]


def test_batch_solver_against_the_bessel_closed_form():
    from sims.rig import batch_equilibrium
    from tests.sims.test_rig_laws import exponential_area_m2, exponential_force_n

    law = ExponentialLaw()
    s = RigSettings(gap="small_clearance", n_theta=8, mesh_tol=1e-5)
    weights = [0.0, 1.0, 13.616, 500.0]
    batch = batch_equilibrium(law, s, weights)
    R, L, c = s.piston_radius_m, s.skirt_length_m, s.clearance_m
    for i, w in enumerate(weights):
        if w == 0:
            assert batch.contact_area_m2[i] == 0 and batch.min_separation_m[i] == c
            continue
        W = s.load_n(w)
        h_ref = brentq(lambda h, W=W: exponential_force_n(law, h, R, L, c) - W, -5e-6, 30e-6, xtol=1e-22)
        assert batch.min_separation_m[i] == pytest.approx(h_ref, rel=1e-6)
        assert batch.contact_area_m2[i] == pytest.approx(exponential_area_m2(law, h_ref, R, L, c), rel=1e-5)
    assert np.all(np.abs(batch.residual_n) <= 1e-8 * np.maximum(batch.load_n, 1.0))
    assert batch.law_calls > 0 and batch.iterations > 0 and batch.mesh_levels >= 2


def test_batch_solver_uniform_mesh_tail_law_and_overload():
    from sims.rig import RigLoadError, batch_equilibrium

    gt = GreenwoodTrippLaw()
    uni = RigSettings(mesh="uniform", n_theta=256, n_axial=1)
    batch = batch_equilibrium(gt, uni, [1e-6, 2.0])  # a tiny weight sits in the Greenwood–Tripp tail, h0 > h_max
    assert batch.mesh.kind == "uniform" and batch.n_nodes == 256 and batch.mesh_levels == 1
    assert batch.min_separation_m[0] > gt.h_max > batch.min_separation_m[1]
    assert np.allclose(batch.contact_force_n, batch.load_n, rtol=1e-9)
    capped = WinklerLaw(k=1e13, h_c=1e-6, h_max=1e-6, h_min=-1e-6, p_cap=1e5)
    with pytest.raises(RigLoadError, match="extend the database"):
        batch_equilibrium(capped, RigSettings(), [1.0, 100.0], name="capped")


@settings(max_examples=10, deadline=None)
@given(st.lists(st.floats(0.0, 2000.0), min_size=1, max_size=6))
def test_batch_solver_monotone_finite_and_balanced_for_any_weights(weights):
    from sims.rig import batch_equilibrium

    batch = batch_equilibrium(GreenwoodTrippLaw(), RigSettings(n_theta=8), weights)
    order = np.argsort(batch.weight_kg)
    area, gap = batch.contact_area_m2[order], batch.min_separation_m[order]
    assert np.all(np.isfinite(area)) and np.all(area >= 0) and np.all(np.isfinite(gap))
    assert np.all(np.diff(area) >= 0) and np.all(np.diff(gap) <= 0)
    assert np.all(np.abs(batch.residual_n) <= 1e-8 * np.maximum(batch.load_n, 1.0))
    assert np.all(batch.peak_pressure_pa >= 0) and np.all(batch.contact_width_m >= 0)


def test_database_is_extended_when_a_load_leaves_its_range(scene):
    # 3000 kg pushes the Greenwood–Tripp minimum gap below the scene's h_min_sigma = −1.5: the curve is rebuilt deeper.
    result = sweep(_cfg(scene), models=["greenwood_tripp"], weights_kg=[25.966, 3000.0])
    ext = result.provenance["database_extension"]
    assert ext["models"] == ["greenwood_tripp"] and ext["h_min_sigma"]["used"] < ext["h_min_sigma"]["scene"]
    assert any("database extended" in w for w in result.warnings)
    assert not any("extrapolated" in w for w in result.warnings)
    h = result.models["greenwood_tripp"].min_separation_m
    assert h[1] >= ext["h_min_sigma"]["used"] * result.provenance["database"]["greenwood_tripp"]["sigma_m"]
    # Beyond what the database allows (−3σ), the result stays extrapolated and says so.
    deep = sweep(_cfg(scene), models=["greenwood_tripp"], weights_kg=[3e5])
    assert any("extrapolated" in w and "greenwood_tripp" in w for w in deep.warnings)
    assert np.all(np.isfinite(deep.models["greenwood_tripp"].contact_area_m2))
    # A database handed in by the caller is not rebuilt: warning only.
    from sims.database import build_database

    given_db = build_database(_cfg(scene), models=["greenwood_tripp"])
    kept = sweep(_cfg(scene), weights_kg=[3000.0], database=given_db)
    assert "database_extension" not in kept.provenance
    assert any("extrapolated" in w for w in kept.warnings)


@pytest.mark.parametrize(
    ("old", "new"),
    [
        (("sq_m = 0.4e-6", "sq_m = 0.3e-6"), ("sq_m = 0.004e-6", "sq_m = 0.003e-6")),  # very smooth
        (("sq_m = 0.4e-6", "sq_m = 0.3e-6"), ("sq_m = 4e-6", "sq_m = 3e-6")),  # very rough
        (("E_pa = 110e9", "E_pa = 75e9"), ("E_pa = 1100e9", "E_pa = 1100e9")),  # very stiff
    ],
    ids=["smooth", "rough", "stiff"],
)
def test_extreme_scenes_give_finite_balanced_sweeps(scene, old, new):
    text = scene.text
    for a, b in zip(old, new, strict=True):
        assert a in text
        text = text.replace(a, b, 1)
    weights = [0.0, 5.44, 25.966, 500.0]
    result = sweep(_cfg(parse_scene(text)), models=["greenwood_tripp", "hertz"], weights_kg=weights)
    for m in result.models.values():
        assert np.all(np.isfinite(m.contact_area_m2)) and np.all(np.isfinite(m.min_separation_m))
        assert m.contact_area_m2[0] == 0 and np.all(np.diff(m.contact_area_m2) > 0)
        assert np.allclose(m.force_n, np.array(weights) * STANDARD_GRAVITY, rtol=1e-8)
        assert np.all(m.peak_pressure_pa >= 0)


def test_batch_mesh_budget_is_reported():
    from sims.rig import batch_equilibrium

    batch = batch_equilibrium(GreenwoodTrippLaw(), RigSettings(n_theta=4, mesh_tol=1e-12, max_nodes=40), [5.0, 20.0])
    assert not batch.converged.any() and batch.n_nodes <= 40
    assert any("max_nodes" in w for w in batch.warnings)
    assert np.allclose(batch.contact_force_n, batch.load_n, rtol=1e-9)


def test_batch_newton_does_not_fall_back_to_bisection_once_converged():
    # Regression: a weight whose Newton step fell below rounding was sent to bisection (x on its own bracket end),
    # restarting from mid-bracket at linear speed: 37 iterations instead of 11 on the paper's weights.
    from sims.rig import batch_equilibrium

    batch = batch_equilibrium(GreenwoodTrippLaw(), RigSettings(), PAPER_WEIGHTS_KG)
    assert batch.iterations <= 8 * batch.mesh_levels
    assert np.all(np.abs(batch.residual_n) <= 1e-9 * batch.load_n)


@pytest.mark.filterwarnings("ignore:The occurrence of roundoff error")  # quad on a tabulated, kinked curve
def test_asperity_sweep_from_the_database_against_quadrature(scene):
    # The variable mesh leaves out the skirt beyond the highest summit's contact edge (the law is zero there):
    # the area still meets mesh_tol against adaptive quadrature of the exact-gap integrals on the same curve.
    result = sweep(_cfg(scene), models=["hertz"], weights_kg=[25.966])
    from sims.database import build_database

    curve = build_database(_cfg(scene), models=["hertz"])["hertz"]
    s = RigSettings.from_scene(scene)
    h_ref, a_ref = _quad_equilibrium(curve, s, 25.966, 0.0, 0.99 * curve.h_max)
    m = result.models["hertz"]
    assert m.contact_area_m2[0] == pytest.approx(a_ref, rel=s.mesh_tol)
    assert m.min_separation_m[0] == pytest.approx(h_ref, rel=1e-4)
    assert result.provenance["solver"]["hertz"]["n_nodes"] <= 64  # zone cells only
