"""The contact database: GT and summed asperity curves against independent sums, interpolation, HDF5, scene
validation, CLI."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sims import greenwood_tripp as gt
from sims import surface
from sims.database import (
    ContactCurve,
    MissingModelError,
    build_database,
    load_database,
    save_database,
)
from sims.materials import Material, composite_modulus
from sims.scene import load_scene, parse_scene
from sims.validation import SettingError

SMALL = """
[scene]
name = "small"
[materials.liner]
E_pa = 110e9
nu = 0.26
H_pa = 2.0e9
[materials.piston]
E_pa = 75e9
nu = 0.33
H_pa = 1.2e9
[surfaces.liner]
kind = "gaussian"
n = 128
pixel_m = 10e-6
sq_m = 0.4e-6
correlation_m = 80e-6
seed = 1
[surfaces.piston]
kind = "gaussian"
n = 128
pixel_m = 10e-6
sq_m = 0.3e-6
correlation_m = 80e-6
seed = 2
[database]
models = ["greenwood_tripp", "hertz", "lagemann", "pasaribu_schipper", "jackson_green"]
n_separations = 64
h_min_sigma = -1.0
h_max_sigma = 6.0
"""


@pytest.fixture(scope="module")
def small_db():
    return build_database(parse_scene(SMALL))


def test_composite_modulus_eq4() -> None:
    steel, iron = Material(210e9, 0.30, 2e9), Material(110e9, 0.26, 2e9)
    assert composite_modulus(steel, iron) == pytest.approx(78.07e9, rel=1e-3)


def test_gt_curve_is_the_formula_and_interpolates_it(small_db) -> None:
    c = small_db["greenwood_tripp"]
    g = small_db.provenance["greenwood_tripp"]
    e_star = small_db.provenance["materials"]["E_star_pa"]
    kw = dict(sigma=g["sigma_m"], eta=g["eta_per_m2"], beta=g["beta_m"])
    np.testing.assert_allclose(c.pressure_pa, gt.pressure(c.separation_m, E_star=e_star, **kw), rtol=1e-12)
    mid = 0.5 * (c.separation_m[1:] + c.separation_m[:-1])
    np.testing.assert_allclose(c.pressure(mid), gt.pressure(mid, E_star=e_star, **kw), rtol=1e-4)
    np.testing.assert_allclose(c.area_fraction_at(mid), gt.area_fraction(mid, **kw), rtol=1e-4)
    assert g["sigma_m"] == pytest.approx(0.5e-6)


def test_asperity_curves_equal_an_independent_sum_over_summits(small_db) -> None:
    sc = parse_scene(SMALL)
    liner, piston = surface.surfaces_from_scene(sc)
    z = liner.heights() + piston.heights()
    peaks = surface.summits(z)
    ii, jj = np.nonzero(peaks)
    zc = z - z.mean()
    px = 10e-6
    # curvature by the 3-point stencil written out here, not taken from the module
    kx = -(np.roll(zc, -1, 0) - 2 * zc + np.roll(zc, 1, 0))[ii, jj] / px**2
    ky = -(np.roll(zc, -1, 1) - 2 * zc + np.roll(zc, 1, 1))[ii, jj] / px**2
    slope_x = ((np.roll(zc, -1, 0) - np.roll(zc, 1, 0)) / (2 * px))[ii, jj]
    slope_y = ((np.roll(zc, -1, 1) - np.roll(zc, 1, 1)) / (2 * px))[ii, jj]
    kappa = (kx / (1 + slope_x**2) ** 1.5 + ky / (1 + slope_y**2) ** 1.5) / 2
    radius, heights = 1 / kappa, zc[ii, jj]
    e_star = small_db.provenance["materials"]["E_star_pa"]
    area0 = z.size * px**2
    c = small_db["lagemann"]
    for k in (0, 20, 40, 62):
        h = c.separation_m[k]
        d = np.clip(heights - h, 0, None)
        p_ref = np.sum(4 / 3 * e_star * np.sqrt(radius) * d**1.5) / area0
        a_ref = np.sum(np.pi * radius * d) / area0
        assert c.pressure_pa[k] == pytest.approx(p_ref, rel=1e-9)
        assert c.area_fraction[k] == pytest.approx(a_ref, rel=1e-9)
    assert c.h_max == pytest.approx(heights.max(), rel=1e-12)
    # Stachowiak's Hertz differs from Johnson's by its rounded constant only
    np.testing.assert_allclose(small_db["hertz"].pressure_pa[:-1] / c.pressure_pa[:-1], 1.0, rtol=6e-4)


@pytest.mark.parametrize("name", ["greenwood_tripp", "hertz", "pasaribu_schipper", "jackson_green"])
def test_curves_monotone_smooth_with_analytic_slope(small_db, name: str) -> None:
    c = small_db[name]
    h = np.linspace(c.h_min - 0.3e-6, c.h_max + 0.3e-6, 20001)
    p, dp, a = c.pressure(h), c.dpressure_dh(h), c.area_fraction_at(h)
    assert np.all(np.isfinite(p)) and p.min() >= 0 and np.all(np.diff(p) <= 0)
    assert np.all(dp <= 0) and a.min() >= 0 and a.max() <= 1 and np.all(np.diff(a) <= 0)
    num = np.gradient(p, h)
    scale = np.abs(dp) + 1e-6 * np.abs(dp).max()
    smooth = np.abs(h - c.h_max) > 2 * (h[1] - h[0])  # the contact onset of asperity curves is a kink
    assert np.max((np.abs(num - dp) / scale)[5:-5][smooth[5:-5]]) < 1e-2
    assert c.in_range(c.h_min) and not c.in_range(c.h_min - 1e-9)
    if name != "greenwood_tripp":
        assert c.pressure(c.h_max + 1e-9) == 0.0 and c.pressure_pa[-1] == 0.0


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(min_value=-1e-3, max_value=1e-3), min_size=1, max_size=20))
def test_curve_finite_for_any_separation(small_db, hs: list[float]) -> None:
    for c in small_db.values():
        p = c.pressure(hs)
        assert np.all(np.isfinite(p)) and np.all(p >= 0)
        assert np.all(np.isfinite(c.dpressure_dh(hs)))


def test_only_requested_models_are_built_and_gt_needs_no_surface(monkeypatch) -> None:
    def boom(self):
        raise AssertionError("a surface was generated for a statistics-only model")

    monkeypatch.setattr(surface.SurfaceSpec, "heights", boom)
    db = build_database(parse_scene(SMALL), models=["greenwood_tripp"])
    assert list(db) == ["greenwood_tripp"]
    with pytest.raises(MissingModelError) as err:
        db["hertz"]
    assert isinstance(err.value, ValueError) and isinstance(err.value, KeyError)


def test_save_load_round_trip(small_db, tmp_path) -> None:
    import h5py

    path = save_database(small_db, tmp_path / "db.h5")
    with h5py.File(path) as f:
        assert set(f) == set(small_db)
        for g in f.values():
            assert {k: g[k].attrs["units"] for k in g} == {
                "separation_m": "m",
                "pressure_pa": "Pa",
                "area_fraction": "1",
            }
    back = load_database(path)
    assert list(back) == list(small_db)
    for name in small_db:
        np.testing.assert_array_equal(back[name].pressure_pa, small_db[name].pressure_pa)
        h = np.linspace(back[name].h_min, back[name].h_max, 7)
        np.testing.assert_array_equal(back[name].pressure(h), small_db[name].pressure(h))
    assert back.provenance["scene_name"] == "small" and back.provenance["software_version"]
    with pytest.raises(SettingError):
        load_database(tmp_path / "missing.h5")


def test_contact_curve_rejects_bad_tables() -> None:
    h = np.array([0.0, 1.0, 2.0])
    with pytest.raises(SettingError):
        ContactCurve("x", h, np.array([1.0, 2.0, 0.5]), np.array([0.1, 0.05, 0.01]))
    with pytest.raises(SettingError):
        ContactCurve("x", h, np.array([1.0, 0.5, 0.1]), np.array([1.5, 0.05, 0.01]))
    with pytest.raises(SettingError):
        ContactCurve("x", h[::-1], np.array([1.0, 0.5, 0.1]), np.array([0.1, 0.05, 0.01]))


@pytest.mark.parametrize(
    ("table", "line", "field"),
    [
        ("[database]", "bogus = 1", "database.bogus"),
        ("[database]", "n_separations = 3", "database.n_separations"),
        ("[materials.liner]", "E_gpa = 1", "materials.liner.E_gpa"),
        ("[materials.piston]", "nu = 0.7", "materials.piston.nu"),
        ("[surfaces.liner]", "hurst = 0.5", "surfaces.liner.hurst"),
    ],
)
def test_scene_errors_name_the_key(table: str, line: str, field: str) -> None:
    text = SMALL.replace(table + "\n", table + "\n" + line + "\n", 1)
    if "n_separations = 3" in line:
        text = text.replace("n_separations = 64\n", "")
    if "nu = 0.7" in line:
        text = text.replace("nu = 0.33\n", "")
    with pytest.raises(SettingError) as err:
        build_database(parse_scene(text), models=["greenwood_tripp"])
    assert err.value.field == field


def test_asperity_models_need_one_grid_but_gt_does_not() -> None:
    text = SMALL.replace("n = 128\npixel_m = 10e-6\nsq_m = 0.3e-6", "n = 64\npixel_m = 10e-6\nsq_m = 0.3e-6")
    assert list(build_database(parse_scene(text), models=["greenwood_tripp"])) == ["greenwood_tripp"]
    with pytest.raises(SettingError, match="one grid"):
        build_database(parse_scene(text), models=["hertz"])


def test_default_scene_covers_the_rig_and_is_elastic_dominated() -> None:
    db = build_database(load_scene(None), models=["greenwood_tripp", "pasaribu_schipper"])
    # 5–26 kg on tens of mm² of nominal area: ~0.5 to ~15 MPa must lie inside every curve's range
    for c in db.values():
        assert c.pressure_pa[0] > 15e6 and c.pressure(c.h_max) < 0.5e6
    assert db.provenance["plasticity_index"] < 0.6
    # at 15 MPa nominal pressure most contacting summits are still below Pasaribu–Schipper's ω_c1
    c = db["pasaribu_schipper"]
    h15 = c.separation_m[np.argmin(np.abs(c.pressure_pa - 15e6))]
    liner, piston = surface.surfaces_from_scene(load_scene(None))
    d = surface.summit_data(liner.heights() + piston.heights(), liner.pixel_m)
    mats = db.provenance["materials"]
    w1 = 0.89 * d.radius_m * (mats["H_pa"] / mats["E_star_pa"]) ** 2
    contacting = d.height_m > h15
    assert np.mean((d.height_m - h15)[contacting] < w1[contacting]) > 0.5


def test_cli_database(tmp_path) -> None:
    from daq.cli import main

    out = tmp_path / "db.h5"
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL)
    assert main(["database", str(scene), "-o", str(out), "--models", "greenwood_tripp,hertz"]) == 0
    assert list(load_database(out)) == ["greenwood_tripp", "hertz"]
    assert main(["database", str(scene), "-o", str(out), "--models", "nope"]) == 2


def test_cli_plot(tmp_path) -> None:
    from daq.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL)
    png = tmp_path / "fig2.png"
    assert main(["database", str(scene), "-o", str(tmp_path / "d.h5"), "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000


def test_commands_import_nothing_heavy() -> None:
    code = "import sys, sims.commands, sims.database; print({'h5py', 'matplotlib', 'pyvisa'} & set(sys.modules))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "set()"


def test_gt_pair_formula_uses_geometric_means(small_db) -> None:
    p = small_db.provenance
    eta = math.sqrt(p["surfaces"]["liner"]["mccool"]["eta"] * p["surfaces"]["piston"]["mccool"]["eta"])
    assert p["greenwood_tripp"]["eta_per_m2"] == pytest.approx(eta)


def test_measured_and_self_affine_surfaces_in_a_scene(tmp_path) -> None:
    rng = np.random.default_rng(1)
    for name in ("liner", "piston"):
        z = surface.gaussian(64, pixel_m=10e-6, sq_m=0.4e-6, correlation_m=80e-6, seed=int(rng.integers(100)))
        (tmp_path / f"{name}.csv").write_text("\n".join(",".join(f"{v * 1e6:.9f}" for v in row) for row in z))
    text = SMALL
    for name in ("liner", "piston"):
        start = text.index(f"[surfaces.{name}]")
        end = text.index("[", start + 2)
        text = (
            text[:start]
            + f'[surfaces.{name}]\nkind = "file"\npath = "{name}.csv"\npixel_m = 10e-6\nheight_unit_m = 1e-6\n'
            + text[end:]
        )
    scene_file = tmp_path / "measured.toml"
    scene_file.write_text(text)
    db = build_database(load_scene(scene_file), models=["greenwood_tripp", "hertz"])
    assert db.provenance["surfaces"]["liner"]["sq_m"] == pytest.approx(0.4e-6, rel=0.05)
    assert db["hertz"].pressure_pa[0] > 0
    affine = SMALL.replace("correlation_m = 80e-6\nseed = 1", "hurst = 0.8\ncutoff_m = 40e-6\nseed = 1")
    affine = affine.replace(
        'kind = "gaussian"\nn = 128\npixel_m = 10e-6\nsq_m = 0.4e-6',
        'kind = "self_affine"\nn = 128\npixel_m = 10e-6\nsq_m = 0.4e-6',
    )
    db2 = build_database(parse_scene(affine), models=["greenwood_tripp", "jackson_green"])
    assert db2.provenance["surfaces"]["liner"]["kind"] == "self_affine"
    assert np.all(np.diff(db2["jackson_green"].pressure_pa) <= 0)
